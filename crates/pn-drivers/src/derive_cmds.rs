//! `pn latex`, `pn equations`, `pn supplemental`: the derived P_N equations.
use std::io::Write;
use std::path::PathBuf;

use anyhow::{bail, Context};
use pn_codegen::derive::{self, general, render, MAX_ORDER};

/// What `pn latex` prints.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct LatexRequest {
    /// Order N of the expanded system (1 ≤ N ≤ 60); give this or `general`.
    pub order: Option<i64>,
    /// The general equations for symbolic (l, m) (cases m < 0, m = 0, m > 0).
    pub general: bool,
    /// A complete LaTeX document instead of the equation blocks only.
    pub standalone: bool,
}

/// What `pn equations` prints.
///
/// With `json` the output is a list of equations `{"l", "m", "terms": [...]}`, one per
/// moment in the order l(l+1)+m; each equation reads **Σ terms = 0** (see `pn equations
/// --help` for the fields).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct EquationsRequest {
    /// Order N (1 ≤ N ≤ 60).
    pub order: i64,
    /// JSON instead of one readable line per equation.
    pub json: bool,
}

/// Where `pn supplemental` writes.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct SupplementalRequest {
    /// Output directory (created if missing); the document is `<out>/supplemental.tex`.
    pub out: PathBuf,
}

impl Default for SupplementalRequest {
    /// `supplemental/`.
    fn default() -> Self {
        Self {
            out: PathBuf::from("supplemental"),
        }
    }
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

/// Runs `pn latex`, printing to `stdout`.
pub fn latex(args: &LatexRequest, stdout: &mut dyn Write) -> anyhow::Result<()> {
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
        write!(stdout, "{}", render::standalone(&title, &body))?;
    } else {
        write!(stdout, "{body}")?;
    }
    Ok(())
}

/// Runs `pn equations`, printing to `stdout`.
pub fn equations(args: &EquationsRequest, stdout: &mut dyn Write) -> anyhow::Result<()> {
    let sys = derive::real_pn_system(order(args.order)?)?;
    if args.json {
        writeln!(
            stdout,
            "{}",
            serde_json::to_string_pretty(&render::system_json(&sys))?
        )?;
    } else {
        for eq in &sys.equations {
            writeln!(stdout, "{}", render::equation_text(eq))?;
        }
    }
    Ok(())
}

/// Runs `pn supplemental`, naming the written file on `stdout`.
pub fn supplemental(args: &SupplementalRequest, stdout: &mut dyn Write) -> anyhow::Result<()> {
    let doc = pn_codegen::derive::supplemental::document()?;
    std::fs::create_dir_all(&args.out)
        .with_context(|| format!("creating {}", args.out.display()))?;
    let path = args.out.join("supplemental.tex");
    std::fs::write(&path, doc).with_context(|| format!("writing {}", path.display()))?;
    writeln!(stdout, "wrote {}", path.display())?;
    Ok(())
}
