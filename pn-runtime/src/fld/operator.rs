//! The discrete FLD operator: cell diffusion coefficients, the 7-point residual, red–black
//! SOR half-sweeps and the discrete flux.
//!
//! Discretisation (cell-centred finite volumes on the uniform grid, spacing h):
//!
//! ```text
//!   Σ_faces D_f (φ_c − φ_nb) / h²  +  σ_a,c φ_c  =  q_c          (interior cells c)
//!   D_f = ½ (D_c + D_nb)                                           (face between c and nb)
//!   D_c = F(R_c) / max(σ_t,c, σ_ε)
//!   R_c = max(|∇φ|_c, ε j̄) / (max(σ_t,c, σ_ε) · max(φ_c, ε j̄ h))
//! ```
//!
//! `D = F(R)/max(σ_t, σ_ε)` and the Knudsen number with lower bounds on `|∇φ|` and `φ` follow
//! Koerner et al. 2014 as summarised in issue 6. Our choices, where that summary leaves
//! details open:
//! * `∇φ` at a cell uses central differences (one-sided in the boundary layer);
//! * the face coefficient is the arithmetic mean of the two cell coefficients (the same rule
//!   DESIGN.md §3 uses for voxel fields at staggered positions, so a Picard iteration through
//!   the generated stencil with the cell field D sees the same operator);
//! * the φ bound is `ε j̄ h` rather than `ε j̄`: the two coincide in voxel units (h = 1), and
//!   with h the bound has the units of φ and equals the Dirichlet boundary value.
//!
//! Everything is parallel over x-planes with rayon; all reductions are summed per plane and
//! then sequentially, so results do not depend on the thread count.

use rayon::prelude::*;

use super::grid::{FldGrid, FldProblem};
use super::limiter::Limiter;
use super::params::FldParams;

/// A validated problem with its derived constants (j̄, bounds, boundary value).
pub(crate) struct Operator<'a> {
    pub grid: FldGrid,
    sigma_t: &'a [f64],
    sigma_a: &'a [f64],
    source: &'a [f64],
    limiter: Limiter,
    sigma_eps: f64,
    /// Lower bound on |∇φ| in the Knudsen number: ε j̄.
    grad_floor: f64,
    /// Lower bound on φ in the Knudsen number: ε j̄ h.
    phi_floor: f64,
    /// Dirichlet value on the outermost cell layer: ε j̄ h.
    pub phi_boundary: f64,
    /// RMS source over all cells.
    pub rms_source: f64,
}

impl<'a> Operator<'a> {
    /// Validates `problem` and `params` and precomputes the constants.
    pub fn new(problem: &'a FldProblem, params: &FldParams) -> anyhow::Result<Self> {
        problem.validate()?;
        params.validate(problem)?;
        let rms_source = problem.rms_source();
        let h = problem.grid.h;
        Ok(Self {
            grid: problem.grid,
            sigma_t: &problem.sigma_t,
            sigma_a: &problem.sigma_a,
            source: &problem.source,
            limiter: params.limiter,
            sigma_eps: params.sigma_eps,
            grad_floor: params.eps * rms_source,
            phi_floor: params.eps * rms_source * h,
            phi_boundary: params.eps * rms_source * h,
            rms_source,
        })
    }

    fn plane(&self) -> usize {
        self.grid.n[1] * self.grid.n[2]
    }

    /// Strides of the x, y, z axes in the linear index.
    fn strides(&self) -> [usize; 3] {
        [self.plane(), self.grid.n[2], 1]
    }

    /// The initial iterate: the boundary value everywhere (our choice).
    pub fn initial_phi(&self) -> Vec<f64> {
        vec![self.phi_boundary; self.grid.len()]
    }

    /// A copy of `phi` with the boundary layer set to the Dirichlet value.
    pub fn with_boundary(&self, phi: &[f64]) -> Vec<f64> {
        phi.iter()
            .enumerate()
            .map(|(c, &v)| {
                if self.grid.is_boundary(self.grid.cell(c)) {
                    self.phi_boundary
                } else {
                    v
                }
            })
            .collect()
    }

