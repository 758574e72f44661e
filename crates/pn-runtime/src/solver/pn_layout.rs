//! The one module of the solvers that reads the P_N unknown layout ([`crate::layout`]):
//! it turns the layout into the plain data the parity and multigrid solvers take (the
//! even/odd mask, the cell of every unknown, the classes and grid positions of
//! [`Geometry`]) and builds the solvers for a layout ([`SolverKind::solver_for`],
//! [`LayoutSolver`]).

use super::cgnr::Cgnr;
use super::multigrid::solve::mg_krylov;
use super::multigrid::Geometry;
use super::parity::split::Split;
use super::parity::{ParityCg, Precond};
use super::{LinearSolver, SolveStats, SolveStatus, SolverKind, SolverOptions};
use crate::layout::Layout;
use rayon::prelude::*;
use sprs::CsMat;

impl Geometry {
    /// The geometry of the unknowns `subset` of `layout` (global indices, in the order of
    /// the operator's rows), or of all unknowns when `subset` is `None`.
    pub fn from_layout(layout: &Layout, subset: Option<&[usize]>) -> Self {
        let locate = |g: usize| {
            let (q, idx) = layout.locate(g);
            (q as u32, idx.map(|v| v as u32))
        };
        let (class, coords) = match subset {
            Some(s) => s.par_iter().map(|&g| locate(g)).unzip(),
            None => {
                // Chunk by chunk, each position stepped from the previous one
                // (`Layout::positions_from`) instead of located by a search and divisions.
                const CHUNK: usize = 1 << 14;
                let n = layout.len();
                let mut class = vec![0u32; n];
                let mut coords = vec![[0u32; 3]; n];
                class
                    .par_chunks_mut(CHUNK)
                    .zip(coords.par_chunks_mut(CHUNK))
                    .enumerate()
                    .for_each(|(c, (cl, co))| {
                        let steps = layout.positions_from(c * CHUNK);
                        for ((cl, co), (q, idx)) in cl.iter_mut().zip(co).zip(steps) {
                            *cl = q as u32;
                            *co = idx.map(|v| v as u32);
                        }
                    });
                (class, coords)
            }
        };
        Self { class, coords }
    }
}

impl ParityCg {
    /// The solver for `layout` with [`Precond::Auto`] (ILU(0) up to
    /// [`super::parity::ILU_MAX_NONZEROS`], which needs the fewest iterations and time on
    /// the 71² checkerboard; else Jacobi). For very large systems,
    /// `Precond::BlockJacobi { block_of: cell_blocks(layout) }` is a cheaper alternative
    /// with somewhat fewer iterations than Jacobi.
    ///
    /// The layout also gives the unknowns' positions, so [`Precond::Auto`] resolves to
    /// multigrid for systems with at least [`super::parity::MG_MIN_NONZEROS`] stored
    /// entries.
    ///
    /// It keeps the parity [`Retained::for_layout`] picks (odd l for even N) and, when the
    /// system cannot be split that way, splits with the even-l moments kept.
    ///
    /// For even N the preconditioner is multigrid at every size: ILU(0) breaks down on the
    /// even-order systems in either parity (CG or BiCGSTAB stagnate at residuals 1e-2 to
    /// 1e2 on a dense ball in near-vacuum at P_2 and P_4, and on the 71² checkerboard,
    /// where multigrid needs 109–186 and 136–155 iterations).
    pub fn for_layout(layout: &Layout) -> Self {
        let precond = match Retained::for_layout(layout) {
            Retained::Odd => Precond::Multigrid,
            Retained::Even => Precond::Auto,
        };
        let (mask, fallback) = layout_masks(layout);
        Self::new(mask, precond)
            .with_fallback_mask(fallback)
            .with_layout_geometry(layout)
    }

    /// Records that the unknowns' classes and positions come from `layout` (needed by
    /// [`Precond::Multigrid`]): built by each solve's setup and dropped before its
    /// iterations ([`ParityCg::with_geometry_from`]).
    pub fn with_layout_geometry(self, layout: &Layout) -> Self {
        let layout = layout.clone();
        self.with_geometry_from(move || Geometry::from_layout(&layout, None))
    }
}

impl SolverKind {
    /// The solver for a system assembled on `layout`: the parity solvers take the even/odd
    /// classes from the layout (no detection pass over the matrix) and the unknowns'
    /// positions for multigrid (`parity-cg` picks it automatically for large systems,
    /// [`super::parity::MG_MIN_NONZEROS`]); the other kinds are as [`SolverKind::solver`].
    pub fn solver_for(self, layout: &Layout) -> Box<dyn LinearSolver> {
        match self.parity_solver_for(layout) {
            Some(s) => Box::new(s),
            None => self.solver(),
        }
    }

