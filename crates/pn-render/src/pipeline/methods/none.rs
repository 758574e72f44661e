//! Single scattering only: no multiple-scattering solution, the renderer's first scatter is
//! the whole image.

use super::{MsSolution, MultipleScattering, PreparedScene};
use anyhow::Result;

/// No multiple scattering (`method = "none"`).
pub struct SingleScatteringOnly;

impl MultipleScattering for SingleScatteringOnly {
    fn name(&self) -> &str {
        "none"
    }

    fn solve(&self, _: &PreparedScene<'_>) -> Result<MsSolution> {
        Ok(MsSolution::default())
    }
}
