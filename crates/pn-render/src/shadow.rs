//! Transmittance through the filtered medium and deep shadow maps.
//!
//! The optical depth along a segment is **exact** (to rounding) for both voxel filters of
//! [`super::medium`]:
//!
//! * nearest: a 3D DDA (Amanatides & Woo, `walk_lattice`) visits every voxel the segment
//!   crosses and sums σ_t·(length inside the voxel);
//! * trilinear: the field ρ = Σ ρ_ijk φ_i(x) φ_j(y) φ_k(z) is, inside each cell of the
//!   lattice of voxel **centres** (and in the clamped outer half-voxel slabs, where it is
//!   constant along the clamped axes), a product of three functions linear in x, y, z, so
//!   along a line it is a polynomial of degree ≤ 3 in t. The same DDA on that dual lattice
//!   (planes at the voxel centres, the box faces as the ends) cuts the segment where the
//!   polynomial changes, and 2-point Gauss–Legendre per piece (exact for degree 3)
//!   integrates it exactly. Each dual cell's 8 voxels are read once, and cells whose 8
//!   voxels are empty are skipped ([`Extinction::optical_depth`]); a column of depths at
//!   many points along one ray is one traversal ([`Extinction::optical_depth_at_marks`]).
//!
//! Transmittance T = exp(−optical depth).
//!
//! A deep shadow map (docs/design.md §6, "T is the transmittance to the light") stores T from
//! every solve-cell centre to each light; it is computed in parallel with rayon. It serves the
//! cell-centre source [`super::first_scatter::source_moments`]; a render reads its optical
//! depth from [`super::light_depth::LightDepth`], computed once for the source and the camera.

use super::lights::Light;
use super::medium::floor_fast;
use super::medium::{DensityFilter, DensityGrid};
use pn_runtime::problem::Grid;
#[cfg(test)]
use rayon::prelude::*;

/// The extinction field σ_t = `scale` × density, with exact ray integrals.
#[derive(Clone, Debug)]
pub struct Extinction<'a> {
    /// The density.
    pub grid: &'a DensityGrid,
    /// σ_t per unit density.
    pub scale: f64,
}

