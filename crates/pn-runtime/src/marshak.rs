//! Marshak vacuum faces in assembly: the rows of the unknowns that sit on a Marshak face
//! become the face's Marshak conditions (docs/design.md §3, "Domain and boundary").
//!
//! On the staggered grid the moments odd under reflection in a face plane are exactly the
//! ones with positions on that face (both domain faces included), and they are as many as
//! the conditions: N(N+1)/2 per face position in 3D for odd N. Their rows, which would
//! otherwise reach across the face for the even moments half a cell outside, are replaced
//! by the condition [`pn_stencil::marshak::MarshakCondition`], derived from the half-range
//! Gram matrix:
//!
//! ```text
//!     (1/h_d) [ L_o(face) ± Σ_e 2G⁺_{oe} L_e(face) ] = 0      (+ min face, − max face)
//! ```
//!
//! (scaled by 1/h_d like the transport rows). The even moments on the face are taken at
//! the nearest centre, half a cell inside ([`FaceValue::Nearest`]: first order in h, the
//! conditions then hold half a cell inside the face), or extrapolated linearly from the
//! two nearest centres ([`FaceValue::Linear`]: second order). The default is
//! [`FaceValue::Linear`]; see docs/design.md §3 for the measured convergence of both.
//!
//! **Structure.** A condition couples its odd moment only to moments of the other
//! l-parity (`Y_l^m` has total parity `(−1)^l`), with the unit diagonal on its own moment, so
//! the system keeps the block form `[[D_e, B], [C, D_o]]` the parity solvers need. But it
//! breaks the skew-adjointness of the transport part at the face: the reduced operator
//! `S = D_e − B D_o⁻¹ C` gains the face term `(2/h) M^d G⁺` (with `Nearest`), which is
//! symmetric only when the products `ω_d Y_e` of the even moments stay within degree N
//! (P_1, and the 1D-like problems where only the moments with no azimuthal dependence about
//! the normal are excited) and not in general; with `Linear` it also couples the second
//! centre, which is never symmetric. The parity solvers detect the asymmetry with their
//! probes and take BiCGSTAB (or GMRES with multigrid) instead of CG.
//!
//! A position on two Marshak faces at once (an edge or corner unknown odd in both axes)
//! takes the condition of the first such axis (x before y before z). No other row
//! references such an unknown (its neighbours across either face are themselves Marshak
//! rows, which reference centres only), so the choice does not reach the rest of the
//! solution: a centred point source in a Marshak cube stays symmetric under x ↔ y to
//! rounding (`crates/pn-runtime/tests/marshak.rs`).

use crate::layout::Layout;
use crate::problem::{BoundaryKind, Problem};
use pn_stencil::marshak::{marshak_closure, MarshakClosure};
use pn_stencil::StencilKernel;

/// Refuses a stencil the derived Marshak rows cannot close: they replace the rows of the
/// face unknowns of the P_N equations, whose transport terms couple opposite l-parities only
/// (apart from a row's own centred term), so a row that couples equal parities elsewhere
/// (DP_N's substituted band, `pdes/dpn.pde`) would reach across the face unclosed. Such a
/// text PDE needs its own `boundary marshak` conditions (docs/pde-text.md).
pub fn check_pn_structure(kernel: &dyn StencilKernel) -> anyhow::Result<()> {
    let moments = kernel.moments();
    for (q, row) in moments.iter().enumerate() {
        for t in kernel.pattern(q) {
            let same = moments.get(t.moment).is_some_and(|p| p.l % 2 == row.l % 2);
            if same && !(t.moment == q && t.offset == [0, 0, 0]) {
                let p = &moments[t.moment];
                anyhow::bail!(
                    "the derived Marshak rows close the P_N equations, whose transport couples \
                     opposite l-parities; stencil {} couples moment ({},{}) to ({},{}) at offset \
                     {:?} (equal parity) and states no `boundary marshak` conditions \
                     (docs/pde-text.md); use --bc neumann or dirichlet",
                    kernel.name(),
                    row.l,
                    row.m,
                    p.l,
                    p.m,
                    t.offset
                );
            }
        }
    }
    Ok(())
}

/// How a Marshak condition evaluates the even moments on the face.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FaceValue {
    /// The value at the nearest centre, half a cell inside (first order).
    Nearest,
    /// Linear extrapolation from the two nearest centres, `(3 L_0 − L_1)/2` (second order;
    /// needs two cells along the face normal).
    Linear,
}

/// The face value the assembly uses.
pub const DEFAULT_FACE_VALUE: FaceValue = FaceValue::Linear;

/// The Marshak conditions of a problem: one closure per axis with a Marshak face.
#[derive(Clone, Debug)]
pub struct MarshakRows {
    /// Per axis: the closure, when one of the axis' faces is Marshak.
    closures: [Option<MarshakClosure>; 3],
    /// Per axis and side: whether the face is Marshak.
    faces: [[bool; 2]; 3],
    /// Cells per axis.
    res: [usize; 3],
    /// 1 / h per axis.
    inv_h: [f64; 3],
    /// How the even moments on the face are evaluated.
    face_value: FaceValue,
}

