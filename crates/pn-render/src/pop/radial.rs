//! Radial grids for point lights (POP paper §6): the octahedral map of directions around
//! the light ([`super::octahedral`]) × exponentially spaced shells, the once-scattered
//! source on it, the propagation of [`super::propagate`] on its neighbourhood, and the
//! conversion of the propagated powers into the fluence-like magnitudes the resampling
//! reads. The decisions on what §6 leaves open (docs/pop-design.md, "Point lights"):
//!
//! * **Extent.** Shells from r_min, the distance from the light to the medium's support box,
//!   to r_max, the distance to its farthest corner. A light inside or on that box (the
//!   paper's Fig. 10 has its light at the centre of a ball) gets r_min = half the smallest
//!   voxel side (below it the density has no detail; exponential shells cannot start at
//!   r = 0): shell 0 then stands for the ball r < r_1 down to the light (its source covers
//!   [0, r_1] with T at r_1/2), and what shell 0 sends inwards crosses the ball to the
//!   opposite cell of shell 0 (the map's antipode), 2 r_c of medium.
//! * **Shell spacing** ("grows exponentially, in proportion to the radial segment length at
//!   a given radius"): `r_k = r_min q^k`, k = 0..=N, with `ln q` the mean angular width of a
//!   cell, `√(4π)/n` for an n × n map, so that Δr ≈ r·Δθ (cells as long as wide); N =
//!   ⌈ln(r_max/r_min)/ln q⌉ and q then shrunk to end exactly at r_max. `[solve] pop_shells`
//!   sets N instead (q = (r_max/r_min)^{1/N}); at most [`POP_MAX_SHELLS`] shells, a range
//!   that would need more is an error.
//! * **Angular cells**: `pop_resolution` cells per side of the octahedral map, rounded up to
//!   even (the map's exact cell solid angles need an even side). The map's pole points from
//!   the light to the centre of the medium's box, so that its seams (the square's folded
//!   outer edges) lie in the hemisphere facing away from the medium.
//! * **Cell centres and steps.** A cell's centre is at the geometric mean radius
//!   `r_c = √(r_k r_{k+1})` along the direction of its map centre; its half-steps (for
//!   Eq. 2's transmittance and Eq. 4's factor, [`super::propagate::Halves`]) are
//!   `r_{k+1} − r_c` outwards, `r_c − r_k` inwards and `r_c √Ω / 2` sideways (Ω the cell's
//!   solid angle).
//! * **Quadratic fall-off** ("we scale the radiance when propagating along the principal
//!   direction in proportion to the radial coordinate spacing"): the grid carries each
//!   cell's **power** P (what Eqs. 2–6 move; the bookkeeping is then exact as on the
//!   light-aligned grid), and the magnitude accumulated for rendering is
//!   `L = P Δr / V = P / S`, S = V/Δr the cell's cross-section ⟂ r (V the cell's volume):
//!   the fluence of power P crossing the cell along one radial step, the same as `L = P/h²`
//!   on the light-aligned grid. For exponential shells S ∝ r², so moving from shell k to
//!   k+1 rescales L by `(r_k/r_{k+1})² = q^{−2}`: the inverse-square law, i.e. the paper's
//!   scaling by the ratio of the radial spacings, squared (a unit test).
//! * **Initialisation** (open point 3, as for directional lights): the once-scattered light
//!   is an HG lobe with a = g about r̂, and its power in cell c is exactly
//!   `σ_s T (Φ/4π) Ω Δr` (`∫ r^{−2} dV = Ω Δr`), T the exact uncollided transmittance from
//!   the light to the centre (`crate::shadow`), σ_s the cell average.
//! * **Boundaries**: what leaves the outer shell has left the grid; so has what goes
//!   inwards from the inner one of a light outside the box (inside r_min is vacuum, and
//!   light crossing it heads away from the medium); the angular neighbours wrap (the map is
//!   closed), and so does the resampling across the map's seams.
//! * **Medium sampling**: `k³` subsamples per cell at the midpoints of (u, v, ln r), weighted
//!   by their volume element `r³ / |p(u, v)|³` (exact for this parametrisation), k the ratio
//!   of the cell's size to the density's voxel, 1..=4 per shell.

