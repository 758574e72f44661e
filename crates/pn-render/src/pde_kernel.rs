//! PDE text files (docs/pde-text.md): reading one with its parameter overrides (errors name
//! the file, line and column) and the 3D stencil that `pn render --pde` solves
//! ([`PdeKernel`]).

use anyhow::Context;
use pn_codegen::text::{parse_pde, TextPde};
use std::path::Path;

/// Reads and parses the PDE file `path` with the `NAME=VALUE` overrides `params`. Errors
/// read `FILE:LINE:COLUMN: reason`.
pub fn load(path: &Path, params: &[(String, String)]) -> anyhow::Result<TextPde> {
    let src = pn_formats::read_text(path)
        .with_context(|| format!("reading the PDE file {}", path.display()))?;
    parse_pde(&src, params).map_err(|e| {
        if e.line == 0 {
            anyhow::anyhow!("{}: {}", path.display(), e.message)
        } else {
            anyhow::anyhow!("{}:{}:{}: {}", path.display(), e.line, e.col, e.message)
        }
    })
}

/// A text PDE's 3D stencil for `pn render --pde`, with what the renderer must ignore.
#[derive(Clone, Debug)]
pub struct PdeKernel {
    /// The PDE's name (`pde NAME`).
    pub name: String,
    /// The 3D stencil (compiled or interpreted).
    pub choice: pn_kernels::KernelChoice,
    /// Storage slots `l(l+1)+m` of the auxiliary unknowns.
    pub auxiliary_slots: Vec<usize>,
    /// The highest band of the source moments Q_l^m the system reads (0 when it reads
    /// Q_0^0 only, or none): `pn render` computes the first-scatter source up to it.
    pub source_band: u32,
}

impl PartialEq for PdeKernel {
    /// Same PDE name, same stencil name, same auxiliary slots and source band.
    fn eq(&self, other: &Self) -> bool {
        self.name == other.name
            && self.choice.kernel.name() == other.choice.kernel.name()
            && self.auxiliary_slots == other.auxiliary_slots
            && self.source_band == other.source_band
    }
}

impl PdeKernel {
    /// Loads `path` ([`load`]) and builds its 3D stencil.
    pub fn load(path: &Path, params: &[(String, String)]) -> anyhow::Result<PdeKernel> {
        let pde = load(path, params)?;
        let ir = pde
            .ir(pn_kernels::Dim::Three)
            .map_err(|e| anyhow::anyhow!("PDE {}: {e}", pde.system.name))
            .with_context(|| format!("{}", path.display()))?;
        let source_band = ir.max_source_band().unwrap_or(0);
        let choice = pn_kernels::pde_ir_kernel(ir);
        Ok(PdeKernel {
            source_band,
            name: pde.system.name.clone(),
            choice,
            auxiliary_slots: pde
                .unknowns
                .iter()
                .filter(|u| !u.radiance)
                .map(|u| (u.label.0 * (u.label.0 + 1) + u.label.1) as usize)
                .collect(),
        })
    }

    /// Sets the auxiliary unknowns of `moments` to zero.
    pub fn zero_auxiliary(&self, moments: &mut pn_runtime::CellMoments) {
        let per = moments.per_cell;
        for cell in moments.data.chunks_mut(per) {
            for &s in &self.auxiliary_slots {
                if s < per {
                    cell[s] = 0.0;
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The first-scatter bands a render computes for each shipped PDE: filtered P_N reads
    /// Q_l^m up to l = N (the P_N equations it includes), SP_3 and CDA Q_0^0 only.
    #[test]
    fn shipped_pdes_read_the_source_bands_they_reference() {
        let pdes = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../pdes");
        let band = |file: &str, params: &[(&str, &str)]| {
            let params: Vec<(String, String)> = params
                .iter()
                .map(|(k, v)| (k.to_string(), v.to_string()))
                .collect();
            PdeKernel::load(&pdes.join(file), &params)
                .unwrap()
                .source_band
        };
        assert_eq!(band("fpn.pde", &[]), 3);
        assert_eq!(band("fpn.pde", &[("N", "5")]), 5);
        assert_eq!(band("sp3.pde", &[]), 0);
        assert_eq!(band("cda.pde", &[]), 0);
    }
}