impl Extinction<'_> {
    /// σ_t at `p` (0 outside the box).
    pub fn sigma_t(&self, p: [f64; 3]) -> f64 {
        self.scale * self.grid.density_at(p)
    }

    /// The largest σ_t (the global majorant of delta tracking).
    pub fn majorant(&self) -> f64 {
        self.scale * self.grid.max_density()
    }

    /// Parameter interval `[t0, t1]` (t ≥ 0) in which `origin + t·dir` is inside the box,
    /// clipped to `[0, tmax]`; `None` if the segment misses it.
    pub fn clip(&self, origin: [f64; 3], dir: [f64; 3], tmax: f64) -> Option<(f64, f64)> {
        let g = self.grid;
        let (mut t0, mut t1) = (0.0f64, tmax);
        for d in 0..3 {
            if dir[d] == 0.0 {
                if origin[d] < g.bbox_min[d] || origin[d] > g.bbox_max[d] {
                    return None;
                }
                continue;
            }
            let inv = 1.0 / dir[d];
            let (mut a, mut b) = (
                (g.bbox_min[d] - origin[d]) * inv,
                (g.bbox_max[d] - origin[d]) * inv,
            );
            if a > b {
                std::mem::swap(&mut a, &mut b);
            }
            t0 = t0.max(a);
            t1 = t1.min(b);
        }
        (t0 < t1).then_some((t0, t1))
    }

    /// Optical depth ∫σ_t along `origin + t·dir`, `t ∈ [0, tmax]`, `dir` a unit vector
    /// (other lengths give ∫σ_t dt in units of t), exact for the grid's filter (module docs).
    pub fn optical_depth(&self, origin: [f64; 3], dir: [f64; 3], tmax: f64) -> f64 {
        let mut tau = 0.0;
        self.walk_pieces(origin, dir, tmax, |a, b, piece| {
            tau += piece.integral(a, b);
            true
        });
        self.scale * tau
    }

    /// The optical depth from `origin` to each of the increasing parameters `marks` along
    /// `dir` (`τ(marks[i])`, exact as [`Self::optical_depth`]), in one traversal. Once a
    /// depth exceeds `cutoff` the walk stops and the later marks get +∞.
    pub fn optical_depth_at_marks(
        &self,
        origin: [f64; 3],
        dir: [f64; 3],
        marks: &[f64],
        cutoff: f64,
        out: &mut [f64],
    ) {
        let Some(&last) = marks.last() else {
            return;
        };
        let mut tau = 0.0;
        let mut next = 0;
        let mut past_cutoff = false;
        // Marks at or before `t` get the depth accumulated so far (the pieces between them
        // and `t`, if any, were empty); false once the cutoff is passed.
        let mut settle = |t: f64, tau: f64, next: &mut usize, past: &mut bool| {
            while *next < marks.len() && marks[*next] <= t {
                out[*next] = tau;
                *next += 1;
                if tau > cutoff {
                    *past = true;
                    return false;
                }
            }
            true
        };
        self.walk_pieces(origin, dir, last, |a, b, piece| {
            if !settle(a, self.scale * tau, &mut next, &mut past_cutoff) {
                return false;
            }
            let mut from = a;
            while next < marks.len() && marks[next] <= b {
                tau += piece.integral(from, marks[next]);
                from = marks[next];
                if !settle(from, self.scale * tau, &mut next, &mut past_cutoff) {
                    return false;
                }
            }
            tau += piece.integral(from, b);
            true
        });
        if !past_cutoff {
            settle(f64::INFINITY, self.scale * tau, &mut next, &mut past_cutoff);
        }
        for v in &mut out[next..marks.len()] {
            *v = f64::INFINITY;
        }
    }

    /// Calls `visit(t_enter, t_exit, piece)` for every piece of the segment `origin + t·dir`,
    /// `t ∈ [0, tmax]`, inside the box on which the filtered density is one polynomial, in
    /// order, skipping pieces where it vanishes, until `visit` returns false.
    fn walk_pieces(
        &self,
        origin: [f64; 3],
        dir: [f64; 3],
        tmax: f64,
        mut visit: impl FnMut(f64, f64, &Piece) -> bool,
    ) {
        let g = self.grid;
        let Some((t0, t1)) = self.clip(origin, dir, tmax) else {
            return;
        };
        match g.filter {
            DensityFilter::Nearest => {
                walk_lattice(origin, dir, t0, t1, g.bbox_min, g.h(), g.res, |a, b, c| {
                    let rho = g.at(c[0] as usize, c[1] as usize, c[2] as usize);
                    rho <= 0.0 || visit(a, b, &Piece::Constant(rho))
                });
            }
            DensityFilter::Trilinear => {
                // Dual lattice: cell 0 is [bbox_min − h/2, c_0], cell n is [c_{n−1}, bbox_max
                // + h/2]; the box clip cuts the outer ones to the half-voxel slabs. Inside dual
                // cell c the field is the trilinear blend of the 8 voxels (c−1, c) per axis
                // (clamped to the grid: constant along an axis in its outer slabs), so the
                // corners are read once per cell and cells with 8 empty corners are skipped.
                let h = g.h();
                let lo = [0, 1, 2].map(|d| g.bbox_min[d] - 0.5 * h[d]);
                let n = g.res.map(|v| v + 1);
                // Voxel-centre coordinate u = (x − bbox_min)·res/extent − ½ (as `sample`).
                let scale = [0, 1, 2].map(|d| g.res[d] as f64 / (g.bbox_max[d] - g.bbox_min[d]));
                let [rx, ry, _] = g.res;
                let data = &g.data;
                walk_lattice(origin, dir, t0, t1, lo, h, n, |a, b, cell| {
                    let pair = |d: usize| {
                        let top = g.res[d] as i64 - 1;
                        (
                            (cell[d] - 1).clamp(0, top) as usize,
                            cell[d].clamp(0, top) as usize,
                        )
                    };
                    let ((x0, x1), (y0, y1), (z0, z1)) = (pair(0), pair(1), pair(2));
                    let at = |i: usize, j: usize, k: usize| data[(k * ry + j) * rx + i] as f64;
                    // c[z][y][x] with 0 = the lower voxel of the pair.
                    let c = [z0, z1].map(|k| [y0, y1].map(|j| [at(x0, j, k), at(x1, j, k)]));
                    if c.iter().flatten().flatten().all(|v| *v == 0.0) {
                        return true;
                    }
                    // Fraction inside the cell at t: base + t·slope (the lower voxel's centre
                    // is at u = c − 1).
                    let base = [0, 1, 2].map(|d| {
                        (origin[d] - g.bbox_min[d]) * scale[d] - 0.5 - (cell[d] - 1) as f64
                    });
                    let slope = [0, 1, 2].map(|d| dir[d] * scale[d]);
                    visit(a, b, &Piece::Trilinear { c, base, slope })
                });
            }
        }
    }

    /// Transmittance from `x` to `light` (T = exp(−τ)); 1 for a point light at `x`.
    pub fn transmittance_to(&self, x: [f64; 3], light: &Light) -> f64 {
        let inc = light.incident(x);
        if inc.distance == 0.0 {
            return 1.0;
        }
        let back = inc.travel.map(|c| -c);
        (-self.optical_depth(x, back, inc.distance)).exp()
    }
}