use super::accumulate::BandGrid;
use super::octahedral::{unnormalised, OctahedralMap};
use super::propagate::{
    check_inputs, dot, frame, propagate_on, Halves, Neighbour, PopMedium, Propagated, Schedule,
    Stencil, BACK, FRONT, SIDE,
};
use super::{eq10_switch, phase_g, PopSeconds, PopSettings};
use crate::medium::DensityGrid;
use crate::scene::{RenderScene, POP_MAX_ITERATIONS, POP_MAX_SHELLS};
use crate::shadow::Extinction;
use anyhow::{bail, ensure};
use rayon::prelude::*;
use std::f64::consts::PI;
use std::time::Instant;

/// A point light's radial grid: n × n octahedral directions × N exponential shells.
#[derive(Clone, Debug, PartialEq)]
pub struct RadialGrid {
    /// The light's position (the grid's centre).
    pub position: [f64; 3],
    /// Orthonormal frame (u, v, w) of the octahedral map; w, its pole, points from the light
    /// to the centre of the medium's box.
    pub axes: [[f64; 3]; 3],
    /// The angular cells.
    pub map: OctahedralMap,
    /// Shell boundaries `r_0 = r_min < … < r_N = r_max` (N + 1 values).
    pub radii: Vec<f64>,
    /// `ln q`, the logarithmic shell spacing.
    pub log_q: f64,
    /// Whether the light lies inside (or on) the medium's box: shell 0 then starts at the
    /// inner radius given to [`RadialGrid::around_box`] and stands for the ball down to the
    /// light (module docs).
    pub inside: bool,
}

impl RadialGrid {
    /// The grid around the light at `position` that covers the box `[lo, hi]` (the medium's
    /// support) with `angular` cells per side of the octahedral map (rounded up to even) and
    /// `shells` shells (None: cells about as long as wide, module docs). A light inside or
    /// on the box gets shells from `inner` (> 0) outwards. Errors: a non-finite position, a
    /// shell count outside 1..=[`POP_MAX_SHELLS`] (given or needed), an `inner` radius that
    /// is not positive or does not lie below the box's farthest corner.
    pub fn around_box(
        position: [f64; 3],
        lo: [f64; 3],
        hi: [f64; 3],
        angular: usize,
        shells: Option<usize>,
        inner: f64,
    ) -> anyhow::Result<RadialGrid> {
        ensure!(
            position.iter().all(|c| c.is_finite()),
            "POP: the point light's [[light]] position {position:?} is not finite"
        );
        ensure!(angular > 0, "POP: pop_resolution must be positive");
        let nearest = [0, 1, 2].map(|d| position[d].clamp(lo[d], hi[d]) - position[d]);
        let distance = dot(nearest, nearest).sqrt();
        let inside = distance <= 0.0;
        let r_min = if inside { inner } else { distance };
        let far = [0, 1, 2].map(|d| (position[d] - lo[d]).abs().max((position[d] - hi[d]).abs()));
        let r_max = dot(far, far).sqrt();
        ensure!(
            r_min.is_finite() && r_min > 0.0 && r_min < r_max,
            "POP: the point light at {position:?} lies in the medium's box {lo:?} to {hi:?}; \
             its radial grid's inner radius {r_min:e} must be positive and below the box's \
             farthest corner ({r_max:e})"
        );
        let n = angular + angular % 2;
        let map = OctahedralMap::new(n)?;
        let width = map.mean_solid_angle().sqrt();
        let ratio = (r_max / r_min).ln();
        let count = match shells {
            Some(s) => {
                ensure!(
                    (1..=POP_MAX_SHELLS).contains(&s),
                    "pop_shells must lie in 1..={POP_MAX_SHELLS}, got {s}"
                );
                s
            }
            None => {
                let need = (ratio / width).ceil().max(1.0);
                ensure!(
                    need <= POP_MAX_SHELLS as f64,
                    "POP: the point light at {position:?} is {r_min:.3e} from the medium, which \
                     reaches to {r_max:.3e}: a radial range beyond the grid's, whose cells as \
                     long as wide (pop_resolution {angular}) would need {need} shells, more \
                     than {POP_MAX_SHELLS}; set [solve] pop_shells (1..={POP_MAX_SHELLS}) or \
                     move the light away from the medium"
                );
                need as usize
            }
        };
        let log_q = ratio / count as f64;
        let mut radii: Vec<f64> = (0..count)
            .map(|k| r_min * (k as f64 * log_q).exp())
            .collect();
        radii.push(r_max);
        let centre = [0, 1, 2].map(|d| 0.5 * (lo[d] + hi[d]) - position[d]);
        let pole = if dot(centre, centre) > 0.0 {
            centre
        } else {
            [0.0, 0.0, 1.0]
        };
        Ok(RadialGrid {
            position,
            axes: frame(pole),
            map,
            radii,
            log_q,
            inside,
        })
    }

