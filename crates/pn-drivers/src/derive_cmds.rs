//! `pn latex`, `pn equations`, `pn supplemental`: the derived P_N equations.
use std::path::PathBuf;

use anyhow::{bail, Context};
use clap::Args;
use pn_codegen::derive::{self, general, render, MAX_ORDER};

/// Arguments of `pn latex`.
#[derive(Args, Debug)]
#[command(group(clap::ArgGroup::new("what").required(true).args(["order", "general"])))]
pub struct LatexArgs {
    /// Order N of the expanded system to print (1 ≤ N ≤ 60).
    #[arg(long, allow_negative_numbers = true)]
    pub order: Option<i64>,
    /// Print the general equations for symbolic (l, m) (cases m < 0, m = 0, m > 0).
    #[arg(long)]
    pub general: bool,
    /// Print a complete LaTeX document instead of the equation blocks only.
    #[arg(long)]
    pub standalone: bool,
}

/// Arguments of `pn equations`.
///
/// With `--json` the output is a list of equations `{"l", "m", "terms": [...]}`, one per
/// moment in the order l(l+1)+m. Each equation reads **Σ terms = 0**: the sum over its terms
/// of `coefficient · factor · [∂_axis] X_l^m` vanishes, with X = L for the kinds
/// "derivative", "collision", "scattering" and X = Q for "source" (whose coefficient is −1,
/// i.e. `lhs = Q_l^m`). A term has `kind`, `axis` (derivatives only), `l`, `m` (the moment it
/// multiplies), `coefficient` (float), `exact` (text such as `-1/3*sqrt(6)`) and `factor`
/// (`1`, `sigma_t`, or `sigma_s*lambda_l*p_l`).
#[derive(Args, Debug)]
#[command(verbatim_doc_comment)]
pub struct EquationsArgs {
    /// Order N (1 ≤ N ≤ 60).
    #[arg(long, allow_negative_numbers = true)]
    pub order: i64,
    /// Print JSON (see the command help for the format: each equation is Σ terms = 0).
    #[arg(long)]
    pub json: bool,
}

/// Arguments of `pn supplemental`.
#[derive(Args, Debug)]
pub struct SupplementalArgs {
    /// Output directory (created if missing); the document is written to
    /// `<out>/supplemental.tex`.
    #[arg(long, default_value = "supplemental")]
    pub out: PathBuf,
}

/// Validates a user-given order.
fn order(n: i64) -> anyhow::Result<usize> {
    if n < 1 {
        bail!("--order must be at least 1 (got {n}): P_N needs N ≥ 1");
    }
    if n as u64 > MAX_ORDER as u64 {
        bail!("--order {n} is too large: the maximum supported order is {MAX_ORDER}");
    }
    Ok(n as usize)
}

/// Runs `pn latex`.
pub fn latex(args: &LatexArgs) -> anyhow::Result<()> {
    let (title, body) = match (args.general, args.order) {
        (true, Some(_)) => bail!("give either --order N or --general, not both"),
        (true, None) => (
            "General real P$_N$ equations".to_string(),
            render::general_latex(&general::general_equations(false)?),
        ),
        (false, Some(n)) => {
            let n = order(n)?;
            (
                format!("Real P$_{{{n}}}$ equations"),
                render::system_latex(&derive::real_pn_system(n)?),
            )
        }
        (false, None) => bail!("give --order N or --general"),
    };
    if args.standalone {
        print!("{}", render::standalone(&title, &body));
    } else {
        print!("{body}");
    }
    Ok(())
}

/// Runs `pn equations`.
pub fn equations(args: &EquationsArgs) -> anyhow::Result<()> {
    let sys = derive::real_pn_system(order(args.order)?)?;
    if args.json {
        println!(
            "{}",
            serde_json::to_string_pretty(&render::system_json(&sys))?
        );
    } else {
        for eq in &sys.equations {
            println!("{}", render::equation_text(eq));
        }
    }
    Ok(())
}

/// Runs `pn supplemental`.
pub fn supplemental(args: &SupplementalArgs) -> anyhow::Result<()> {
    let doc = pn_codegen::derive::supplemental::document()?;
    std::fs::create_dir_all(&args.out)
        .with_context(|| format!("creating {}", args.out.display()))?;
    let path = args.out.join("supplemental.tex");
    std::fs::write(&path, doc).with_context(|| format!("writing {}", path.display()))?;
    println!("wrote {}", path.display());
    Ok(())
}