/// The filtered density on one piece of a ray ([`Extinction::walk_pieces`]).
enum Piece {
    /// Constant (the nearest filter's voxel).
    Constant(f64),
    /// The trilinear blend of the corners `c[z][y][x]` of a dual-lattice cell at the
    /// in-cell fractions `base + t·slope`.
    Trilinear {
        c: [[[f64; 2]; 2]; 2],
        base: [f64; 3],
        slope: [f64; 3],
    },
}

impl Piece {
    /// ∫ρ dt over `[a, b]` (same units as the ray parameter): exact, the trilinear blend
    /// being a cubic in t on the piece and 2-point Gauss–Legendre exact for cubics.
    #[inline]
    fn integral(&self, a: f64, b: f64) -> f64 {
        match self {
            Piece::Constant(rho) => rho * (b - a),
            Piece::Trilinear { c, base, slope } => {
                // Nodes ½ ∓ 1/(2√3) on [0, 1], weights ½.
                let off = 0.5 / 3f64.sqrt();
                let (len, mid) = (b - a, 0.5 * (a + b));
                let blend = |t: f64| {
                    let f = [0, 1, 2].map(|d| base[d] + t * slope[d]);
                    let lerp = |p: f64, q: f64, w: f64| p + w * (q - p);
                    let row = |r: [f64; 2]| lerp(r[0], r[1], f[0]);
                    let plane = |pl: [[f64; 2]; 2]| lerp(row(pl[0]), row(pl[1]), f[1]);
                    lerp(plane(c[0]), plane(c[1]), f[2])
                };
                0.5 * len * (blend(mid - off * len) + blend(mid + off * len))
            }
        }
    }
}

/// The 3D DDA (Amanatides & Woo) on the uniform lattice with lower corner `lo`, spacing `h`
/// and `n` cells per axis: calls `visit(t_enter, t_exit, cell)` for every cell the segment
/// `origin + t·dir`, t ∈ [t0, t1], crosses, in order, until `visit` returns false. The
/// segment's start must lie in the lattice; a start exactly on a plane while moving down
/// belongs to the cell below. Shared by the exact optical depth and the renderer's march.
#[allow(clippy::too_many_arguments)]
pub(crate) fn walk_lattice(
    origin: [f64; 3],
    dir: [f64; 3],
    t0: f64,
    t1: f64,
    lo: [f64; 3],
    h: [f64; 3],
    n: [usize; 3],
    mut visit: impl FnMut(f64, f64, [i64; 3]) -> bool,
) {
    let mut cell = [0i64; 3];
    let mut step = [0i64; 3];
    let mut t_next = [f64::INFINITY; 3];
    let mut t_delta = [f64::INFINITY; 3];
    for d in 0..3 {
        let p = origin[d] + t0 * dir[d];
        let u = (p - lo[d]) / h[d];
        let mut c = floor_fast(u) as i64;
        if dir[d] < 0.0 && u == floor_fast(u) {
            c -= 1; // on a plane, moving down: the cell below
        }
        c = c.clamp(0, n[d] as i64 - 1);
        cell[d] = c;
        if dir[d] > 0.0 {
            step[d] = 1;
            let face = lo[d] + (c + 1) as f64 * h[d];
            t_next[d] = (face - origin[d]) / dir[d];
            t_delta[d] = h[d] / dir[d];
        } else if dir[d] < 0.0 {
            step[d] = -1;
            let face = lo[d] + c as f64 * h[d];
            t_next[d] = (face - origin[d]) / dir[d];
            t_delta[d] = -h[d] / dir[d];
        }
    }
    let mut t = t0;
    loop {
        // Axis with the nearest plane crossing.
        let a = if t_next[0] <= t_next[1] && t_next[0] <= t_next[2] {
            0
        } else if t_next[1] <= t_next[2] {
            1
        } else {
            2
        };
        let t_exit = t_next[a].min(t1);
        if t_exit > t && !visit(t, t_exit, cell) {
            return;
        }
        if t_next[a] >= t1 {
            return;
        }
        t = t_exit;
        cell[a] += step[a];
        if cell[a] < 0 || cell[a] >= n[a] as i64 {
            return;
        }
        t_next[a] += t_delta[a];
    }
}