    /// Angular cells per side.
    pub fn angular(&self) -> usize {
        self.map.n
    }

    /// Number of shells N.
    pub fn shells(&self) -> usize {
        self.radii.len() - 1
    }

    /// Cells along (u, v, r).
    pub fn res(&self) -> [usize; 3] {
        [self.map.n, self.map.n, self.shells()]
    }

    /// Storage index of cell (i, j, k), k the shell: `(k·n + j)·n + i` (a shell is
    /// contiguous).
    #[inline]
    pub fn index(&self, i: usize, j: usize, k: usize) -> usize {
        (k * self.map.n + j) * self.map.n + i
    }

    /// (i, j, k) of the storage index `c`.
    pub fn cell(&self, c: usize) -> [usize; 3] {
        let n = self.map.n;
        [c % n, (c / n) % n, c / (n * n)]
    }

    /// The geometric mean radius of shell k, its cells' centre.
    pub fn centre_radius(&self, k: usize) -> f64 {
        (self.radii[k] * self.radii[k + 1]).sqrt()
    }

    /// World direction (unit) of the angular cell (i, j)'s centre.
    pub fn direction(&self, i: usize, j: usize) -> [f64; 3] {
        self.to_world(self.map.directions[j * self.map.n + i])
    }

    fn to_world(&self, w: [f64; 3]) -> [f64; 3] {
        [0, 1, 2].map(|q| (0..3).map(|a| w[a] * self.axes[a][q]).sum::<f64>())
    }

    /// Solid angle of the angular cell of storage index `c`.
    pub fn solid_angle(&self, c: usize) -> f64 {
        let [i, j, _] = self.cell(c);
        self.map.solid_angles[j * self.map.n + i]
    }

    /// Volume of cell `c`: `Ω (r_{k+1}³ − r_k³)/3`.
    pub fn volume(&self, c: usize) -> f64 {
        let k = self.cell(c)[2];
        let (a, b) = (self.radii[k], self.radii[k + 1]);
        self.solid_angle(c) * (b * b * b - a * a * a) / 3.0
    }

    /// Cross-section of cell `c` ⟂ r, `V/Δr`: the power-to-fluence factor (module docs).
    pub fn cross_section(&self, c: usize) -> f64 {
        let k = self.cell(c)[2];
        self.volume(c) / (self.radii[k + 1] - self.radii[k])
    }

    /// Continuous cell coordinates (i, j along the map, k along ln r) of the world point
    /// `x`; cell c's centre is at c. The light's own position maps to (0, 0, −∞).
    pub fn local(&self, x: [f64; 3]) -> [f64; 3] {
        let rel = [0, 1, 2].map(|d| x[d] - self.position[d]);
        let r = dot(rel, rel).sqrt();
        if r <= 0.0 {
            return [0.0, 0.0, f64::NEG_INFINITY];
        }
        let w = self.axes.map(|a| dot(rel, a));
        let [i, j] = self.map.local(w);
        [i, j, (r / self.radii[0]).ln() / self.log_q - 0.5]
    }
}

impl Stencil for RadialGrid {
    fn shape(&self) -> [usize; 3] {
        self.res()
    }

    #[inline]
    fn neighbours(&self, i: usize, j: usize, k: usize) -> [Neighbour; 6] {
        let s = self.map.neighbours(i, j);
        let n = self.map.n;
        // Inwards from shell 0: through the light's ball to the opposite cell of shell 0
        // (whose own back patch points here), or out of the grid where that ball is vacuum.
        let back = if k > 0 {
            (Some(self.index(i, j, k - 1)), BACK, FRONT)
        } else if self.inside {
            (Some(self.map.antipodes[j * n + i]), BACK, BACK)
        } else {
            (None, BACK, FRONT)
        };
        [
            (
                (k + 1 < self.shells()).then(|| self.index(i, j, k + 1)),
                FRONT,
                BACK,
            ),
            back,
            (Some(self.index(s[0].0, s[0].1, k)), SIDE, SIDE),
            (Some(self.index(s[1].0, s[1].1, k)), SIDE, SIDE),
            (Some(self.index(s[2].0, s[2].1, k)), SIDE, SIDE),
            (Some(self.index(s[3].0, s[3].1, k)), SIDE, SIDE),
        ]
    }
}