    /// `∇φ` at cell `c = (i, j, k)`: central differences, one-sided on the domain faces.
    #[inline]
    fn gradient(&self, phi: &[f64], c: usize, ijk: [usize; 3]) -> [f64; 3] {
        let h = self.grid.h;
        let strides = self.strides();
        let mut g = [0.0; 3];
        for d in 0..3 {
            let s = strides[d];
            let m = self.grid.n[d];
            g[d] = if ijk[d] == 0 {
                (phi[c + s] - phi[c]) / h
            } else if ijk[d] + 1 == m {
                (phi[c] - phi[c - s]) / h
            } else {
                (phi[c + s] - phi[c - s]) / (2.0 * h)
            };
        }
        g
    }

    /// Knudsen number `R` at cell `c` with the lower bounds of the module docs.
    #[inline]
    fn knudsen(&self, phi: &[f64], c: usize, ijk: [usize; 3]) -> f64 {
        let g = self.gradient(phi, c, ijk);
        let grad = (g[0] * g[0] + g[1] * g[1] + g[2] * g[2])
            .sqrt()
            .max(self.grad_floor);
        let sigma = self.sigma_t[c].max(self.sigma_eps);
        grad / (sigma * phi[c].max(self.phi_floor))
    }

    /// Fills `d` with the cell diffusion coefficients `D_c = F(R_c)/max(σ_t, σ_ε)` of `phi`.
    pub fn cell_coefficients(&self, phi: &[f64], d: &mut [f64]) {
        let plane = self.plane();
        let [_, ny, nz] = self.grid.n;
        d.par_chunks_mut(plane).enumerate().for_each(|(i, dp)| {
            for j in 0..ny {
                for k in 0..nz {
                    let local = j * nz + k;
                    let c = i * plane + local;
                    let sigma = self.sigma_t[c].max(self.sigma_eps);
                    let f = if self.limiter.is_nonlinear() {
                        self.limiter.eval(self.knudsen(phi, c, [i, j, k]))
                    } else {
                        1.0 / 3.0
                    };
                    dp[local] = f / sigma;
                }
            }
        });
    }

    /// The six face coefficients `D_f` and neighbour values `φ_nb` of interior cell `c`,
    /// returned as `(Σ D_f, Σ D_f φ_nb)`.
    #[inline]
    fn face_sums(&self, phi: &[f64], d: &[f64], c: usize) -> (f64, f64) {
        let dc = d[c];
        let mut sum_d = 0.0;
        let mut sum_dphi = 0.0;
        for s in self.strides() {
            for nb in [c - s, c + s] {
                let df = 0.5 * (dc + d[nb]);
                sum_d += df;
                sum_dphi += df * phi[nb];
            }
        }
        (sum_d, sum_dphi)
    }

    /// RMS over the interior cells of the residual `q − (−∇·D∇φ + σ_a φ)`, for the cell
    /// coefficients `d` (which the caller computed from `phi`).
    pub fn residual_rms(&self, phi: &[f64], d: &[f64]) -> f64 {
        let [nx, ny, nz] = self.grid.n;
        let plane = self.plane();
        let h2 = self.grid.h * self.grid.h;
        let per_plane: Vec<f64> = (1..nx - 1)
            .into_par_iter()
            .map(|i| {
                let mut acc = 0.0;
                for j in 1..ny - 1 {
                    for k in 1..nz - 1 {
                        let c = i * plane + j * nz + k;
                        let (sum_d, sum_dphi) = self.face_sums(phi, d, c);
                        let lhs = (sum_d * phi[c] - sum_dphi) / h2 + self.sigma_a[c] * phi[c];
                        let r = self.source[c] - lhs;
                        acc += r * r;
                    }
                }
                acc
            })
            .collect();
        let interior = ((nx - 2) * (ny - 2) * (nz - 2)) as f64;
        (per_plane.iter().sum::<f64>() / interior).sqrt()
    }

