//! Solver parameters for flux-limited diffusion.

use anyhow::{ensure, Result};

use super::grid::{FldGrid, FldProblem};
use super::limiter::Limiter;

/// Parameters of the nonlinear red–black SOR solver.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FldParams {
    /// The flux limiter ([`Limiter::Cda`] solves classical diffusion with the same solver).
    pub limiter: Limiter,
    /// SOR relaxation factor, `0 < ω < 2` (ω = 1 is plain Gauss–Seidel).
    pub omega: f64,
    /// Convergence tolerance: stop when the RMS residual over the interior cells falls below
    /// `tol × j̄` (j̄ the RMS source over all cells).
    pub tol: f64,
    /// Maximum number of iterations (one iteration = a red and a black half-sweep).
    pub max_iter: usize,
    /// Extinction threshold σ_ε: the coefficient uses `max(σ_t, σ_ε)`, so σ_ε must be positive
    /// where the medium has vacuum (σ_t = 0). Absolute units (1/length).
    pub sigma_eps: f64,
    /// ε of the lower bounds `|∇φ| ≥ ε j̄`, `φ ≥ ε j̄ h` in the Knudsen number and of the
    /// Dirichlet boundary value `φ = ε j̄ h`.
    pub eps: f64,
}

impl Default for FldParams {
    /// Levermore–Pomraning, ω = 1.5, tol = 1e-6, 20 000 iterations, σ_ε = 1e-3 (i.e.
    /// 1e-3 per unit domain length; use [`FldParams::for_grid`] to scale it to the domain),
    /// ε = 1e-6. ω and ε are our choices: ω = 1.5 needed the fewest iterations of 1.3 … 1.9
    /// for LP on the sphere in vacuum at 64³ with the earlier cell-centred D (1.9 did not
    /// converge); with the face D of `operator.rs`, ω = 1.3/1.4/1.5/1.6 need 206/177/204/219
    /// iterations at 24³. ε makes the boundary value and floors far below the fluence of
    /// interest.
    fn default() -> Self {
        Self {
            limiter: Limiter::LevermorePomraning,
            omega: 1.5,
            tol: 1e-6,
            max_iter: 20_000,
            sigma_eps: 1e-3,
            eps: 1e-6,
        }
    }
}

impl FldParams {
    /// Defaults for `limiter` with σ_ε = 1e-3 / L, L the longest domain edge of `grid`
    /// (the paper's choice of σ_ε relative to the domain size).
    pub fn for_grid(limiter: Limiter, grid: &FldGrid) -> Self {
        Self {
            limiter,
            sigma_eps: 1e-3 / grid.max_extent(),
            ..Self::default()
        }
    }

    /// Checks the parameters on their own and against `problem` (σ_ε must be positive when
    /// the problem contains vacuum cells, σ_t = 0).
    pub fn validate(&self, problem: &FldProblem) -> Result<()> {
        self.limiter.validate()?;
        ensure!(
            self.omega.is_finite() && self.omega > 0.0 && self.omega < 2.0,
            "SOR factor omega must lie in the open interval (0, 2), got {}",
            self.omega
        );
        ensure!(
            self.tol.is_finite() && self.tol > 0.0,
            "FLD tolerance must be finite and positive, got {}",
            self.tol
        );
        ensure!(self.max_iter >= 1, "FLD max_iter must be at least 1");
        ensure!(
            self.eps.is_finite() && self.eps > 0.0,
            "FLD epsilon must be finite and positive, got {}",
            self.eps
        );
        ensure!(
            self.sigma_eps.is_finite() && self.sigma_eps >= 0.0,
            "sigma_eps must be finite and non-negative, got {}",
            self.sigma_eps
        );
        if self.sigma_eps <= 0.0 {
            if let Some(idx) = problem.sigma_t.iter().position(|&s| s <= 0.0) {
                anyhow::bail!(
                    "the medium has vacuum (sigma_t = 0 at cell {:?}) but sigma_eps = {} : \
                     a positive extinction threshold sigma_eps is required there",
                    problem.grid.cell(idx),
                    self.sigma_eps
                );
            }
        }
        Ok(())
    }
}