impl BandGrid for RadialGrid {
    /// Trilinear in (i, j, ln r); across the map's seams the cells beyond are read through
    /// the fold ([`OctahedralMap::fold`]), so the interpolation is continuous on the sphere;
    /// clamped at the innermost and outermost shells' centres.
    fn corners(&self, x: [f64; 3]) -> [(usize, f64); 8] {
        let q = self.local(x);
        let n = self.map.n as f64;
        let axis = |t: f64| {
            let t = if t.is_finite() {
                t.clamp(-0.5, n - 0.5)
            } else {
                0.0
            };
            let i0 = t.floor();
            (i0 as i64, t - i0)
        };
        let (i0, fi) = axis(q[0]);
        let (j0, fj) = axis(q[1]);
        let ns = self.shells();
        let kq = if q[2].is_finite() {
            q[2].clamp(0.0, (ns - 1) as f64)
        } else {
            0.0
        };
        let k0 = (kq.floor() as usize).min(ns - 1);
        let k1 = (k0 + 1).min(ns - 1);
        let fk = kq - k0 as f64;
        let wi = [1.0 - fi, fi];
        let wj = [1.0 - fj, fj];
        let wk = [1.0 - fk, fk];
        let mut out = [(0usize, 0.0f64); 8];
        for a in 0..2 {
            for b in 0..2 {
                let (i, j) = self.map.fold(i0 + a as i64, j0 + b as i64);
                for (c, k) in [k0, k1].into_iter().enumerate() {
                    out[a * 4 + b * 2 + c] = (self.index(i, j, k), wi[a] * wj[b] * wk[c]);
                }
            }
        }
        out
    }

    fn centre_of(&self, c: usize) -> [f64; 3] {
        let [i, j, k] = self.cell(c);
        let d = self.direction(i, j);
        let r = self.centre_radius(k);
        [0, 1, 2].map(|q| self.position[q] + r * d[q])
    }

    fn principal(&self, x: [f64; 3]) -> [f64; 3] {
        let rel = [0, 1, 2].map(|d| x[d] - self.position[d]);
        let r = dot(rel, rel).sqrt();
        if r > 0.0 {
            rel.map(|c| c / r)
        } else {
            self.axes[2]
        }
    }

    fn fixed_principal(&self) -> Option<[f64; 3]> {
        None
    }
}

/// Most medium lookups for the cell averages (cells × subsamples³).
const MAX_LOOKUPS: usize = 1 << 26;

/// Cell averages of σ_s and σ_a on the radial grid (module docs) and the largest number of
/// subsamples per axis used.
pub fn sample_medium(
    scene: &RenderScene,
    density: &DensityGrid,
    grid: &RadialGrid,
    g: f64,
) -> anyhow::Result<(PopMedium, usize)> {
    let hmin = density.h().iter().fold(f64::INFINITY, |m, v| m.min(*v));
    let n = grid.map.n;
    let plane = n * n;
    let cells = Stencil::cells(grid);
    let width = grid.map.mean_solid_angle().sqrt();
    let per_shell: Vec<usize> = (0..grid.shells())
        .map(|k| {
            let size = (grid.radii[k + 1] - grid.radii[k]).max(grid.centre_radius(k) * width);
            let mut s = ((size / hmin).ceil() as usize).clamp(1, 4);
            while s > 1 && cells.saturating_mul(s * s * s) > MAX_LOOKUPS {
                s -= 1;
            }
            s
        })
        .collect();
    let mut sigma_s = vec![0.0; cells];
    let mut sigma_a = vec![0.0; cells];
    let w = 2.0 / n as f64;
    sigma_s
        .par_chunks_mut(plane)
        .zip(sigma_a.par_chunks_mut(plane))
        .enumerate()
        .for_each(|(k, (ss, sa))| {
            let s = per_shell[k];
            let sf = s as f64;
            let ln_r0 = grid.radii[k].ln();
            for j in 0..n {
                for i in 0..n {
                    let (mut wsum, mut st_sum, mut ss_sum) = (0.0, 0.0, 0.0);
                    for a in 0..s {
                        for b in 0..s {
                            let u = -1.0 + (i as f64 + (a as f64 + 0.5) / sf) * w;
                            let v = -1.0 + (j as f64 + (b as f64 + 0.5) / sf) * w;
                            let p = unnormalised(u, v);
                            let pn = dot(p, p).sqrt();
                            let dir = grid.to_world(p.map(|c| c / pn));
                            for c in 0..s {
                                let r = (ln_r0 + (c as f64 + 0.5) / sf * grid.log_q).exp();
                                let x = [0, 1, 2].map(|q| grid.position[q] + r * dir[q]);
                                let wt = (r / pn).powi(3);
                                let (t, sc) = scene.medium.coefficients_at(density, x);
                                wsum += wt;
                                st_sum += wt * t;
                                ss_sum += wt * sc;
                            }
                        }
                    }
                    let o = j * n + i;
                    ss[o] = ss_sum / wsum;
                    sa[o] = ((st_sum - ss_sum) / wsum).max(0.0);
                }
            }
        });
    if let Some(bad) = sigma_s.iter().chain(&sigma_a).find(|v| !v.is_finite()) {
        bail!("POP: the medium has a non-finite coefficient ({bad}) on a point light's grid");
    }
    let k = per_shell.iter().copied().max().unwrap_or(1);
    Ok((
        PopMedium {
            sigma_s,
            sigma_a,
            g,
        },
        k,
    ))
}