    /// For the parity kinds (`parity-cg`, `parity-mg`, `parity-ilu`), the layout solver
    /// [`SolverKind::solver_for`] uses, which can also solve from the parity blocks alone
    /// ([`LayoutSolver::solve_split`]); `None` for the other kinds.
    pub fn parity_solver_for(self, layout: &Layout) -> Option<LayoutSolver> {
        match self {
            SolverKind::ParityCg => Some(LayoutSolver::new(ParityCg::for_layout(layout), layout)),
            SolverKind::ParityMg => Some(LayoutSolver::new(
                ParityCg::for_layout(layout).with_precond(Precond::Multigrid),
                layout,
            )),
            SolverKind::ParityIlu => {
                let (mask, fallback) = layout_masks(layout);
                Some(LayoutSolver::without_multigrid(
                    ParityCg::new(mask, Precond::Auto).with_fallback_mask(fallback),
                ))
            }
            _ => None,
        }
    }
}

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
        split: &Split,
        b: &[f64],
        opts: &SolverOptions,
    ) -> (Vec<f64>, SolveStats) {
        self.solve_split_from(split, b, opts, &[])
    }

    /// [`LayoutSolver::solve_split`] started from the best combination of `guesses`
    /// ([`ParityCg::solve_split_from`]; the fallbacks start from them too).
    pub fn solve_split_from(
        &self,
        split: &Split,
        b: &[f64],
        opts: &SolverOptions,
        guesses: &[&[f64]],
    ) -> (Vec<f64>, SolveStats) {
        match self.parity.solve_split_from(split, b, opts, guesses) {
            Err(e @ crate::solver::parity::ParityError::GuessLength { .. }) => {
                failed_solve(b.len(), opts, &e.to_string())
            }
            Ok((u, report)) => (u, report.stats),
            Err(e) => {
                let jacobi_note = format!(
                    "note: the parity preconditioner could not be built ({e}); using Jacobi"
                );
                let jacobi = self.parity.clone().with_precond(Precond::Jacobi);
                match jacobi.solve_split_from(split, b, opts, guesses) {
                    Ok((u, report)) => (u, report.stats.with_note(jacobi_note)),
                    Err(e) => {
                        let none_note = format!(
                            "note: Jacobi could not be built either ({e}); unpreconditioned"
                        );
                        match jacobi
                            .with_precond(Precond::None)
                            .solve_split_from(split, b, opts, guesses)
                        {
                            Ok((u, report)) => {
                                (u, report.stats.with_note(jacobi_note).with_note(none_note))
                            }
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
            notes: vec![format!("error: the parity solve could not start: {why}")],
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
                        let (u, stats) = Cgnr.solve(a, b, opts);
                        let note =
                            format!("note: multigrid does not apply ({err}); falling back to cgnr");
                        (u, stats.with_note(note))
                    }
                },
                _ => super::parity::fallback::fallback(a, b, opts, &e.to_string()),
            },
        }
    }
}

/// Which moments the parity solvers keep as the unknowns of the reduced system `S`; the
/// moments of the other parity are eliminated (docs/design.md §5, "Which parity is kept").
///
/// The algebra is the same either way: `A = [[D_r, B], [C, D_x]]` with `D_x` diagonal gives
/// `S = D_r − B D_x⁻¹ C`. What differs is where the truncation sits. The highest band
/// `l = N` couples only to band `N − 1` (band `N + 1` is cut off). Kept, it lacks half of
/// its transport coupling: its modes with `|m| = N` about a direction `k` have no diffusion
/// along `k`, so in near-vacuum (σ_t ≈ the threshold) `S` has eigenvalues of order σ_t for
/// plane waves of every frequency, which neither smoothing nor a coarse grid removes.
/// Eliminated, every kept band couples fully to both neighbours. So the solvers keep the
/// parity *opposite* to `N`'s: even `l` for odd `N` (as always), odd `l` for even `N`.
/// On the cloud scene at 16³ this took P_4 from 1503 to 171 multigrid-CG iterations
/// (docs/solvers.md, "Even orders").
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Retained {
    /// Keep the even-l moments, eliminate the odd ones (odd `N`, and P_0).
    Even,
    /// Keep the odd-l moments, eliminate the even ones (even `N ≥ 2`). Needs the even
    /// moments' diagonal, for `l = 0` the absorption σ_a = σ_t − σ_s, to be non-zero;
    /// where it is not (albedo 1), [`Retained::Even`] is the fallback.
    Odd,
}

