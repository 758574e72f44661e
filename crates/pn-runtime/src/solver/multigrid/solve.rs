//! Solvers that know the layout: the parity solver with the layout's classes and
//! positions, and multigrid-preconditioned Krylov directly on a scalar diffusion matrix
//! (CDA, the FLD Picard steps), which has no parity structure to eliminate.

use super::{Geometry, MgOptions, Multigrid};
use crate::layout::Layout;
use crate::linalg::{dot, norm, residual, spmv};
use crate::solver::parity::krylov::{self, Control, KrylovMethod, Outcome};
use crate::solver::parity::{ParityCg, SYMMETRY_TOL};
use crate::solver::{
    progress_bar, report_progress, LinearSolver, SolveStats, SolveStatus, SolverOptions,
};
use sprs::CsMat;

/// A [`ParityCg`] built for one layout. When the matrix lacks the parity structure and
/// the layout has a single moment (a scalar diffusion system such as CDA), it solves
/// with multigrid-preconditioned CG (BiCGSTAB if nonsymmetric) on the matrix itself;
/// otherwise it falls back to CGNR like [`ParityCg`].
pub struct LayoutSolver {
    parity: ParityCg,
    geometry: Option<Geometry>,
}

impl LayoutSolver {
    /// Wraps `parity` (built from `layout`).
    pub fn new(parity: ParityCg, layout: &Layout) -> Self {
        let geometry = (layout.moments.len() == 1).then(|| Geometry::from_layout(layout, None));
        Self { parity, geometry }
    }

    /// Wraps `parity` without the multigrid fallback (non-parity systems go to CGNR).
    pub fn without_multigrid(parity: ParityCg) -> Self {
        Self {
            parity,
            geometry: None,
        }
    }
}

impl LayoutSolver {
    /// Solves the system given by its parity blocks (no `A` to fall back on): when the
    /// chosen preconditioner cannot be built (multigrid on a degenerate grid, a singular
    /// block), says so and solves with the Jacobi preconditioner instead.
    pub fn solve_split(
        &self,
        split: &crate::solver::parity::split::Split,
        b: &[f64],
        opts: &SolverOptions,
    ) -> (Vec<f64>, SolveStats) {
        match self.parity.solve_split(split, b, opts) {
            Ok((u, report)) => (u, report.stats),
            Err(e) => {
                eprintln!("note: the parity preconditioner could not be built ({e}); using Jacobi");
                let jacobi = self
                    .parity
                    .clone()
                    .with_precond(crate::solver::parity::Precond::Jacobi);
                match jacobi.solve_split(split, b, opts) {
                    Ok((u, report)) => (u, report.stats),
                    Err(e) => {
                        eprintln!("note: Jacobi could not be built either ({e}); unpreconditioned");
                        match jacobi
                            .with_precond(crate::solver::parity::Precond::None)
                            .solve_split(split, b, opts)
                        {
                            Ok((u, report)) => (u, report.stats),
                            // Unreachable: `Precond::None` builds nothing that can fail.
                            Err(e) => failed_solve(b.len(), opts, &e.to_string()),
                        }
                    }
                }
            }
        }
    }
}

/// A `Diverged` result for a solve that could not start.
fn failed_solve(n: usize, opts: &SolverOptions, why: &str) -> (Vec<f64>, SolveStats) {
    eprintln!("error: the parity solve could not start: {why}");
    (
        vec![0.0; n],
        SolveStats {
            solver: "parity-cg".into(),
            status: SolveStatus::Diverged,
            iterations: 0,
            relative_residual: f64::NAN,
            absolute_residual: f64::NAN,
            rhs_norm: f64::NAN,
            tolerance: opts.tol,
            history: Vec::new(),
            operator_applications: 0,
        },
    )
}

impl LinearSolver for LayoutSolver {
    fn name(&self) -> &'static str {
        "parity-cg"
    }

    fn solve(&self, a: &CsMat<f64>, b: &[f64], opts: &SolverOptions) -> (Vec<f64>, SolveStats) {
        match self.parity.solve_detailed(a, b, opts) {
            Ok((u, report)) => (u, report.stats),
            Err(e) => match &self.geometry {
                Some(g) if g.len() == a.rows() => match mg_krylov(a, b, g, opts) {
                    Ok(r) => r,
                    Err(err) => {
                        eprintln!("note: multigrid does not apply ({err}); falling back to cgnr");
                        crate::solver::cgnr::Cgnr.solve(a, b, opts)
                    }
                },
                _ => {
                    eprintln!("note: parity-cg does not apply ({e}); falling back to cgnr");
                    crate::solver::cgnr::Cgnr.solve(a, b, opts)
                }
            },
        }
    }
}

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

/// Over-correction of the coarse-grid step for scalar diffusion: piecewise-constant
/// aggregation underestimates the coarse correction of smooth modes, and with the plain
/// step MG-CG on the 7-point CDA operator needed 8/10/14 iterations at 16³/32³/64³,
/// with 1.4 it needs 9/10/11 (`tests/multigrid.rs`). On the P_N even-parity systems the
/// plain step is better (80³… 40³ P_3: 12 vs 15 iterations), so it stays 1 there.
pub const SCALAR_CORRECTION_SCALE: f64 = 1.4;

/// Multigrid-preconditioned CG (BiCGSTAB when `a` is measurably nonsymmetric) on `a`,
/// with the stopping rules of [`SolverOptions`]; the residual is recomputed at the end.
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
    let mut mg_opts = MgOptions::from_env();
    if std::env::var_os("PN_MG_SCALE").is_none() {
        mg_opts.correction_scale = SCALAR_CORRECTION_SCALE;
    }
    let mg = Multigrid::for_matrix(a, geometry, &mg_opts)?;
    let method = if asymmetry(a) <= SYMMETRY_TOL {
        KrylovMethod::Cg
    } else {
        KrylovMethod::BiCgStab
    };
    let bnorm = norm(b);
    let scale = if bnorm > 0.0 { bnorm } else { 1.0 };
    let pb = progress_bar(opts.max_iter, opts.progress);
    let show = report_progress(&pb);
    let mut ctl = Control::for_options(opts, bnorm, &show);
    // Every product with `a`, the multigrid cycle's finest level included.
    let products = std::sync::atomic::AtomicUsize::new(0);
    let apply = |x: &[f64], y: &mut [f64]| {
        products.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
        spmv(a, x, y)
    };
    let prec = |r: &[f64], z: &mut [f64]| mg.apply(&apply, r, z);
    let mut x = vec![0.0; b.len()];
    let outcome = if bnorm == 0.0 {
        Outcome::Reached
    } else {
        match method {
            KrylovMethod::Cg => krylov::pcg(&apply, &prec, b, &mut x, &mut ctl),
            _ => krylov::bicgstab(&apply, &prec, b, &mut x, &mut ctl),
        }
    };
    pb.finish_and_clear();
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
    if crate::solver::parity::profile_enabled() {
        eprintln!("profile mg-{}: {}", method.name(), mg.describe());
    }
    Ok((
        x,
        SolveStats {
            solver: "mg-cg".into(),
            status,
            iterations: ctl.iterations,
            relative_residual: rel,
            absolute_residual: abs,
            rhs_norm: bnorm,
            tolerance: opts.tol,
            history: ctl.history,
            // The products above, the final residual, and the setup's power iteration.
            operator_applications: products.load(std::sync::atomic::Ordering::Relaxed)
                + 1
                + mg.setup_fine_applications(),
        },
    ))
}