/// `T` at every cell centre: the exact optical depth from the light along each angular
/// cell's direction to the shells' centre radii (one traversal per direction); for a light
/// inside the medium, shell 0's at r_1/2, the midpoint of the ball and shell it stands for.
pub fn transmittance(ext: &Extinction, grid: &RadialGrid) -> Vec<f64> {
    let n = grid.map.n;
    // For a light inside the medium shell 0 stands for [0, r_1]: its midpoint r_1/2 (module
    // docs).
    let marks: Vec<f64> = (0..grid.shells())
        .map(|k| {
            if k == 0 && grid.inside {
                0.5 * grid.radii[1]
            } else {
                grid.centre_radius(k)
            }
        })
        .collect();
    let columns: Vec<Vec<f64>> = (0..n * n)
        .into_par_iter()
        .map(|a| {
            let mut tau = vec![0.0; marks.len()];
            let d = grid.direction(a % n, a / n);
            ext.optical_depth_at_marks(grid.position, d, &marks, f64::INFINITY, &mut tau);
            tau.iter().map(|t| (-t).exp()).collect()
        })
        .collect();
    let mut t = vec![0.0; Stencil::cells(grid)];
    for (a, col) in columns.iter().enumerate() {
        for (k, v) in col.iter().enumerate() {
            t[grid.index(a % n, a / n, k)] = *v;
        }
    }
    t
}

/// The once-scattered power per cell, `σ_s T (Φ/4π) Ω Δr` (module docs); for a light inside
/// the medium's box shell 0 also holds the ball inside it (Δr = r_1).
pub fn source(grid: &RadialGrid, medium: &PopMedium, t: &[f64], power: f64) -> Vec<f64> {
    let intensity = power / (4.0 * PI);
    (0..Stencil::cells(grid))
        .map(|c| {
            let k = grid.cell(c)[2];
            let dr = if k == 0 && grid.inside {
                grid.radii[1]
            } else {
                grid.radii[k + 1] - grid.radii[k]
            };
            medium.sigma_s[c] * t[c] * intensity * grid.solid_angle(c) * dr
        })
        .collect()
}

/// Eq. 2's and Eq. 4's halves on the radial grid (module docs: outward, sideways and
/// inward half-steps of each cell).
pub fn halves(grid: &RadialGrid, medium: &PopMedium) -> Halves {
    let g = medium.g;
    let lengths: Vec<[f64; 3]> = (0..Stencil::cells(grid))
        .map(|c| {
            let k = grid.cell(c)[2];
            let rc = grid.centre_radius(k);
            let mut l = [0.0; 3];
            l[FRONT as usize] = grid.radii[k + 1] - rc;
            l[SIDE as usize] = 0.5 * rc * grid.solid_angle(c).sqrt();
            // Inwards from shell 0 of a light inside the medium: through the ball, r_c to the
            // light and r_c on to the opposite cell's centre.
            l[BACK as usize] = if k == 0 && grid.inside {
                rc
            } else {
                rc - grid.radii[k]
            };
            l
        })
        .collect();
    let t = lengths
        .iter()
        .zip(&medium.sigma_a)
        .map(|(l, s)| l.map(|l| (-s * l).exp()))
        .collect();
    let gh = lengths
        .iter()
        .zip(&medium.sigma_s)
        .map(|(l, s)| l.map(|l| g.powf(s * l)))
        .collect();
    Halves { t, g: gh }
}