impl Retained {
    /// The parity opposite to the layout's highest band (see [`Retained`]).
    pub fn for_layout(layout: &Layout) -> Self {
        let top = layout.moments.iter().map(|m| m.l).max().unwrap_or(0);
        if top > 0 && top % 2 == 0 {
            Retained::Odd
        } else {
            Retained::Even
        }
    }

    /// Whether a moment of band `l` is kept.
    pub fn keeps(self, l: usize) -> bool {
        l.is_multiple_of(2) == (self == Retained::Even)
    }
}

/// `true` for the unknowns the parity solvers keep (`retained`), in the storage order of
/// `layout`. The parity blocks call them "even" (`D_e`, `B`, [`Split::even`]) whichever
/// parity they are.
pub fn retained_mask(layout: &Layout, retained: Retained) -> Vec<bool> {
    let mut mask = Vec::with_capacity(layout.len());
    for (q, mp) in layout.moments.iter().enumerate() {
        let n = layout.offsets[q + 1] - layout.offsets[q];
        mask.extend(std::iter::repeat_n(retained.keeps(mp.l as usize), n));
    }
    mask
}

/// `true` for the unknowns of even-l moments, in the storage order of `layout`
/// ([`retained_mask`] with [`Retained::Even`]).
pub fn even_mask(layout: &Layout) -> Vec<bool> {
    retained_mask(layout, Retained::Even)
}

/// The mask [`ParityCg::for_layout`] splits with first ([`Retained::for_layout`]), and
/// the even-l mask to fall back on when that one is [`Retained::Odd`].
fn layout_masks(layout: &Layout) -> (Vec<bool>, Option<Vec<bool>>) {
    match Retained::for_layout(layout) {
        Retained::Even => (even_mask(layout), None),
        Retained::Odd => (
            retained_mask(layout, Retained::Odd),
            Some(even_mask(layout)),
        ),
    }
}

/// Block id of every unknown: the grid cell it belongs to (a face or corner position at
/// index `s` belongs to cell `s`, the last one on an axis to the last cell), so that
/// block-Jacobi groups the even moments of one cell.
pub fn cell_blocks(layout: &Layout) -> Vec<usize> {
    let mut res = [1usize; 3];
    if let (Some(e), Some(mp)) = (layout.extents.first(), layout.moments.first()) {
        for d in 0..3 {
            res[d] = (e[d] - mp.shift[d] as usize).max(1);
        }
    }
    let mut out = Vec::with_capacity(layout.len());
    for (q, e) in layout.extents.iter().enumerate() {
        for i in 0..e[0] {
            for j in 0..e[1] {
                for k in 0..e[2] {
                    let c = [i.min(res[0] - 1), j.min(res[1] - 1), k.min(res[2] - 1)];
                    out.push((c[0] * res[1] + c[1]) * res[2] + c[2]);
                }
            }
        }
        debug_assert_eq!(out.len(), layout.offsets[q + 1]);
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::layout::Layout;
    use crate::problem::Grid;
    use pn_stencil::{Dim, MomentPlacement};

    /// The geometry of a whole layout, built chunk by chunk by stepping, is what
    /// [`Layout::locate`] gives for every unknown, across chunk and moment boundaries; the
    /// subset route agrees with it.
    #[test]
    fn geometry_from_layout_locates_every_unknown() {
        let grid = Grid {
            dim: Dim::Three,
            min: [0.0; 3],
            max: [1.0; 3],
            res: [29, 23, 19],
        };
        let moments: Vec<MomentPlacement> = [[0, 0, 0], [1, 0, 0], [0, 1, 1], [1, 1, 1]]
            .iter()
            .map(|&shift| MomentPlacement { l: 0, m: 0, shift })
            .collect();
        let layout = Layout::new(&grid, &moments).unwrap();
        assert!(layout.len() > 2 * (1 << 14));
        let g = Geometry::from_layout(&layout, None);
        assert_eq!(g.len(), layout.len());
        for i in 0..layout.len() {
            let (q, idx) = layout.locate(i);
            assert_eq!((g.class[i], g.coords[i]), (q as u32, idx.map(|v| v as u32)));
        }
        let subset: Vec<usize> = (0..layout.len()).step_by(7).collect();
        let s = Geometry::from_layout(&layout, Some(&subset));
        for (k, &i) in subset.iter().enumerate() {
            assert_eq!((s.class[k], s.coords[k]), (g.class[i], g.coords[i]));
        }
    }
}
