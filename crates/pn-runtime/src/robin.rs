//! Boundary conditions stated by the PDE itself ([`pn_stencil::robin`]: a text PDE's
//! `boundary marshak` statements, docs/pde-text.md) applied on the Marshak faces of a
//! problem, by eliminating the ghost values the stencil reaches for across the face.
//!
//! A row of a cell-centred unknown next to a face references the unknowns half a cell
//! outside it — one cell beyond the nearest centre `c_0`, the *ghost* `u_g`. With the
//! conditions `Σ_j A_ij u_j + Σ_k B_ik ∂_n u_k = 0` (K targets, `∂_n` outward) the ghost is
//! eliminated as follows, for every target q:
//!
//! ```text
//!     ∂_n u ≈ (u_g − u_{c0}) / h          (one-sided across the face, outward)
//!     u(face) ≈ (3 u_{c0} − u_{c1}) / 2     (linear extrapolation from the two nearest centres)
//!     ∂_n u_T = −B⁻¹ A u(face)              (the conditions solved for the normal derivatives)
//!     u_g,q  = u_{c0,q} + h (∂_n u_T)_q
//! ```
//!
//! For a flux-form row `−∇·(D ∇u)` the face flux `D (u_{c0} − u_g)/h` thereby becomes the
//! flux the conditions prescribe, with the face values taken as P_N's Marshak closure takes
//! them (`crate::marshak`, [`crate::marshak::FaceValue::Linear`], second order). This makes
//! a diffusion-type system whose conditions are the P_N Marshak conditions with the odd
//! moments eliminated the same discrete system as the staggered P_N one: SP_1 = P_1 and, in
//! a slab, SP_3 = P_3 with Marshak faces (`crates/pn-runtime/tests/marshak_sp.rs`). `A` and
//! `B` are evaluated at the face point (the fields there), as the stencil's `D` is.
//!
//! Restrictions (errors, not silent fallbacks): the unknowns the conditions name must sit
//! at cell centres along the face normal and share one placement; a face needs two cells
//! along its normal; a reference across two Marshak faces at once (a diagonal stencil term
//! at an edge) is refused; `B` must be invertible at every face point.

use crate::context::RowContext;
use crate::layout::Layout;
use crate::problem::{BoundaryKind, Problem};
use anyhow::{bail, ensure, Context, Result};
use pn_stencil::robin::RobinBoundary;
use pn_stencil::StencilKernel;

/// The kind of the conditions applied on `--bc marshak` faces.
pub const MARSHAK: &str = "marshak";

/// A kernel's boundary conditions applied on a problem's Marshak faces.
#[derive(Clone, Debug)]
pub struct RobinFaces<'a> {
    boundary: &'a RobinBoundary,
    /// Per axis and side: whether the face is Marshak (and closed by the conditions).
    faces: [[bool; 2]; 3],
    /// Cells per axis.
    res: [usize; 3],
    /// h per axis.
    h: [f64; 3],
}

impl<'a> RobinFaces<'a> {
    /// The conditions of `kernel` on the Marshak faces of `problem`, or `None` when the
    /// problem has no Marshak face or the kernel states no `marshak` conditions (then
    /// `crate::marshak` closes P_N stencils or refuses). Fails when the conditions cannot
    /// close the faces (see the module documentation).
    pub fn new(
        problem: &Problem,
        layout: &Layout,
        kernel: &'a dyn StencilKernel,
    ) -> Result<Option<Self>> {
        let grid = &problem.grid;
        let axes = grid.dim.axes();
        if !problem.boundary.has_marshak(axes) {
            return Ok(None);
        }
        let Some(boundary) = kernel.boundary_conditions().filter(|b| b.kind == MARSHAK) else {
            return Ok(None);
        };
        ensure!(
            !boundary.conditions.is_empty(),
            "the stencil's `{MARSHAK}` boundary conditions are empty"
        );
        let moments = &layout.moments;
        let label = |q: usize| {
            moments
                .get(q)
                .map(|m| format!("({},{})", m.l, m.m))
                .unwrap_or_else(|| format!("#{q}"))
        };
        let mut referenced = Vec::new();
        for c in &boundary.conditions {
            referenced.push(c.target);
            referenced.extend(c.value.iter().map(|t| t.0));
            for &(q, _) in &c.normal {
                ensure!(
                    boundary.condition_of(q).is_some(),
                    "the boundary conditions take the normal derivative of moment {} but state \
                     no condition for it",
                    label(q)
                );
                referenced.push(q);
            }
        }
        ensure!(
            referenced.iter().all(|&q| q < moments.len()),
            "the boundary conditions reference a moment the stencil does not have"
        );
        let shift = moments[boundary.conditions[0].target].shift;
        let faces_kind = problem.boundary.faces();
        let mut faces = [[false; 2]; 3];
        for d in 0..axes {
            faces[d] = faces_kind[d].map(|k| k == BoundaryKind::Marshak);
            if !(faces[d][0] || faces[d][1]) {
                continue;
            }
            for &q in &referenced {
                ensure!(
                    moments[q].shift == shift && shift[d] == 0,
                    "the `boundary marshak` conditions need their unknowns at cell centres \
                     along the face normal, all on one grid: moment {} has shift {:?} (axis {d})",
                    label(q),
                    moments[q].shift
                );
            }
            ensure!(
                grid.res[d] >= 2,
                "a Marshak face needs at least 2 cells along its normal (axis {d} has {})",
                grid.res[d]
            );
        }
        Ok(Some(Self {
            boundary,
            faces,
            res: grid.res,
            h: [0, 1, 2].map(|d| grid.h(d)),
        }))
    }