/// One propagated point light: its radial grid, the medium on it and the band amplitudes,
/// already converted from power to the fluence-like magnitude (`L = P/S`, module docs).
#[derive(Clone, Debug)]
pub struct PointSolution {
    /// The radial grid.
    pub grid: RadialGrid,
    /// The medium on it.
    pub medium: PopMedium,
    /// Band amplitudes (fluence units) and bookkeeping (powers).
    pub propagated: Propagated,
    /// Largest number of midpoint subsamples per axis.
    pub subsamples: usize,
}

/// Propagates the point light at `position` of power `power` through the scene's medium on
/// a radial grid (`settings.resolution` angular cells per side, `shells` shells or the
/// automatic count). `None` for an empty medium.
pub fn solve_point_light(
    scene: &RenderScene,
    density: &DensityGrid,
    position: [f64; 3],
    power: f64,
    settings: &PopSettings,
    shells: Option<usize>,
    seconds: &mut PopSeconds,
) -> anyhow::Result<Option<PointSolution>> {
    settings.validate()?;
    let g = phase_g(&scene.phase)?;
    ensure!(
        power.is_finite() && power >= 0.0,
        "POP: a point light's power must be finite and non-negative, got {power}"
    );
    let Some((lo, hi)) = density.support() else {
        return Ok(None);
    };
    let t0 = Instant::now();
    // A light inside the medium's box: shells from half the smallest voxel side (the
    // density has no detail below it; the ball inside is lumped into shell 0).
    let inner = 0.5 * density.h().iter().fold(f64::INFINITY, |m, v| m.min(*v));
    let grid = RadialGrid::around_box(position, lo, hi, settings.resolution, shells, inner)?;
    let cells = Stencil::cells(&grid);
    // As the light-aligned grid (super::solve_light), with six halves instead of two.
    let bytes = cells as u128 * 8 * (19 + settings.lmax as u128 + 1);
    let limit = pn_runtime::memory_estimate::default_limit_bytes() as u128;
    ensure!(
        bytes <= limit,
        "POP: the radial grid of {:?} cells needs about {:.1} GiB, more than the default \
         memory limit of {:.1} GiB: lower pop_resolution or pop_shells",
        grid.res(),
        bytes as f64 / (1u64 << 30) as f64,
        limit as f64 / (1u64 << 30) as f64
    );
    let (medium, subsamples) = sample_medium(scene, density, &grid, g)?;
    seconds.medium += t0.elapsed().as_secs_f64();
    let t1 = Instant::now();
    let ext = Extinction {
        grid: density,
        scale: scene.medium.sigma_t_scale,
    };
    let t = transmittance(&ext, &grid);
    let src = source(&grid, &medium, &t, power);
    let halves = halves(&grid, &medium);
    seconds.initialization += t1.elapsed().as_secs_f64();
    let t2 = Instant::now();
    let schedule = match settings.residuum {
        None => Schedule::Fixed(settings.iterations),
        Some(r) => {
            // Eq. 10 with the mean optical depth of one radial step over the medium's cells.
            let (sum, count) =
                (0..cells)
                    .filter(|c| medium.sigma_s[*c] > 0.0)
                    .fold((0.0, 0usize), |(a, n), c| {
                        let k = grid.cell(c)[2];
                        (
                            a + medium.sigma_s[c] * (grid.radii[k + 1] - grid.radii[k]),
                            n + 1,
                        )
                    });
            let tau = (count > 0).then(|| sum / count as f64);
            Schedule::Residuum {
                anisotropic: eq10_switch(grid.shells(), g, tau, r.epsilon_a),
                epsilon_l: r.epsilon_l,
                max_total: POP_MAX_ITERATIONS,
            }
        }
    };
    check_inputs(cells, &medium, &src, g, schedule)?;
    let mut propagated = propagate_on(&grid, &halves, 1.0, &src, g, settings.lmax, schedule)?;
    let nb = settings.lmax + 1;
    for (c, b) in propagated.bands.chunks_mut(nb).enumerate() {
        let s = grid.cross_section(c);
        b.iter_mut().for_each(|v| *v /= s);
    }
    seconds.propagation += t2.elapsed().as_secs_f64();
    Ok(Some(PointSolution {
        grid,
        medium,
        propagated,
        subsamples,
    }))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn radial_grid_covers_the_box_and_spaces_shells_exponentially() {
        let g =
            RadialGrid::around_box([3.0, 0.5, -0.2], [-1.0; 3], [1.0; 3], 16, None, 0.1).unwrap();
        // r_min is the distance to the face x = 1, r_max to the corner (−1, −1, 1).
        assert!((g.radii[0] - 2.0).abs() < 1e-15);
        let far: f64 = (16.0f64 + 1.5 * 1.5 + 1.2 * 1.2).sqrt();
        assert!((g.radii[g.shells()] - far).abs() < 1e-12);
        let width = (4.0 * PI).sqrt() / 16.0;
        assert!(g.log_q <= width && g.log_q > 0.5 * width, "{}", g.log_q);
        for k in 1..g.shells() {
            let q = g.radii[k + 1] / g.radii[k];
            assert!((q.ln() - g.log_q).abs() < 1e-12);
        }
        // The box's corners lie within the grid's radial range, and local() inverts the
        // cell centres.
        for c in [0, 17, 200, Stencil::cells(&g) - 1] {
            let q = g.local(g.centre_of(c));
            let want = g.cell(c).map(|v| v as f64);
            for (a, b) in q.iter().zip(&want) {
                assert!((a - b).abs() < 1e-9, "{c}: {q:?} vs {want:?}");
            }
        }
        // The pole points at the box.
        let want = {
            let d = [-3.0f64, -0.5, 0.2];
            let n = dot(d, d).sqrt();
            d.map(|c| c / n)
        };
        assert!(g.axes[2]
            .iter()
            .zip(&want)
            .all(|(a, b)| (a - b).abs() < 1e-15));
        // Volumes add up to the spherical shell's.
        let total: f64 = (0..Stencil::cells(&g)).map(|c| g.volume(c)).sum();
        let want = 4.0 * PI / 3.0 * (g.radii[g.shells()].powi(3) - 8.0);
        assert!((total - want).abs() < 1e-10 * want);
    }

    #[test]
    fn bad_radial_input_is_an_error() {
        let err = |p: [f64; 3], shells: Option<usize>, inner: f64| {
            format!(
                "{:#}",
                RadialGrid::around_box(p, [-1.0; 3], [1.0; 3], 8, shells, inner).unwrap_err()
            )
        };
        // A light inside (or on) the box needs a positive inner radius below the farthest
        // corner.
        for inner in [0.0, -1.0, f64::NAN, 10.0] {
            for p in [[0.2, 0.0, 0.0], [1.0, 0.0, 0.0]] {
                assert!(
                    err(p, None, inner).contains("inner radius"),
                    "{p:?} {inner}"
                );
            }
        }
        assert!(err([f64::NAN, 0.0, 0.0], None, 0.1).contains("position"));
        assert!(err([2.0, 0.0, 0.0], Some(0), 0.1).contains("pop_shells must lie in 1..=512"));
        assert!(err([2.0, 0.0, 0.0], Some(513), 0.1).contains("pop_shells must lie in 1..=512"));
        // A light 1e−100 from the unit box: cells as long as wide (ln q = √(4π)/16 = 0.22)
        // would need ln(1.22/1e−100)/0.22 ≈ 1040 shells…
        let near = [-1e-100, 0.5, 0.5];
        let e = format!(
            "{:#}",
            RadialGrid::around_box(near, [0.0; 3], [1.0; 3], 16, None, 0.1).unwrap_err()
        );
        assert!(
            e.contains("beyond the grid's") && e.contains("pop_shells"),
            "{e}"
        );
        // …which pop_shells overrides; so does an inner radius 1e−100 inside the box.
        let g = RadialGrid::around_box(near, [0.0; 3], [1.0; 3], 16, Some(40), 0.1).unwrap();
        assert_eq!(g.shells(), 40);
        assert!(!g.inside);
        let inner = RadialGrid::around_box([0.5; 3], [0.0; 3], [1.0; 3], 16, None, 1e-100);
        assert!(format!("{:#}", inner.unwrap_err()).contains("beyond the grid's"));
        // Inside, with a sensible inner radius: shells from it.
        let g = RadialGrid::around_box([0.5; 3], [0.0; 3], [1.0; 3], 16, None, 0.01).unwrap();
        assert!(g.inside && g.radii[0] == 0.01);
    }
}
