//! The slab problems and solver settings shared by the Marshak tests of P_N
//! (tests/marshak.rs) and of the text PDEs (tests/marshak_sp.rs).

use pn_runtime::problem::Problem;
use pn_runtime::scenes::vacuum::SlabParams;
use pn_runtime::scenes::{builtin, BuiltinOptions};
use pn_runtime::solver::SolverOptions;
use pn_stencil::Dim;

/// Relative residual 1e-10, at most 20 000 iterations.
pub fn opts() -> SolverOptions {
    SolverOptions {
        tol: 1e-10,
        max_iter: 20_000,
        ..Default::default()
    }
}

/// The built-in `slab` (optical thickness `tau`, `albedo`) with `res` cells across, in `dim`.
pub fn slab_scene(res: usize, tau: f64, albedo: f64, dim: Dim) -> Problem {
    builtin(
        "slab",
        &BuiltinOptions {
            dim: Some(dim),
            res: Some(vec![res]),
            slab: SlabParams {
                tau: Some(tau),
                albedo: Some(albedo),
            },
            ..Default::default()
        },
    )
    .unwrap()
    .problem
}

/// Richardson extrapolation of a second-order quantity from h and h/2.
pub fn richardson(coarse: f64, fine: f64) -> f64 {
    fine + (fine - coarse) / 3.0
}
