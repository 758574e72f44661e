//! The vacuum around a medium, treated where the transport equation allows it: a graded pure
//! absorber outside the medium's **convex hull**.
//!
//! Light that leaves the convex hull of a medium surrounded by vacuum never comes back: every
//! straight line meets a convex set in one interval, so a ray that has left the hull cannot
//! re-enter it. Outside the hull the exact transport solution inside the medium therefore does
//! not change when the vacuum is replaced by a pure absorber (σ_s = 0) of any strength. Inside
//! the hull (the concavities of a cloud) light can return, and the vacuum stays vacuum (the
//! σ_t threshold of [`pn_runtime::problem::Problem::sigma_t_min`]).
//!
//! Why it matters for P_N (issue 17, docs/design.md §6): in a near-vacuum cell the odd moments
//! are about −(1/σ_t) times the gradient of the even ones, so the even moments are nearly
//! constant across it. An empty margin between the medium and the grid's absorbing boundary
//! then couples the medium's surface to that boundary as a short circuit; for P_1 in exact
//! vacuum φ is constant there and the outflow grows with the area of the outer boundary — the
//! darker image with the larger margin that the issue measured. Absorbing the vacuum outside
//! the hull removes the short circuit without touching the transport problem.
//!
//! The absorber is graded over a ramp of `ramp` cells ([`add_hull_absorber`]): a cell whose
//! centre lies δ cells outside the hull gets `σ_t ≥ min(1, δ/ramp)²·τ/h` with
//! τ = [`super::solve_setup::ABSORBER_OPTICAL_DEPTH_PER_CELL`].
//!
//! **The ramp is fixed in space, not in cells** ([`super::scene::SolveSettings::ramp_cells`],
//! default 1/6 of the solve cells across the medium box). The continuous P_N equations with
//! a pure absorber reflect nothing in 1-D; their staggered discretization does: a jump of
//! σ_t·h between two cells reflects part of the light that reaches it, by the same share at
//! every N (about 0.14 per unit jump of σ_t·h, `scripts/absorber-reflection.py`:
//! a 1-cell ramp reflects 0.12–0.15 of the amplitude at P_1…P_15, a 4-cell ramp 0.06, an
//! 8-cell one 0.02). A ramp of a fixed number of cells is the same discrete problem at every
//! h, so its reflection never goes away and the image does not converge as h → 0: with the
//! former 1-cell default the cumulus' P_5 mean went −2.1 / +2.1 / +3.2 / +4.9 % against
//! Mitsuba at 12³ / 24³ / 32³ / 48³, while a ramp of fixed width (1 / 2 / 4 cells at
//! 12³ / 24³ / 48³) gives −2.1 / −0.2 / −0.3 % (docs/vacuum.md). A ramp fixed in space is
//! resolved as h → 0, its reflection vanishes, and what remains is the P_N problem with a
//! smooth absorber outside the hull, which converges to transport as N → ∞.
//!
//! The hull is approximated from outside by the polytope ⋂_k {x : n_k·x ≤ s_k} over the
//! directions n_k of [`hull_directions`], with s_k the largest n_k·x over the corners of the
//! solve cells that hold medium (σ_t > 0 before any threshold). It contains the true hull,
//! so nothing is absorbed where light could return; the distance δ is the largest
//! n_k·x − s_k (the distance to the polytope for points whose nearest feature is a facet, a
//! lower bound elsewhere).

use pn_runtime::problem::Grid;

/// Directions per cube-face axis of [`hull_directions`]: a `HULL_GRID × HULL_GRID` grid on
/// each face of the cube, 6·HULL_GRID² directions (150), normalised.
pub const HULL_GRID: usize = 5;

/// The outward normals of the hull polytope: points of a `HULL_GRID × HULL_GRID` grid on each
/// face of the cube [−1, 1]³ (the face centres, edge and corner directions included),
/// normalised. They contain the 26 directions of the faces, edges and corners of the cube,
/// so the polytope is at least as tight as the bounding box with its edges and corners cut.
pub fn hull_directions() -> Vec<[f64; 3]> {
    let mut out = Vec::with_capacity(6 * HULL_GRID * HULL_GRID);
    let t = |i: usize| -1.0 + 2.0 * i as f64 / (HULL_GRID - 1) as f64;
    for axis in 0..3 {
        for sign in [-1.0, 1.0] {
            for a in 0..HULL_GRID {
                for b in 0..HULL_GRID {
                    let mut n = [0.0; 3];
                    n[axis] = sign;
                    n[(axis + 1) % 3] = t(a);
                    n[(axis + 2) % 3] = t(b);
                    let len = dot(&n, &n).sqrt();
                    out.push(n.map(|c| c / len));
                }
            }
        }
    }
    out
}