/// Transmittance from every cell centre of `grid` to each light: `maps[light][cell]` with
/// cells in the solve grid's order (x slowest, `(i·ny + j)·nz + k`).
/// Only the tests use them now (the pipeline reads the [`crate::light_depth::LightDepth`] grid).
#[cfg(test)]
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct DeepShadowMaps {
    /// One map per light.
    pub(crate) maps: Vec<Vec<f64>>,
}

#[cfg(test)]
impl DeepShadowMaps {
    /// Computes the maps in parallel (one ray per cell centre and light).
    pub(crate) fn compute(ext: &Extinction, grid: &Grid, lights: &[Light]) -> Self {
        Self::compute_where(ext, grid, lights, |_| true)
    }

    /// [`Self::compute`] at the cells `(i, j, k)` where `wanted` holds; the others hold 0.
    pub(crate) fn compute_where(
        ext: &Extinction,
        grid: &Grid,
        lights: &[Light],
        wanted: impl Fn([usize; 3]) -> bool + Sync,
    ) -> Self {
        let [nx, ny, nz] = grid.res;
        let maps = lights
            .iter()
            .map(|light| {
                (0..nx * ny * nz)
                    .into_par_iter()
                    .map(|c| {
                        let cell = [c / (ny * nz), (c / nz) % ny, c % nz];
                        if wanted(cell) {
                            ext.transmittance_to(cell_centre(grid, cell), light)
                        } else {
                            0.0
                        }
                    })
                    .collect()
            })
            .collect();
        Self { maps }
    }
}

/// The density grid's voxels as a [`Grid`] (cell centres = voxel centres); for the tests.
#[cfg(test)]
pub(crate) fn density_as_grid(density: &DensityGrid) -> Grid {
    Grid {
        dim: pn_stencil::Dim::Three,
        min: density.bbox_min,
        max: density.bbox_max,
        res: density.res,
    }
}

/// Whether each voxel of `g` (linear index `(i·ny + j)·nz + k`, x slowest) lies within one
/// voxel (the 26-neighbourhood) of a voxel with non-zero density. A trilinear read of a
/// voxel-centre grid at a point of non-zero density (either filter) reads only the 8
/// centres around it, which all lie there ([`super::light_depth::LightDepth::compute`]).
pub(crate) fn near_medium_mask(g: &DensityGrid) -> Vec<bool> {
    let [nx, ny, nz] = g.res;
    let mut near = vec![false; nx * ny * nz];
    let span = |c: usize, n: usize| c.saturating_sub(1)..=(c + 1).min(n - 1);
    for k in 0..nz {
        for j in 0..ny {
            for i in 0..nx {
                if g.at(i, j, k) == 0.0 {
                    continue;
                }
                for a in span(i, nx) {
                    for b in span(j, ny) {
                        for c in span(k, nz) {
                            near[(a * ny + b) * nz + c] = true;
                        }
                    }
                }
            }
        }
    }
    near
}

