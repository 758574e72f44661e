//! The built-in scenes `slab` and `milne` of `pn solve`: the classic checks of the Marshak
//! vacuum boundary (docs/design.md §3, "Domain and boundary"; references in
//! `tests/data/marshak/README.md` and [`crate::reference::slab`]), and what their reports
//! measure.
//!
//! Both are 1D problems posed on a 2D (or 3D) grid one cell thick in y (and z) with
//! reflecting (Neumann) faces there, σ_t = 1 and isotropic scattering:
//!
//! * `slab`: thickness τ (`--tau`, default 1), albedo c (`--albedo`, default 0.9), a unit
//!   beam normally incident on x = 0. The solve is for the collided radiance, with the
//!   first-collision source `Q = σ_s e^{−x}/(4π)` per steradian (`Q_0^0 = c e^{−x}/√(4π)`),
//!   Marshak on both x faces. [`slab_fluxes`] gives the collided outgoing fluxes
//!   `R = −J_x(0)` and `T = J_x(τ)` with `J_x = √(4π/3) L_1^1` (the face unknowns).
//! * `milne`: the half-space with c = 1, in the standard finite form: depth X (`--tau`,
//!   default 30), Marshak at x = 0, reflecting at x = X, a uniform source `Q_0^0 = 1` in the
//!   last mean free path [X − 1, X]. Between, far from both ends, φ is linear,
//!   `φ ∝ x + z_0`; [`milne_extrapolation_length`] reads z_0 off two cell centres at X/2 ∓ 2
//!   (the boundary transients decay like `e^{−x/ν}` with ν < 1: below 1e−5 there for X = 30).

use super::Scene;
use crate::field::{Field, Point};
use crate::layout::Layout;
use crate::problem::{Boundary, BoundaryKind, Grid, Phase, Problem, Scattering, SourceTerm};
use anyhow::{ensure, Context, Result};
use pn_stencil::Dim;

/// Parameters of the `slab` and `milne` scenes.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct SlabParams {
    /// Optical thickness τ of the slab (`slab`) or depth X of the half-space (`milne`);
    /// `None`: 1 for `slab`, 30 for `milne`.
    pub tau: Option<f64>,
    /// Albedo of the slab (`slab` only; default 0.9).
    pub albedo: Option<f64>,
}

/// Default albedo of `slab`.
pub const SLAB_ALBEDO: f64 = 0.9;
/// Default thickness of `slab`.
pub const SLAB_TAU: f64 = 1.0;
/// Default depth of `milne`.
pub const MILNE_DEPTH: f64 = 30.0;

/// The grid of a 1D problem on [0, length] in x: `res` one value (cells in x, one cell in y
/// and z) or one per axis.
fn slab_grid(dim: Dim, length: f64, res: Option<&[usize]>, default: usize) -> Result<Grid> {
    let r = match res {
        None => [default, 1, 1],
        Some([n]) => [*n, 1, 1],
        Some(v) => super::resolve_res(dim, default, Some(v))?,
    };
    ensure!(
        r.iter().all(|&n| n > 0),
        "resolution must be positive on every axis"
    );
    let res = if dim == Dim::Two { [r[0], r[1], 1] } else { r };
    let grid = Grid {
        dim,
        min: [0.0; 3],
        max: [length, 1.0, 1.0],
        res,
    };
    Ok(grid)
}

/// `x=marshak` (or only the min x face), reflecting elsewhere.
fn x_vacuum(both: bool) -> Boundary {
    let mut f = [[BoundaryKind::Neumann; 2]; 3];
    f[0][0] = BoundaryKind::Marshak;
    if both {
        f[0][1] = BoundaryKind::Marshak;
    }
    Boundary::from_faces(f)
}

/// The `slab` scene.
pub fn slab(dim: Option<Dim>, res: Option<&[usize]>, p: SlabParams) -> Result<Scene> {
    let tau = p.tau.unwrap_or(SLAB_TAU);
    let albedo = p.albedo.unwrap_or(SLAB_ALBEDO);
    ensure!(
        tau.is_finite() && tau > 0.0,
        "--tau must be positive, got {tau}"
    );
    ensure!(
        (0.0..=1.0).contains(&albedo),
        "--albedo must lie in [0, 1], got {albedo}"
    );
    let grid = slab_grid(dim.unwrap_or(Dim::Two), tau, res, 200)?;
    let norm = albedo / (4.0 * std::f64::consts::PI).sqrt();
    let q = Field::analytic(move |x: Point| norm * (-x[0]).exp());
    Ok(Scene {
        name: "slab".into(),
        problem: Problem {
            grid,
            sigma_t: Field::Constant(1.0),
            scattering: Scattering::Albedo(Field::Constant(albedo)),
            phase: Phase::Isotropic,
            sources: vec![SourceTerm {
                l: 0,
                m: 0,
                field: q,
            }],
            boundary: x_vacuum(true),
            sigma_t_min: None,
        },
        default_order: 3,
        notes: Vec::new(),
    })
}

