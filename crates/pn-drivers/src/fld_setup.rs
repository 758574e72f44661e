//! The FLD settings of `pn solve --method fld` ([`crate::fld_method`]), read from its command
//! line. The FLD problem and its solve by either route live in [`pn_render::fld_problem`]
//! (shared with `pn render --method fld`), re-exported here.
//!
//! **From the scene to the FLD problem** ([`fld_problem`]): σ_t, σ_s (or the albedo) and
//! `Q_0^0` are evaluated at the cell centres (exact for analytic fields, the voxel itself for
//! voxel data at the grid resolution). The FLD extinction is the transport coefficient
//! `σ_t − g σ_s` (`g = λ_1 p_1`, docs/design.md §2.2; σ_t for isotropic scattering), the
//! absorption `σ_t − σ_s`. FLD needs cubic cells (one `h`) and 3D.
//!
//! **Normalisation.** The FLD solvers work with the fluence `φ = √(4π) L_0^0` and the
//! isotropic emission `q = √(4π) Q_0^0` ([`SQRT_4PI`]).

use anyhow::{ensure, Result};
use pn_runtime::fld::{FldGrid, FldParams, Limiter};

use crate::scene_setup::{Route, SolveRequest};

pub use pn_render::fld_problem::{
    fld_grid, fld_problem, solve_fld_route, FldRun, FldSettings, SQRT_4PI,
};

/// Refuses the FLD-only flags with `--method pn|cda`.
pub fn reject_fld_flags(a: &SolveRequest) -> Result<()> {
    for (set, flag) in [
        (a.limiter.is_some(), "--limiter"),
        (a.omega.is_some(), "--omega"),
        (a.fld_solver.is_some(), "--fld-solver"),
        (a.sigma_eps.is_some(), "--sigma-eps"),
        (a.fld_all_limiters, "--fld-all-limiters"),
    ] {
        ensure!(!set, "{flag} applies to --method fld only");
    }
    Ok(())
}

/// Reads and checks the FLD options of `a` for `grid` (σ_ε defaults to `1e-3/L`). Options
/// that belong to other methods are refused with a message naming the FLD counterpart.
pub fn settings_from_request(a: &SolveRequest, grid: &FldGrid) -> Result<FldSettings> {
    ensure!(!a.collocated, "--collocated applies to --method pn only");
    ensure!(a.order.is_none(), "--order applies to --method pn only");
    ensure!(
        a.bc.is_none(),
        "--bc does not apply to --method fld: FLD holds the outermost cell layer at the \
         Dirichlet value φ = ε·j̄·h"
    );
    ensure!(
        a.sigma_t_min.is_none(),
        "--sigma-t-min does not apply to --method fld: use --sigma-eps (FLD uses \
         max(σ_t, σ_ε) in the diffusion coefficient)"
    );
    let limiter = a.limiter.unwrap_or(Limiter::LevermorePomraning);
    // ω is the SOR factor of the Gauss–Seidel route: giving it selects that route.
    let route = a.fld_solver.unwrap_or(if a.omega.is_some() {
        Route::GaussSeidel
    } else {
        Route::default()
    });
    ensure!(
        !(route == Route::Picard && a.omega.is_some()),
        "--omega (the SOR factor) applies to --fld-solver gs only"
    );
    if let Some(w) = a.omega {
        ensure!(
            w.is_finite() && w > 0.0 && w < 2.0,
            "--omega must lie in the open interval (0, 2), got {w}"
        );
    }
    if let Some(s) = a.sigma_eps {
        ensure!(
            s.is_finite() && s >= 0.0,
            "--sigma-eps must be finite and non-negative, got {s}"
        );
    }
    ensure!(
        a.tol.is_finite() && a.tol > 0.0,
        "--tol must be positive, got {}",
        a.tol
    );
    ensure!(a.max_iter > 0, "--max-iter must be at least 1");
    let d = FldParams::for_grid(limiter, grid);
    let params = FldParams {
        omega: a.omega.unwrap_or(d.omega),
        sigma_eps: a.sigma_eps.unwrap_or(d.sigma_eps),
        tol: a.tol,
        max_iter: a.max_iter,
        ..d
    };
    Ok(FldSettings {
        params,
        route,
        linear_solver: a.solver,
        tuning: a.tuning.clone(),
    })
}