/// World position of the centre of cell (i, j, k) of `grid`.
pub fn cell_centre(grid: &Grid, c: [usize; 3]) -> [f64; 3] {
    [0, 1, 2].map(|d| grid.coord(d, 2 * c[d] as i64 + 1))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn homogeneous(n: usize) -> DensityGrid {
        DensityGrid::new([n; 3], [-1.0; 3], [1.0; 3], vec![1.0; n * n * n]).unwrap()
    }

    #[test]
    fn homogeneous_box_matches_beer_lambert() {
        let g = homogeneous(7);
        let ext = Extinction {
            grid: &g,
            scale: 2.5,
        };
        // From inside the box along an oblique direction to the box face: the length is
        // the distance to the first face crossed (exact up to rounding: ~1e-15 relative).
        let x = [0.1, -0.3, 0.2];
        let d = [0.3f64, 0.5, -0.8];
        let n = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
        let d = d.map(|c| c / n);
        let len = (0..3)
            .map(|a| {
                let face = if d[a] > 0.0 { 1.0 } else { -1.0 };
                (face - x[a]) / d[a]
            })
            .fold(f64::INFINITY, f64::min);
        let tau = ext.optical_depth(x, d, f64::INFINITY);
        assert!((tau - 2.5 * len).abs() < 1e-12, "{tau} vs {}", 2.5 * len);
        let light = Light::Directional {
            direction: d.map(|c| -c),
            irradiance: 1.0,
        };
        assert!((ext.transmittance_to(x, &light) - (-2.5 * len).exp()).abs() < 1e-14);
        // A segment from outside through the whole box along x: length 2.
        let tau = ext.optical_depth([-3.0, 0.05, 0.05], [1.0, 0.0, 0.0], 10.0);
        assert!((tau - 5.0).abs() < 1e-12);
        // A segment that stops inside: length 1.5.
        let tau = ext.optical_depth([-3.0, 0.05, 0.05], [1.0, 0.0, 0.0], 3.5);
        assert!((tau - 2.5 * 1.5).abs() < 1e-12);
        // Missing the box.
        assert_eq!(
            ext.optical_depth([-3.0, 2.0, 0.0], [1.0, 0.0, 0.0], 10.0),
            0.0
        );
    }

    #[test]
    fn two_voxels_by_hand() {
        // Voxels [0,1] (density 1) and [1,2] (density 3) along x, σ_t = 2·density.
        let g = DensityGrid::new([2, 1, 1], [0.0; 3], [2.0, 1.0, 1.0], vec![1.0, 3.0])
            .unwrap()
            .with_filter(DensityFilter::Nearest);
        let ext = Extinction {
            grid: &g,
            scale: 2.0,
        };
        // Diagonal in the x–y plane from (0.5, 0) to (1.5, 1): half the length (√2/2) in each.
        let s = 0.5f64.sqrt();
        let tau = ext.optical_depth([0.5, 0.0, 0.5], [s, s, 0.0], 2f64.sqrt());
        let expect = 2.0 * 1.0 * s + 2.0 * 3.0 * s;
        assert!((tau - expect).abs() < 1e-14, "{tau} vs {expect}");
        // Point light at (1.75, 0.5, 0.5) seen from (0.25, 0.5, 0.5): 0.75 in the first
        // voxel, 0.75 in the second.
        let light = Light::Point {
            position: [1.75, 0.5, 0.5],
            power: 1.0,
        };
        let t = ext.transmittance_to([0.25, 0.5, 0.5], &light);
        assert!((t - (-(2.0 * 0.75 + 6.0 * 0.75f64)).exp()).abs() < 1e-15);
        // The light inside the medium works from either side.
        let t2 = ext.transmittance_to([1.75, 0.5, 0.5], &light);
        assert_eq!(t2, 1.0);
    }

    /// Trilinear, by hand: the 2-voxel grid above (values 1, 3 at x = 0.5, 1.5) along x is
    /// 1 on [0, 0.5], 1 + 2(x − 0.5) on [0.5, 1.5], 3 on [1.5, 2]; ∫ from 0.25 to 1.75 =
    /// 0.25 + 2 + 0.75 = 3, and over the whole box 0.5 + 2 + 1.5 = 4 (= Σρ_i h, as nearest).
    #[test]
    fn trilinear_two_voxels_by_hand() {
        let g = DensityGrid::new([2, 1, 1], [0.0; 3], [2.0, 1.0, 1.0], vec![1.0, 3.0]).unwrap();
        let ext = Extinction {
            grid: &g,
            scale: 2.0,
        };
        let tau = ext.optical_depth([0.25, 0.5, 0.5], [1.0, 0.0, 0.0], 1.5);
        assert!((tau - 6.0).abs() < 1e-14, "{tau}");
        let tau = ext.optical_depth([-1.0, 0.3, 0.7], [1.0, 0.0, 0.0], 10.0);
        assert!((tau - 8.0).abs() < 1e-14, "{tau}");
        // Backwards, from inside the ramp to the −x face: ∫_0^1 = 0.5 + (1 + 2)/2·0.5 = 1.25.
        let tau = ext.optical_depth([1.0, 0.5, 0.5], [-1.0, 0.0, 0.0], f64::INFINITY);
        assert!((tau - 2.5).abs() < 1e-14, "{tau}");
    }

    /// A linear density ρ = 1 + x + 2y − z sampled at the voxel centres: trilinear
    /// reproduces it exactly between the outermost centres (and clamps it outside them), so
    /// the optical depth of a segment inside the centres' box is its length times ρ at its
    /// midpoint; one through the whole box adds the clamped slabs, by hand.
    #[test]
    fn trilinear_linear_ramp_is_analytic() {
        let n = [5, 4, 6];
        let (lo, hi) = ([-1.0, 0.0, 0.5], [1.0, 2.0, 2.0]);
        let mut g = DensityGrid::new(n, lo, hi, vec![0.0; 120]).unwrap();
        let h = g.h();
        let rho = |p: [f64; 3]| 3.0 + p[0] + 2.0 * p[1] - p[2];
        for k in 0..n[2] {
            for j in 0..n[1] {
                for i in 0..n[0] {
                    let c = [i, j, k];
                    let x = [0, 1, 2].map(|d| lo[d] + (c[d] as f64 + 0.5) * h[d]);
                    let idx = g.index(i, j, k);
                    g.data[idx] = rho(x) as f32;
                }
            }
        }
        let ext = Extinction {
            grid: &g,
            scale: 1.5,
        };
        // f32 storage: values carry ~1e-7 relative rounding.
        let (a, b) = ([-0.7, 0.3, 0.7], [0.75, 1.7, 1.8]);
        let len = ((0..3).map(|d| (b[d] - a[d]) * (b[d] - a[d])).sum::<f64>()).sqrt();
        let dir = [0, 1, 2].map(|d| (b[d] - a[d]) / len);
        let mid = [0, 1, 2].map(|d| 0.5 * (a[d] + b[d]));
        let tau = ext.optical_depth(a, dir, len);
        let expect = 1.5 * len * rho(mid);
        assert!((tau - expect).abs() < 1e-6 * expect, "{tau} vs {expect}");
        // Along x through the whole box at interior y, z: the ramp between the centres
        // x = −0.8 and 0.8, constant (clamped) in the slabs [−1, −0.8] and [0.8, 1].
        let (y, z) = (0.9, 1.1);
        let r = |x: f64| rho([x, y, z]);
        let expect = 1.5 * (0.2 * r(-0.8) + 1.6 * r(0.0) + 0.2 * r(0.8));
        let tau = ext.optical_depth([-3.0, y, z], [1.0, 0.0, 0.0], 10.0);
        assert!((tau - expect).abs() < 1e-6 * expect, "{tau} vs {expect}");
    }

    /// A random 5×4×3 grid: the exact traversal against a fine composite midpoint rule over
    /// the part inside the box (200 000 points; for the continuous trilinear field its error
    /// is O(step²), ~1e-10 relative here), for segments that start
    /// outside, inside, end inside, run backwards and graze the box, for both filters.
    #[test]
    fn optical_depth_matches_brute_force_quadrature() {
        let mut state = 0x1234_5678_u64;
        let mut rand = || {
            state = state
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (state >> 11) as f64 / (1u64 << 53) as f64
        };
        let data: Vec<f32> = (0..60).map(|_| (rand() * 4.0) as f32).collect();
        let base = DensityGrid::new([5, 4, 3], [-1.0, -0.5, 0.0], [1.5, 1.5, 0.9], data).unwrap();
        for filter in [DensityFilter::Trilinear, DensityFilter::Nearest] {
            let g = base.clone().with_filter(filter);
            let ext = Extinction {
                grid: &g,
                scale: 0.7,
            };
            let segments: [([f64; 3], [f64; 3], f64); 5] = [
                ([-2.0, 0.1, 0.45], [3.0, 1.0, 0.05], 6.0),
                ([0.2, 0.3, 0.4], [-0.4, 0.7, 0.2], 5.0),
                ([0.2, 0.3, 0.4], [0.5, -0.6, 0.3], 0.8),
                ([1.4, 1.4, 0.85], [-1.0, -0.8, -0.35], 4.0),
                ([-1.0, -0.5, 0.3], [1.0, 0.0, 0.0], 2.5),
            ];
            for (o, d, tmax) in segments {
                let l = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
                let d = d.map(|c: f64| c / l);
                let tau = ext.optical_depth(o, d, tmax);
                // Over the part inside the box (the field jumps to 0 at its faces).
                let (t0, t1) = ext.clip(o, d, tmax).unwrap();
                let steps = 200_000;
                let dt = (t1 - t0) / steps as f64;
                let brute: f64 = (0..steps)
                    .map(|s| {
                        let t = t0 + (s as f64 + 0.5) * dt;
                        ext.sigma_t([0, 1, 2].map(|a| o[a] + t * d[a]))
                    })
                    .sum::<f64>()
                    * dt;
                assert!(brute > 0.0);
                // Nearest: the midpoint rule errs by O(dt) at each jump, ~3e-6 relative here.
                let tol = match filter {
                    DensityFilter::Trilinear => 1e-9,
                    DensityFilter::Nearest => 1e-4,
                };
                assert!(
                    (tau - brute).abs() < tol * brute,
                    "{filter:?} {o:?}: {tau} vs {brute}"
                );
            }
        }
    }

    /// The depths at marks from one traversal equal the sums of separate traversals of
    /// the intervals between them (both filters, marks inside and outside the box), and the
    /// marks after the first depth above the cutoff are +∞.
    #[test]
    fn optical_depth_at_marks_equals_interval_sums() {
        let data: Vec<f32> = (0..60).map(|v| ((v * 37) % 11) as f32 * 0.3).collect();
        let base = DensityGrid::new([5, 4, 3], [-1.0, -0.5, 0.0], [1.5, 1.5, 0.9], data).unwrap();
        let o = [-1.6, -0.2, 0.1];
        let l = (3.0f64 * 3.0 + 1.2 * 1.2 + 0.5 * 0.5).sqrt();
        let d = [3.0 / l, 1.2 / l, 0.5 / l];
        let marks: Vec<f64> = (1..=16).map(|k| 0.27 * k as f64).collect();
        for filter in [DensityFilter::Trilinear, DensityFilter::Nearest] {
            let g = base.clone().with_filter(filter);
            let ext = Extinction {
                grid: &g,
                scale: 1.3,
            };
            let mut at_marks = vec![0.0; marks.len()];
            ext.optical_depth_at_marks(o, d, &marks, f64::INFINITY, &mut at_marks);
            let mut sum = 0.0;
            let mut from = 0.0;
            for (m, got) in marks.iter().zip(&at_marks) {
                let start = [0, 1, 2].map(|q| o[q] + from * d[q]);
                sum += ext.optical_depth(start, d, m - from);
                from = *m;
                assert!(
                    (got - sum).abs() <= 1e-12 * sum.max(1.0),
                    "{filter:?} {m}: {got} vs {sum}"
                );
            }
            assert!(
                sum > 1.0 && at_marks[0] == 0.0,
                "the ray starts outside the box"
            );
            // Cut off at half the total: the first mark beyond it is kept, the rest +∞.
            let cut = 0.5 * sum;
            let mut cutoff = vec![0.0; marks.len()];
            ext.optical_depth_at_marks(o, d, &marks, cut, &mut cutoff);
            let first = at_marks.iter().position(|t| *t > cut).unwrap();
            assert_eq!(cutoff[..=first], at_marks[..=first]);
            assert!(cutoff[first + 1..].iter().all(|t| t.is_infinite()));
        }
    }

    #[test]
    fn shadow_maps_hold_one_value_per_cell_and_light() {
        let g = homogeneous(4);
        let ext = Extinction {
            grid: &g,
            scale: 1.0,
        };
        let grid = crate::test_box_grid([2, 2, 2]);
        let light = Light::Directional {
            direction: [0.0, 0.0, -1.0],
            irradiance: 1.0,
        };
        let m = DeepShadowMaps::compute(&ext, &grid, &[light]);
        // Cell (0,0,1) centre z = 0.5: depth 0.5 to the top face; (0,0,0): 1.5.
        assert!((m.maps[0][1] - (-0.5f64).exp()).abs() < 1e-15);
        assert!((m.maps[0][0] - (-1.5f64).exp()).abs() < 1e-15);
    }
}
