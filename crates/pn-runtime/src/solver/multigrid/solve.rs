//! Multigrid-preconditioned Krylov directly on a scalar diffusion matrix (CDA, the FLD
//! Picard steps), which has no parity structure to eliminate.

use super::{Geometry, Multigrid};
use crate::solver::{SolveStats, SolveStatus, SolverOptions};
use pn_krylov::control::{Control, Outcome};
use pn_krylov::krylov::{KrylovMethod, SYMMETRY_TOL};
use pn_krylov::linalg::{dot, norm, residual, spmv};
use pn_krylov::operator::Counted;
use sprs::CsMat;

pub use super::SCALAR_CORRECTION_SCALE;

/// Relative asymmetry `|xᵀAy − yᵀAx| / (‖x‖‖Ay‖ + ‖y‖‖Ax‖)` for one deterministic pair.
fn asymmetry(a: &CsMat<f64>) -> f64 {
    let n = a.rows();
    let x = super::smoother::pseudo_random(n, 1);
    let y = super::smoother::pseudo_random(n, 2);
    let (mut ax, mut ay) = (vec![0.0; n], vec![0.0; n]);
    spmv(a, &x, &mut ax);
    spmv(a, &y, &mut ay);
    let scale = norm(&x) * norm(&ay) + norm(&y) * norm(&ax);
    if scale == 0.0 {
        0.0
    } else {
        (dot(&x, &ay) - dot(&y, &ax)).abs() / scale
    }
}

/// Multigrid-preconditioned CG (BiCGSTAB when `a` is measurably nonsymmetric; the stats name
/// the method, `mg-cg` or `mg-bicgstab`) on `a`,
/// with the stopping rules of [`SolverOptions`]; the residual is recomputed at the end.
/// The multigrid parameters are `opts.tuning`'s ([`crate::solver::SolverTuning`]); an unset
/// correction scale is [`SCALAR_CORRECTION_SCALE`]. With `opts.tuning.profile`, prints
/// the hierarchy and its timings.
pub fn mg_krylov(
    a: &CsMat<f64>,
    b: &[f64],
    geometry: &Geometry,
    opts: &SolverOptions,
) -> Result<(Vec<f64>, SolveStats), super::MgError> {
    let a_csr;
    let a = if a.is_csr() {
        a
    } else {
        a_csr = a.to_csr();
        &a_csr
    };
    let mg = Multigrid::for_matrix(a, geometry, &opts.tuning.multigrid_options())?;
    let mut notes = Vec::new();
    if opts.tuning.profile {
        notes.push(format!("profile mg setup: {}", mg.describe_setup()));
    }
    let method = if asymmetry(a) <= SYMMETRY_TOL {
        KrylovMethod::Cg
    } else {
        KrylovMethod::BiCgStab
    };
    let bnorm = norm(b);
    let scale = if bnorm > 0.0 { bnorm } else { 1.0 };
    let mut ctl = Control::for_options(&opts.stopping(), bnorm);
    // Every product with `a`, the multigrid cycle's finest level included.
    let products = Counted::new(a);
    let prec = mg.with_fine(&products);
    let mut x = vec![0.0; b.len()];
    let outcome = if bnorm == 0.0 {
        Outcome::Reached
    } else {
        method.run(&products, &prec, b, &mut x, &mut ctl)
    };
    ctl.finish();
    let mut r = vec![0.0; b.len()];
    residual(a, &x, b, &mut r);
    let abs = norm(&r);
    let rel = abs / scale;
    let status = match outcome {
        _ if rel <= opts.tol => SolveStatus::Converged,
        Outcome::Diverged => SolveStatus::Diverged,
        Outcome::MaxIterations => SolveStatus::MaxIterations,
        Outcome::Reached | Outcome::Stagnated => SolveStatus::Stagnated,
    };
    if opts.tuning.profile {
        notes.push(format!("profile mg-{}: {}", method.name(), mg.describe()));
    }
    Ok((
        x,
        SolveStats {
            solver: format!("mg-{}", method.name()),
            status,
            iterations: ctl.iterations,
            relative_residual: rel,
            absolute_residual: abs,
            rhs_norm: bnorm,
            tolerance: opts.tol,
            history: ctl.history,
            // The products above, the final residual, and the setup's `λ_max` estimate.
            operator_applications: products.count() + 1 + mg.setup_fine_applications(),
            notes,
        },
    ))
}