    /// One SOR half-sweep over the interior cells of one colour (`(i+j+k) % 2 == colour`),
    /// using the frozen coefficients `d`; relaxed values are clamped at 0. Cells of one colour only couple to the other colour,
    /// so the new values are computed in parallel into `scratch` and then copied back.
    pub fn half_sweep(
        &self,
        colour: usize,
        omega: f64,
        phi: &mut [f64],
        scratch: &mut [f64],
        d: &[f64],
    ) {
        let [nx, ny, nz] = self.grid.n;
        let plane = self.plane();
        let h2 = self.grid.h * self.grid.h;
        let phi_ro: &[f64] = phi;
        scratch
            .par_chunks_mut(plane)
            .enumerate()
            .for_each(|(i, out)| {
                if i == 0 || i + 1 == nx {
                    return;
                }
                for j in 1..ny - 1 {
                    let k0 = 1 + (1 + i + j + colour) % 2;
                    for k in (k0..nz - 1).step_by(2) {
                        let local = j * nz + k;
                        let c = i * plane + local;
                        let (sum_d, sum_dphi) = self.face_sums(phi_ro, d, c);
                        let den = sum_d + self.sigma_a[c] * h2;
                        let old = phi_ro[c];
                        out[local] = if den > 0.0 {
                            let gs = (self.source[c] * h2 + sum_dphi) / den;
                            // Over-relaxation can overshoot below 0 where φ is tiny (vacuum, near
                            // the boundary); the fluence is non-negative, so clamp (our choice).
                            ((1.0 - omega) * old + omega * gs).max(0.0)
                        } else {
                            old
                        };
                    }
                }
            });
        phi.par_chunks_mut(plane)
            .zip(scratch.par_chunks(plane))
            .enumerate()
            .for_each(|(i, (p, s))| {
                if i == 0 || i + 1 == nx {
                    return;
                }
                for j in 1..ny - 1 {
                    let k0 = 1 + (1 + i + j + colour) % 2;
                    for k in (k0..nz - 1).step_by(2) {
                        p[j * nz + k] = s[j * nz + k];
                    }
                }
            });
    }

    /// `|E|/φ` per cell, with `E = −D∇φ` the flux the scheme transports: each component is
    /// the mean of the two face fluxes `−D_f (φ_nb − φ_c)/h` along that axis. Cells of the
    /// boundary layer (where no equation is solved) get 0; a cell with φ ≤ 0 gets ∞ if it
    /// carries flux, else 0.
    pub fn flux_ratio(&self, phi: &[f64], d: &[f64]) -> Vec<f64> {
        let [nx, ny, nz] = self.grid.n;
        let plane = self.plane();
        let h = self.grid.h;
        let strides = self.strides();
        let mut out = vec![0.0; self.grid.len()];
        out.par_chunks_mut(plane).enumerate().for_each(|(i, op)| {
            if i == 0 || i + 1 == nx {
                return;
            }
            for j in 1..ny - 1 {
                for k in 1..nz - 1 {
                    let c = i * plane + j * nz + k;
                    let mut e2 = 0.0;
                    for s in strides {
                        let f_minus = -0.5 * (d[c] + d[c - s]) * (phi[c] - phi[c - s]) / h;
                        let f_plus = -0.5 * (d[c] + d[c + s]) * (phi[c + s] - phi[c]) / h;
                        let e = 0.5 * (f_minus + f_plus);
                        e2 += e * e;
                    }
                    let e = e2.sqrt();
                    op[j * nz + k] = if phi[c] > 0.0 {
                        e / phi[c]
                    } else if e > 0.0 {
                        f64::INFINITY
                    } else {
                        0.0
                    };
                }
            }
        });
        out
    }
}