fn dot(a: &[f64; 3], b: &[f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

/// Distance in cells (of the smallest cell side) of every cell centre of `grid` outside the
/// hull polytope of the cells with `medium[c] > 0` (0 inside it; x slowest, as
/// [`super::solve_setup::cell_average`]). `None` when no cell holds medium.
pub fn hull_depth(grid: &Grid, medium: &[f64]) -> Option<Vec<f64>> {
    let [nx, ny, nz] = grid.res;
    let h = [0, 1, 2].map(|d| grid.h(d));
    let hmin = h.iter().copied().fold(f64::INFINITY, f64::min);
    let dirs = hull_directions();
    let mut support = vec![f64::NEG_INFINITY; dirs.len()];
    let mut any = false;
    let index = |i: usize, j: usize, k: usize| (i * ny + j) * nz + k;
    for i in 0..nx {
        for j in 0..ny {
            for k in 0..nz {
                if medium[index(i, j, k)] <= 0.0 {
                    continue;
                }
                any = true;
                // n·x over the cell is largest at the corner on n's side of every axis.
                let cell = [i, j, k];
                let lo = [0, 1, 2].map(|d| grid.min[d] + cell[d] as f64 * h[d]);
                for (s, n) in support.iter_mut().zip(&dirs) {
                    let corner = [0, 1, 2].map(|d| lo[d] + if n[d] > 0.0 { h[d] } else { 0.0 });
                    *s = s.max(dot(n, &corner));
                }
            }
        }
    }
    if !any {
        return None;
    }
    let mut depth = vec![0.0; nx * ny * nz];
    for i in 0..nx {
        for j in 0..ny {
            for k in 0..nz {
                let cell = [i, j, k];
                let x = [0, 1, 2].map(|d| grid.min[d] + (cell[d] as f64 + 0.5) * h[d]);
                let mut out = 0.0f64;
                for (s, n) in support.iter().zip(&dirs) {
                    out = out.max(dot(n, &x) - s);
                }
                depth[index(i, j, k)] = out / hmin;
            }
        }
    }
    Some(depth)
}

/// Raises σ_t outside the convex hull of the medium (`sigma_t > 0` on entry) to a pure
/// absorber graded over `ramp` cells: `σ_t ≥ min(1, δ/ramp)²·τ/h`, δ the distance of the cell
/// centre outside the hull in cells of the smallest side h (module docs). `ramp = 0` leaves
/// σ_t alone. Cells that hold medium are never changed (their centres lie inside the hull).
pub fn add_hull_absorber(grid: &Grid, ramp: f64, sigma_t: &mut [f64]) {
    if ramp <= 0.0 {
        return;
    }
    let Some(depth) = hull_depth(grid, sigma_t) else {
        return;
    };
    let hmin = (0..3).map(|d| grid.h(d)).fold(f64::INFINITY, f64::min);
    let full = super::solve_setup::ABSORBER_OPTICAL_DEPTH_PER_CELL / hmin;
    for (s, &delta) in sigma_t.iter_mut().zip(&depth) {
        if delta > 0.0 {
            let t = (delta / ramp).min(1.0);
            *s = s.max(t * t * full);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::test_box_grid;

    #[test]
    fn directions_are_unit_and_include_the_cube_corners() {
        let dirs = hull_directions();
        assert_eq!(dirs.len(), 6 * HULL_GRID * HULL_GRID);
        for n in &dirs {
            let len = dot(n, n).sqrt();
            assert!((len - 1.0).abs() < 1e-12);
        }
        let c = 1.0 / 3f64.sqrt();
        assert!(dirs
            .iter()
            .any(|n| n.iter().all(|&v| (v - c).abs() < 1e-12)));
    }

    /// A ball of medium: cells inside the hull (all of the ball's cells and the gaps of its
    /// staircase) are left alone, cells outside are graded with the distance, and the depth
    /// along an axis is the distance to the ball's outermost cell face.
    #[test]
    fn a_ball_is_left_alone_and_its_outside_is_graded() {
        let n = 20;
        let g = test_box_grid([n; 3]);
        let h = g.h(0);
        let centre = |c: usize| -1.0 + (c as f64 + 0.5) * h;
        let mut sigma_t = vec![0.0; n * n * n];
        for i in 0..n {
            for j in 0..n {
                for k in 0..n {
                    let r2 = centre(i).powi(2) + centre(j).powi(2) + centre(k).powi(2);
                    if r2 < 0.5 * 0.5 {
                        sigma_t[(i * n + j) * n + k] = 2.0;
                    }
                }
            }
        }
        let before = sigma_t.clone();
        let depth = hull_depth(&g, &sigma_t).unwrap();
        add_hull_absorber(&g, 4.0, &mut sigma_t);
        for c in 0..n * n * n {
            if before[c] > 0.0 {
                assert_eq!(sigma_t[c], before[c], "medium changed at {c}");
                assert_eq!(depth[c], 0.0);
            }
        }
        // Along +x from the centre row: the ball's last cell is i = 14 (centre 0.45),
        // its face at x = 0.5; cell 16 has its centre at 0.65, 1.5 cells out.
        let at = |i: usize| (i * n + n / 2) * n + n / 2;
        assert!((depth[at(16)] - 1.5).abs() < 1e-9, "{}", depth[at(16)]);
        let full = crate::solve_setup::ABSORBER_OPTICAL_DEPTH_PER_CELL / h;
        assert!((sigma_t[at(16)] - (1.5f64 / 4.0).powi(2) * full).abs() < 1e-9);
        assert!((sigma_t[at(19)] - full).abs() < 1e-9);
        // Monotone outward.
        for i in 15..n - 1 {
            assert!(sigma_t[at(i + 1)] >= sigma_t[at(i)]);
        }
        // A corner of the grid is far outside.
        assert!((sigma_t[0] - full).abs() < 1e-9);
        // A ramp of a fractional number of cells (a width fixed in space): 1.5/2.5 of the way.
        let mut frac = before.clone();
        add_hull_absorber(&g, 2.5, &mut frac);
        assert!((frac[at(16)] - (1.5f64 / 2.5).powi(2) * full).abs() < 1e-9);
        assert!((frac[at(17)] - full).abs() < 1e-9);
    }

    /// The gap of a C-shaped (non-convex) medium lies inside its hull: left as vacuum.
    #[test]
    fn a_concavity_stays_vacuum() {
        let n = 12;
        let g = test_box_grid([n; 3]);
        let mut sigma_t = vec![0.0; n * n * n];
        // Two slabs x ∈ cells 2..4 and 8..10, joined at y cells 2..4; everything in z 2..10.
        for i in 2..10 {
            for j in 2..10 {
                for k in 2..10 {
                    let slab = (2..4).contains(&i) || (8..10).contains(&i);
                    let bridge = (2..4).contains(&j);
                    if slab || bridge {
                        sigma_t[(i * n + j) * n + k] = 1.0;
                    }
                }
            }
        }
        let gap = (5 * n + 7) * n + 6;
        assert_eq!(sigma_t[gap], 0.0);
        add_hull_absorber(&g, 3.0, &mut sigma_t);
        assert_eq!(sigma_t[gap], 0.0, "the concavity must stay vacuum");
        assert!(
            sigma_t[(5 * n + 11) * n + 6] > 0.0,
            "outside the hull is absorbed"
        );
    }

    #[test]
    fn no_medium_and_no_ramp_change_nothing() {
        let g = test_box_grid([6; 3]);
        let mut empty = vec![0.0; 216];
        add_hull_absorber(&g, 4.0, &mut empty);
        assert!(empty.iter().all(|&v| v == 0.0));
        let mut one = vec![0.0; 216];
        one[100] = 1.0;
        let before = one.clone();
        add_hull_absorber(&g, 0.0, &mut one);
        assert_eq!(one, before);
    }
}