impl MarshakRows {
    /// The Marshak rows of `problem` for the moments of `layout`, or `None` when no face of
    /// the problem's axes is Marshak. Fails (naming the reason) when the stencil cannot take
    /// the condition: not the staggered P_N placement, an even order N (the conditions then
    /// do not match the face unknowns), or fewer than two cells across a Marshak face with
    /// [`FaceValue::Linear`].
    pub fn new(
        problem: &Problem,
        layout: &Layout,
        face_value: FaceValue,
    ) -> anyhow::Result<Option<Self>> {
        let grid = &problem.grid;
        let axes = grid.dim.axes();
        if !problem.boundary.has_marshak(axes) {
            return Ok(None);
        }
        let moments = &layout.moments;
        let order = moments.iter().map(|m| m.l).max().unwrap_or(0);
        anyhow::ensure!(
            moments.len() > 1 && moments.iter().any(|m| m.l == 0 && m.m == 0),
            "the Marshak boundary applies to the P_N equations only, and to text PDEs that \
             state `boundary marshak` conditions (docs/pde-text.md; diffusion with its \
             Marshak condition: --pde pdes/cda.pde); this stencil has {} unknown{} per cell \
             and states none; use --bc neumann or dirichlet",
            moments.len(),
            if moments.len() == 1 { "" } else { "s" }
        );
        anyhow::ensure!(
            order % 2 == 1,
            "the Marshak boundary needs an odd order N (it sets N(N+1)/2 half-range moments \
             per face, one per odd moment on the face; for even N the odd moments on the \
             face do not match the conditions), got N = {order}; use --order {} or {}",
            order - 1,
            order + 1
        );
        let faces = problem.boundary.faces();
        let mut marshak = [[false; 2]; 3];
        let mut closures: [Option<MarshakClosure>; 3] = [None, None, None];
        for d in 0..axes {
            marshak[d] = faces[d].map(|k| k == BoundaryKind::Marshak);
            if !(marshak[d][0] || marshak[d][1]) {
                continue;
            }
            let closure = marshak_closure(moments, d).map_err(|e| {
                anyhow::anyhow!(
                    "the Marshak boundary needs the staggered P_N stencil ({e}); drop \
                     --collocated or use --bc neumann or dirichlet"
                )
            })?;
            if face_value == FaceValue::Linear {
                anyhow::ensure!(
                    grid.res[d] >= 2,
                    "a Marshak face needs at least 2 cells along its normal (axis {d} has {})",
                    grid.res[d]
                );
            }
            closures[d] = Some(closure);
        }
        Ok(Some(Self {
            closures,
            faces: marshak,
            res: grid.res,
            inv_h: [0, 1, 2].map(|d| 1.0 / grid.h(d)),
            face_value,
        }))
    }

    /// Whether the row of moment `q` at position `idx` is a Marshak condition, and on
    /// which face: `Some((axis, side))`.
    pub fn face_of(&self, q: usize, idx: [usize; 3]) -> Option<(usize, usize)> {
        (0..3).find_map(|d| {
            let c = self.closures[d].as_ref()?;
            c.conditions.get(q)?.as_ref()?;
            // An odd moment has res + 1 positions: 0 is the min face, res the max face.
            let side = if idx[d] == 0 {
                0
            } else if idx[d] == self.res[d] {
                1
            } else {
                return None;
            };
            self.faces[d][side].then_some((d, side))
        })
    }

    /// The entries `(column, value)` of the Marshak row of moment `q` at `idx` on face
    /// `(axis, side)` (from [`MarshakRows::face_of`]), appended to `out`; the right-hand
    /// side is 0.
    pub fn row(
        &self,
        layout: &Layout,
        q: usize,
        idx: [usize; 3],
        (axis, side): (usize, usize),
        out: &mut Vec<(usize, f64)>,
    ) {
        let Some(cond) = self.closures[axis]
            .as_ref()
            .and_then(|c| c.conditions.get(q))
            .and_then(|c| c.as_ref())
        else {
            return;
        };
        let s = self.inv_h[axis];
        out.push((layout.index(q, idx), s));
        let sign = if side == 0 { 1.0 } else { -1.0 };
        // Centre indices along the axis: nearest first.
        let n = self.res[axis];
        let (c0, c1) = if side == 0 {
            (0, 1)
        } else {
            (n - 1, n.saturating_sub(2))
        };
        let weights: &[(usize, f64)] = match self.face_value {
            FaceValue::Nearest => &[(c0, 1.0)],
            FaceValue::Linear => &[(c0, 1.5), (c1, -0.5)],
        };
        for &(e, coeff) in &cond.terms {
            for &(c, w) in weights {
                let mut at = idx;
                at[axis] = c;
                out.push((layout.index(e, at), s * sign * coeff * w));
            }
        }
    }

    /// The largest number of entries of one Marshak row (for capacity bounds).
    pub fn max_row_len(&self) -> usize {
        let per = match self.face_value {
            FaceValue::Nearest => 1,
            FaceValue::Linear => 2,
        };
        self.closures
            .iter()
            .flatten()
            .flat_map(|c| c.conditions.iter().flatten())
            .map(|c| 1 + per * c.terms.len())
            .max()
            .unwrap_or(0)
    }
}