    /// Whether face `(axis, side)` is closed by the conditions (a Marshak face).
    pub fn closes(&self, (axis, side): (usize, usize)) -> bool {
        self.faces.get(axis).is_some_and(|f| f[side.min(1)])
    }

    /// The Marshak face `(axis, side)` a reference to moment `q` at absolute half
    /// coordinate `half` reaches across, if any.
    pub fn crossing(&self, layout: &Layout, q: usize, half: [i64; 3]) -> Option<(usize, usize)> {
        let s = layout.moments[q].shift;
        let e = layout.extents[q];
        (0..3).find_map(|d| {
            let raw = if s[d] == 1 {
                half[d].div_euclid(2)
            } else {
                (half[d] - 1).div_euclid(2)
            };
            let side = if raw < 0 {
                0
            } else if raw > e[d] as i64 - 1 {
                1
            } else {
                return None;
            };
            self.faces[d][side].then_some((d, side))
        })
    }

    /// Appends to `out` the entries `(column, value)` that replace `weight × u_g`, the ghost
    /// value of moment `q` at absolute half coordinate `half` across face `(axis, side)`
    /// (from [`RobinFaces::crossing`]).
    #[expect(
        clippy::too_many_arguments,
        reason = "one row's context, passed through"
    )]
    pub fn ghost(
        &self,
        problem: &Problem,
        layout: &Layout,
        q: usize,
        half: [i64; 3],
        (axis, side): (usize, usize),
        weight: f64,
        out: &mut Vec<(usize, f64)>,
    ) -> Result<()> {
        let mp = &layout.moments[q];
        let Some(k) = self.boundary.condition_of(q) else {
            bail!(
                "the stencil reaches across a Marshak face for moment ({},{}), for which the \
                 PDE states no `boundary marshak` condition",
                mp.l,
                mp.m
            );
        };
        // Tangential indices (the usual closure on the other axes).
        let e = layout.extents[q];
        let mut idx = [0usize; 3];
        for d in (0..3).filter(|&d| d != axis) {
            let raw = if mp.shift[d] == 1 {
                half[d].div_euclid(2)
            } else {
                (half[d] - 1).div_euclid(2)
            };
            let max = e[d] as i64 - 1;
            if (0..=max).contains(&raw) {
                idx[d] = raw as usize;
                continue;
            }
            match problem.boundary.face(d, usize::from(raw > max)) {
                BoundaryKind::Neumann => idx[d] = raw.clamp(0, max) as usize,
                BoundaryKind::Dirichlet => return Ok(()),
                BoundaryKind::Marshak => bail!(
                    "a stencil term reaches across two Marshak faces at once (axes {axis} and \
                     {d}); the `boundary` conditions close one face at a time"
                ),
            }
        }
        let n = self.res[axis];
        let (c0, c1) = if side == 0 { (0, 1) } else { (n - 1, n - 2) };
        let mut at0 = idx;
        at0[axis] = c0;
        let mut at1 = idx;
        at1[axis] = c1;
        // The face point: the tangential position of the reference, the face along `axis`.
        let mut face = layout.half_coord(q, at0);
        face[axis] = if side == 0 { 0 } else { 2 * n as i64 };
        let ctx = RowContext::new(problem, face);
        let kk = self.boundary.conditions.len();
        let mut b = vec![vec![0.0; kk]; kk];
        for (i, c) in self.boundary.conditions.iter().enumerate() {
            for (qn, w) in &c.normal {
                if let Some(j) = self.boundary.condition_of(*qn) {
                    b[i][j] += w.eval(&ctx);
                }
            }
        }
        let values: Vec<Vec<(usize, f64)>> = self
            .boundary
            .conditions
            .iter()
            .map(|c| c.value.iter().map(|(qv, w)| (*qv, w.eval(&ctx))).collect())
            .collect();
        if let Some(err) = ctx.take_error() {
            return Err(err).context("invalid scene coefficients at a Marshak face");
        }
        // y = B^{-T} e_k: (∂_n u_T)_k = −Σ_i y_i (A u(face))_i.
        let bt: Vec<Vec<f64>> = (0..kk)
            .map(|i| (0..kk).map(|j| b[j][i]).collect())
            .collect();
        let mut rhs = vec![0.0; kk];
        rhs[k] = 1.0;
        let y = solve_dense(bt, rhs).with_context(|| {
            format!(
                "the normal-derivative coefficients of the `boundary marshak` conditions are \
                 singular at the face point {:?} (together they must determine every target's \
                 normal derivative)",
                ctx.point([0; 3])
            )
        })?;
        let h = self.h[axis];
        out.push((layout.index(q, at0), weight));
        for (i, vals) in values.iter().enumerate() {
            if y[i] == 0.0 {
                continue;
            }
            for &(qv, a) in vals {
                let c = -weight * h * y[i] * a;
                out.push((layout.index(qv, at0), 1.5 * c));
                out.push((layout.index(qv, at1), -0.5 * c));
            }
        }
        ensure!(
            out.iter().all(|e| e.1.is_finite()),
            "non-finite boundary coefficient at the face point {:?}",
            ctx.point([0; 3])
        );
        Ok(())
    }

    /// The net outflow per unit area through face `(axis, side)` (averaged over the face's
    /// tangential positions) of the radiance the solution `u` describes, read off the
    /// equation located at L_0^0: `√(4π) h × Σ w (u_g − u_{c0})` over the row's terms that
    /// reach across the face, i.e. `√(4π)` times the flux of the row's divergence through
    /// the face (the closed ghost minus the reflecting closure, which has no flux). This is
    /// `J·n` when the L_0^0 equation is the continuity equation
    /// `∇·J/√(4π) + σ_a L_0^0 = Q_0^0` in the normalisation of the P_N equations (the
    /// shipped CDA, SP_1 and SP_3 files, whose L_0^0 equations have the source `Q(0, 0)`
    /// with coefficient 1).
    pub fn face_outflow(
        &self,
        problem: &Problem,
        kernel: &dyn StencilKernel,
        layout: &Layout,
        u: &[f64],
        (axis, side): (usize, usize),
    ) -> Result<f64> {
        ensure!(
            self.faces[axis][side],
            "face {axis}/{side} is not a Marshak face closed by the PDE's conditions"
        );
        let q0 = layout
            .moments
            .iter()
            .position(|m| m.l == 0 && m.m == 0 && m.shift[axis] == 0)
            .context("the stencil has no cell-centred L_0^0")?;
        let e = layout.extents[q0];
        let c0 = if side == 0 { 0 } else { e[axis] - 1 };
        let (a, b) = ((axis + 1) % 3, (axis + 2) % 3);
        let pattern = kernel.pattern(q0);
        let mut weights = vec![0.0; pattern.len()];
        let mut entries = Vec::new();
        let mut ctx = RowContext::new(problem, [0; 3]);
        let mut total = 0.0;
        for ia in 0..e[a] {
            for ib in 0..e[b] {
                let mut idx = [0usize; 3];
                idx[axis] = c0;
                idx[a] = ia;
                idx[b] = ib;
                let pos = layout.half_coord(q0, idx);
                ctx.set_row(pos);
                kernel.eval_row(q0, &ctx, &mut weights);
                if let Some(err) = ctx.take_error() {
                    return Err(err).context("invalid scene coefficients");
                }
                for (t, &w) in pattern.iter().zip(&weights) {
                    let half = [0, 1, 2].map(|d| pos[d] + t.offset[d] as i64);
                    if self.crossing(layout, t.moment, half) != Some((axis, side)) {
                        continue;
                    }
                    entries.clear();
                    self.ghost(
                        problem,
                        layout,
                        t.moment,
                        half,
                        (axis, side),
                        w,
                        &mut entries,
                    )?;
                    let ghost: f64 = entries.iter().map(|&(col, v)| v * u[col]).sum();
                    // The reflecting closure: the same moment at the nearest centre.
                    let mut near = idx;
                    for d in 0..3 {
                        let raw = (half[d] - 1 + i64::from(layout.moments[t.moment].shift[d]))
                            .div_euclid(2);
                        let max = layout.extents[t.moment][d] as i64 - 1;
                        near[d] = raw.clamp(0, max) as usize;
                    }
                    total += ghost - w * u[layout.index(t.moment, near)];
                }
            }
        }
        let s4pi = (4.0 * std::f64::consts::PI).sqrt();
        Ok(s4pi * self.h[axis] * total / (e[a] * e[b]) as f64)
    }
}

/// Solves the small dense system `m x = rhs`; `None` when `m` is singular (a pivot below
/// 1e-13 of the largest entry, [`pn_krylov::linalg::solve_small_dense`]).
fn solve_dense(m: Vec<Vec<f64>>, rhs: Vec<f64>) -> Option<Vec<f64>> {
    let scale = m.iter().flatten().fold(0.0f64, |s, v| s.max(v.abs()));
    if !(scale > 0.0 && scale.is_finite()) {
        return None;
    }
    pn_krylov::linalg::solve_small_dense(m, rhs, 1e-13 * scale)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn dense_solve_and_singular() {
        let x = solve_dense(vec![vec![0.0, 2.0], vec![1.0, 1.0]], vec![4.0, 3.0]).unwrap();
        assert!(
            (x[0] - 1.0).abs() < 1e-15 && (x[1] - 2.0).abs() < 1e-15,
            "{x:?}"
        );
        assert!(solve_dense(vec![vec![1.0, 2.0], vec![2.0, 4.0]], vec![1.0, 0.0]).is_none());
        assert!(solve_dense(vec![vec![0.0]], vec![1.0]).is_none());
    }
}
