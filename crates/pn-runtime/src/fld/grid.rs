//! The uniform cell-centred grid and the diffusion problem posed on it.

use anyhow::{bail, ensure, Result};

/// A uniform cell-centred 3D grid: `n[0]×n[1]×n[2]` cubic cells of edge `h`.
///
/// Cell `(i, j, k)` (x, y, z indices) is stored at [`FldGrid::index`]
/// `(i·n[1] + j)·n[2] + k`: x slowest, z fastest — the C order of an array of shape
/// `(nx, ny, nz)`, the same layout as `crate::field::VoxelGrid`.
///
/// The outermost layer of cells carries the Dirichlet boundary value; the unknowns are the
/// interior cells, so every axis needs at least 3 cells.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FldGrid {
    /// Cells per axis (x, y, z).
    pub n: [usize; 3],
    /// Cell edge length (the same on every axis).
    pub h: f64,
}

impl FldGrid {
    /// Creates a grid, checking `n[d] ≥ 3` and `h` finite and positive.
    pub fn new(n: [usize; 3], h: f64) -> Result<Self> {
        let g = Self { n, h };
        g.validate()?;
        Ok(g)
    }

    /// A cubic grid of `n³` cells spanning an edge of length `length`.
    pub fn cube(n: usize, length: f64) -> Result<Self> {
        ensure!(n > 0, "grid must have at least one cell per axis");
        Self::new([n; 3], length / n as f64)
    }

    /// Checks the invariants documented on [`FldGrid::new`].
    pub fn validate(&self) -> Result<()> {
        ensure!(
            self.n.iter().all(|&m| m >= 3),
            "FLD grid needs at least 3 cells per axis (one boundary layer on each side), got {:?}",
            self.n
        );
        ensure!(
            self.h.is_finite() && self.h > 0.0,
            "FLD grid spacing must be finite and positive, got {}",
            self.h
        );
        ensure!(
            self.n[0]
                .checked_mul(self.n[1])
                .and_then(|m| m.checked_mul(self.n[2]))
                .is_some(),
            "FLD grid {:?} is too large",
            self.n
        );
        Ok(())
    }

    /// Total number of cells.
    pub fn len(&self) -> usize {
        self.n[0] * self.n[1] * self.n[2]
    }

    /// Whether the grid has no cells (never true for a validated grid).
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Linear index of cell `(i, j, k)`.
    #[inline]
    pub fn index(&self, i: usize, j: usize, k: usize) -> usize {
        (i * self.n[1] + j) * self.n[2] + k
    }

    /// Cell `(i, j, k)` of a linear index.
    #[inline]
    pub fn cell(&self, idx: usize) -> [usize; 3] {
        let k = idx % self.n[2];
        let j = (idx / self.n[2]) % self.n[1];
        let i = idx / (self.n[1] * self.n[2]);
        [i, j, k]
    }

    /// Whether `(i, j, k)` lies in the outermost (Dirichlet) layer.
    #[inline]
    pub fn is_boundary(&self, [i, j, k]: [usize; 3]) -> bool {
        i == 0 || j == 0 || k == 0 || i + 1 == self.n[0] || j + 1 == self.n[1] || k + 1 == self.n[2]
    }

    /// Centre of cell `(i, j, k)` relative to the grid's lower corner.
    pub fn centre(&self, [i, j, k]: [usize; 3]) -> [f64; 3] {
        [
            (i as f64 + 0.5) * self.h,
            (j as f64 + 0.5) * self.h,
            (k as f64 + 0.5) * self.h,
        ]
    }

    /// Edge length of the domain along its longest axis.
    pub fn max_extent(&self) -> f64 {
        self.n[0].max(self.n[1]).max(self.n[2]) as f64 * self.h
    }
}

/// A steady diffusion problem `−∇·(D ∇φ) + σ_a φ = q` on a [`FldGrid`].
///
/// All fields are cell-centred, in the grid's index order. `sigma_t` is the extinction used in
/// the diffusion coefficient (pass the transport coefficient `σ_t − g σ_s` for anisotropic
/// scattering, cf. docs/design.md §2.2); `sigma_a` the absorption; `source` the isotropic emission
/// density q (power per volume; a unit-power point source in one cell is `q = 1/h³`), so that
/// φ is the fluence.
#[derive(Debug, Clone, PartialEq)]
pub struct FldProblem {
    /// The grid.
    pub grid: FldGrid,
    /// Extinction coefficient σ_t per cell (0 is vacuum).
    pub sigma_t: Vec<f64>,
    /// Absorption coefficient σ_a per cell, `0 ≤ σ_a ≤ σ_t`.
    pub sigma_a: Vec<f64>,
    /// Emission density q per cell, `q ≥ 0`.
    pub source: Vec<f64>,
}

impl FldProblem {
    /// Checks the grid, the field lengths and that every coefficient is finite, non-negative
    /// and `σ_a ≤ σ_t`.
    pub fn validate(&self) -> Result<()> {
        self.grid.validate()?;
        let len = self.grid.len();
        for (name, field) in [
            ("sigma_t", &self.sigma_t),
            ("sigma_a", &self.sigma_a),
            ("source", &self.source),
        ] {
            ensure!(
                field.len() == len,
                "FLD field {name} has {} values, grid {:?} needs {len}",
                field.len(),
                self.grid.n
            );
            if let Some((idx, v)) = field
                .iter()
                .enumerate()
                .find(|(_, v)| !(v.is_finite() && **v >= 0.0))
            {
                bail!(
                    "FLD field {name} must be finite and non-negative, got {v} at cell {:?}",
                    self.grid.cell(idx)
                );
            }
        }
        if let Some(idx) = (0..len).find(|&c| self.sigma_a[c] > self.sigma_t[c]) {
            bail!(
                "sigma_a ({}) exceeds sigma_t ({}) at cell {:?}",
                self.sigma_a[idx],
                self.sigma_t[idx],
                self.grid.cell(idx)
            );
        }
        Ok(())
    }

    /// The RMS of the source over all cells, `j̄ = √(Σ q²/N)`.
    pub fn rms_source(&self) -> f64 {
        let n = self.source.len().max(1) as f64;
        (self.source.iter().map(|q| q * q).sum::<f64>() / n).sqrt()
    }
}
