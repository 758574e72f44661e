//! Diffusion coefficients on the cell faces of an [`FldGrid`].

use anyhow::{ensure, Result};

use super::grid::FldGrid;

/// One diffusion coefficient per cell face: `d[c][a]` is `D_f` on the face between cell `c`
/// and its neighbour `c + e_a` along axis `a` (x, y, z) — the cell's upper face. Faces on the
/// upper domain boundary (no neighbour) hold 0 and are never used: every face of an interior
/// cell is the upper face of some cell of the grid.
///
/// The red–black solver and the Picard route both read `D_f` from here, so they discretise the
/// same operator (`operator.rs` documents how `D_f` is computed).
#[derive(Debug, Clone, PartialEq)]
pub struct FaceCoefficients {
    /// The grid.
    pub grid: FldGrid,
    /// Upper-face coefficients per cell, in the grid's index order.
    pub d: Vec<[f64; 3]>,
}

impl FaceCoefficients {
    /// All faces zero.
    pub fn zeros(grid: FldGrid) -> Self {
        Self {
            grid,
            d: vec![[0.0; 3]; grid.len()],
        }
    }

    /// `D_f` on the face of cell `cell` at half-cell offset `±1` along `axis` (`upper` for
    /// +1), or `None` if that face lies on the domain boundary.
    pub fn at(&self, cell: [usize; 3], axis: usize, upper: bool) -> Option<f64> {
        let n = self.grid.n;
        if upper {
            (cell[axis] + 1 < n[axis])
                .then(|| self.d[self.grid.index(cell[0], cell[1], cell[2])][axis])
        } else {
            if cell[axis] == 0 {
                return None;
            }
            let mut lower = cell;
            lower[axis] -= 1;
            Some(self.d[self.grid.index(lower[0], lower[1], lower[2])][axis])
        }
    }

    /// Checks the length and that every coefficient is finite and non-negative.
    pub fn validate(&self) -> Result<()> {
        ensure!(
            self.d.len() == self.grid.len(),
            "face diffusion coefficients have {} cells, grid {:?} needs {}",
            self.d.len(),
            self.grid.n,
            self.grid.len()
        );
        if let Some(idx) = self
            .d
            .iter()
            .position(|f| f.iter().any(|v| !(v.is_finite() && *v >= 0.0)))
        {
            anyhow::bail!(
                "face diffusion coefficient {:?} at cell {:?} is not finite and non-negative",
                self.d[idx],
                self.grid.cell(idx)
            );
        }
        Ok(())
    }
}
