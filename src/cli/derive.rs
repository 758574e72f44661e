//! `pn latex`, `pn equations`, `pn supplemental`: their arguments.

use clap::Args;
use pn_drivers::derive_cmds::{EquationsRequest, LatexRequest, SupplementalRequest};
use std::path::PathBuf;

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

impl LatexArgs {
    /// The driver's request.
    pub fn request(&self) -> LatexRequest {
        LatexRequest {
            order: self.order,
            general: self.general,
            standalone: self.standalone,
        }
    }
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

impl EquationsArgs {
    /// The driver's request.
    pub fn request(&self) -> EquationsRequest {
        EquationsRequest {
            order: self.order,
            json: self.json,
        }
    }
}

/// Arguments of `pn supplemental`.
#[derive(Args, Debug)]
pub struct SupplementalArgs {
    /// Output directory (created if missing); the document is written to
    /// `<out>/supplemental.tex`.
    #[arg(long, default_value = "supplemental")]
    pub out: PathBuf,
}

impl SupplementalArgs {
    /// The driver's request.
    pub fn request(&self) -> SupplementalRequest {
        SupplementalRequest {
            out: self.out.clone(),
        }
    }
}