/// The `milne` scene.
pub fn milne(dim: Option<Dim>, res: Option<&[usize]>, p: SlabParams) -> Result<Scene> {
    ensure!(
        p.albedo.is_none(),
        "--albedo does not apply to milne (the Milne problem has c = 1)"
    );
    let depth = p.tau.unwrap_or(MILNE_DEPTH);
    ensure!(
        depth.is_finite() && depth >= 12.0,
        "--tau (the depth of the milne half-space) must be at least 12 mean free paths, got \
         {depth}"
    );
    let grid = slab_grid(dim.unwrap_or(Dim::Two), depth, res, 300)?;
    let q = Field::analytic(move |x: Point| if x[0] > depth - 1.0 { 1.0 } else { 0.0 });
    Ok(Scene {
        name: "milne".into(),
        problem: Problem {
            grid,
            sigma_t: Field::Constant(1.0),
            scattering: Scattering::Albedo(Field::Constant(1.0)),
            phase: Phase::Isotropic,
            sources: vec![SourceTerm {
                l: 0,
                m: 0,
                field: q,
            }],
            boundary: x_vacuum(false),
            sigma_t_min: None,
        },
        default_order: 3,
        notes: Vec::new(),
    })
}

/// Index of moment (l, m) in the layout.
fn moment(layout: &Layout, l: i32, m: i32) -> Result<usize> {
    layout
        .moments
        .iter()
        .position(|mp| mp.l == l && mp.m == m)
        .with_context(|| format!("the stencil has no moment ({l},{m})"))
}

/// Mean of moment `q` over the tangential (y, z) positions at x index `ix`.
fn mean_at(layout: &Layout, u: &[f64], q: usize, ix: usize) -> f64 {
    let e = layout.extents[q];
    let mut s = 0.0;
    for j in 0..e[1] {
        for k in 0..e[2] {
            s += u[layout.index(q, [ix, j, k])];
        }
    }
    s / (e[1] * e[2]) as f64
}

/// `(R, T)`: the net flux out through x = min and x = max per unit area,
/// `R = −J_x(min)`, `T = J_x(max)`, `J_x = √(4π/3) L_1^1` on the x faces (averaged over
/// y, z). For the `slab` scene these are the collided reflection and transmission.
pub fn slab_fluxes(layout: &Layout, u: &[f64]) -> Result<(f64, f64)> {
    let q = moment(layout, 1, 1)?;
    ensure!(
        layout.moments[q].shift[0] == 1,
        "L_1^1 is not on the x faces (a staggered stencil is needed)"
    );
    let c = (4.0 * std::f64::consts::PI / 3.0).sqrt();
    let n = layout.extents[q][0] - 1;
    Ok((-c * mean_at(layout, u, q, 0), c * mean_at(layout, u, q, n)))
}

/// The extrapolation length of the `milne` scene: `z_0 = φ(x_a)/φ' − x_a` with φ' the
/// difference quotient of the fluence (L_0^0, averaged over y, z) between the cell centres
/// nearest to X/2 − 2 and X/2 + 2.
pub fn milne_extrapolation_length(grid: &Grid, layout: &Layout, u: &[f64]) -> Result<f64> {
    let q = moment(layout, 0, 0)?;
    let h = grid.h(0);
    let depth = grid.max[0] - grid.min[0];
    let centre =
        |x: f64| (((x - grid.min[0]) / h - 0.5).round().max(0.0) as usize).min(grid.res[0] - 1);
    let (ia, ib) = (centre(0.5 * depth - 2.0), centre(0.5 * depth + 2.0));
    ensure!(ib > ia, "the milne grid is too coarse to measure a slope");
    let x = |i: usize| grid.min[0] + (i as f64 + 0.5) * h;
    let (fa, fb) = (mean_at(layout, u, q, ia), mean_at(layout, u, q, ib));
    let slope = (fb - fa) / (x(ib) - x(ia));
    ensure!(
        slope.is_finite() && slope != 0.0,
        "the milne fluence has no slope (did the solve converge?)"
    );
    Ok(fa / slope - (x(ia) - grid.min[0]))
}
