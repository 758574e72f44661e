//! The density grid of a render scene and the procedural media (sphere, box, noise-displaced
//! "cloud" and "nebula").
//!
//! **Storage.** Voxel (i, j, k) covers `bbox_min + [i, i+1)·h_x × [j, j+1)·h_y × [k, k+1)·h_z`
//! and holds one value; data are stored x fastest, index `(k·ny + j)·nx + i`, the order of a
//! `.vol` file (docs/design.md §6). σ_t(x) = `sigma_t_scale` × density(x).
//!
//! **Reading the voxels ([`DensityFilter`], shared with the Mitsuba export).** Exactly
//! Mitsuba 3's `gridvolume` (`src/volumes/grid.cpp`, which evaluates a `dr::Texture3f` with
//! its default `wrap_mode = "clamp"`; `accel` only matters for CUDA hardware textures, the
//! software path is drjit's `tex_eval`):
//!
//! * [`DensityFilter::Trilinear`] (Mitsuba's default `filter_type = "trilinear"`): the value
//!   of voxel i sits at its centre `c_i = bbox_min + (i + ½)h`. Per axis, `u = (x −
//!   bbox_min)/h − ½`, `i₀ = ⌊u⌋`, `f = u − i₀`, and the value is the trilinear blend of the
//!   8 voxels `clamp(i₀ + {0, 1}, 0, n − 1)` with weights `1 − f`, `f`. Between the centres
//!   that is ordinary trilinear interpolation; in the **outer half voxel** (between the box
//!   face and the outermost centres) both indices clamp to the edge voxel, so the field is
//!   constant along that axis there (the edge value extends to the face, it does not fall
//!   to 0). Equivalently ρ(x) = Σ ρ_ijk φ_i(x) φ_j(y) φ_k(z) with φ_i the hat function
//!   between neighbouring centres, the two outermost ones extended flat to the box faces
//!   ([`DensityGrid::axis_weights`]).
//! * [`DensityFilter::Nearest`] (`filter_type = "nearest"`): `clamp(⌊(x − bbox_min)/h⌋)`, i.e.
//!   piecewise constant per voxel.
//! * **Outside the box** the density is 0 for both: Mitsuba's medium is the interior of a
//!   `cube` covering the box (the texture's clamping is never reached from outside).
//!
//! Both filters give the same ∫ρ dV (every φ_i integrates to h) and the same maximum (a
//! trilinear value is a convex combination of voxel values), so the delta-tracking majorant
//! is the largest voxel value for both. Mitsuba 3.9.1 itself was checked to follow this
//! convention on a 4-voxel grid (`tests/mitsuba_single_scatter.rs`).
//!
//! Procedural media are deterministic functions of the seed (a hash of the lattice point and
//! the seed, no global random state), evaluated at the voxel centres.

use anyhow::{bail, ensure, Context};
use pn_runtime::field::VoxelGrid;
use rayon::prelude::*;

/// ⌊x⌋ for finite |x| < 2⁶³ without the libm call `f64::floor` becomes on baseline x86-64
/// (no SSE4.1 `roundsd`): truncation, one down for negative non-integers. The renderers'
/// lookups call it several times per sample.
#[inline]
pub(crate) fn floor_fast(x: f64) -> f64 {
    let t = x as i64 as f64;
    if t > x {
        t - 1.0
    } else {
        t
    }
}

/// How a voxel grid is read between voxel centres (see the module docs): Mitsuba's
/// `gridvolume` `filter_type`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum DensityFilter {
    /// Trilinear interpolation between voxel centres, clamped to the edge voxels in the
    /// outer half voxel (Mitsuba's default).
    #[default]
    Trilinear,
    /// Piecewise constant per voxel.
    Nearest,
}

impl DensityFilter {
    /// The accepted names, as in the scene file, `--filter` and Mitsuba's `filter_type`.
    pub const NAMES: [&'static str; 2] = ["trilinear", "nearest"];

    /// Lower-case name (Mitsuba's `filter_type` value).
    pub fn name(self) -> &'static str {
        match self {
            DensityFilter::Trilinear => "trilinear",
            DensityFilter::Nearest => "nearest",
        }
    }
}

impl std::fmt::Display for DensityFilter {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

impl std::str::FromStr for DensityFilter {
    type Err = anyhow::Error;
    fn from_str(s: &str) -> anyhow::Result<Self> {
        match s {
            "trilinear" => Ok(DensityFilter::Trilinear),
            "nearest" => Ok(DensityFilter::Nearest),
            _ => bail!("unknown density filter {s:?} (expected \"trilinear\" or \"nearest\")"),
        }
    }
}

/// A density on an axis-aligned box: voxel values, x fastest, read with [`Self::filter`]
/// (see the module docs).
#[derive(Clone, Debug, PartialEq)]
pub struct DensityGrid {
    /// Voxels per axis (x, y, z).
    pub res: [usize; 3],
    /// Lower corner of the box.
    pub bbox_min: [f64; 3],
    /// Upper corner of the box.
    pub bbox_max: [f64; 3],
    /// `res[0]·res[1]·res[2]` densities, index `(k·ny + j)·nx + i`.
    pub data: Vec<f32>,
    /// How the voxels are read between their centres ([`DensityFilter::Trilinear`] from
    /// [`DensityGrid::new`]; change it with [`DensityGrid::with_filter`]).
    pub filter: DensityFilter,
}

impl DensityGrid {
    /// Creates a grid with the default filter ([`DensityFilter::Trilinear`], Mitsuba's),
    /// checking the resolution, the box and the data (finite, ≥ 0).
    pub fn new(
        res: [usize; 3],
        bbox_min: [f64; 3],
        bbox_max: [f64; 3],
        data: Vec<f32>,
    ) -> anyhow::Result<Self> {
        ensure!(
            res.iter().all(|&n| n > 0),
            "density grid resolution must be positive on every axis, got {res:?}"
        );
        let n = res[0]
            .checked_mul(res[1])
            .and_then(|v| v.checked_mul(res[2]))
            .with_context(|| format!("density grid {res:?} is too large"))?;
        ensure!(
            data.len() == n,
            "density grid {}×{}×{} needs {n} values, got {}",
            res[0],
            res[1],
            res[2],
            data.len()
        );
        check_box(bbox_min, bbox_max)?;
        if let Some(p) = data.iter().position(|v| !v.is_finite() || *v < 0.0) {
            let (i, j, k) = (p % res[0], (p / res[0]) % res[1], p / (res[0] * res[1]));
            anyhow::bail!(
                "density must be finite and non-negative, voxel ({i}, {j}, {k}) is {}",
                data[p]
            );
        }
        Ok(Self {
            res,
            bbox_min,
            bbox_max,
            data,
            filter: DensityFilter::default(),
        })
    }

    /// The same grid read with `filter`.
    pub fn with_filter(mut self, filter: DensityFilter) -> Self {
        self.filter = filter;
        self
    }

    /// Voxel size along each axis.
    pub fn h(&self) -> [f64; 3] {
        [0, 1, 2].map(|d| (self.bbox_max[d] - self.bbox_min[d]) / self.res[d] as f64)
    }

    /// Linear index of voxel (i, j, k).
    #[inline]
    pub fn index(&self, i: usize, j: usize, k: usize) -> usize {
        (k * self.res[1] + j) * self.res[0] + i
    }

    /// Density of voxel (i, j, k).
    #[inline]
    pub fn at(&self, i: usize, j: usize, k: usize) -> f64 {
        self.data[self.index(i, j, k)] as f64
    }

    /// The voxel containing `p`, or `None` outside the box (faces on the max side belong to
    /// no voxel, matching the half-open cells).
    pub fn voxel_of(&self, p: [f64; 3]) -> Option<[usize; 3]> {
        let h = self.h();
        let mut v = [0usize; 3];
        for d in 0..3 {
            let u = (p[d] - self.bbox_min[d]) / h[d];
            if !(u >= 0.0 && u < self.res[d] as f64) {
                return None;
            }
            v[d] = (u as usize).min(self.res[d] - 1);
        }
        Some(v)
    }

    /// Whether `p` lies in the closed box.
    #[inline]
    pub fn contains(&self, p: [f64; 3]) -> bool {
        (0..3).all(|d| p[d] >= self.bbox_min[d] && p[d] <= self.bbox_max[d])
    }

    /// Density at `p` with the grid's [`DensityFilter`] (module docs); 0 outside the box.
    /// Nearest: the voxel of [`Self::voxel_of`] (half-open cells: 0 on the box's max faces);
    /// trilinear: the clamped trilinear blend in the closed box (continuous up to its faces).
    #[inline]
    pub fn density_at(&self, p: [f64; 3]) -> f64 {
        self.sample(&self.data, p)
    }

    /// The value at `p` of a per-voxel quantity `values` laid out like [`Self::data`] (e.g.
    /// an albedo grid), read with the grid's filter like [`Self::density_at`]; 0 outside the
    /// box. `values.len()` must equal the voxel count (a shorter slice gives 0).
    pub fn sample(&self, values: &[f32], p: [f64; 3]) -> f64 {
        match self.filter {
            DensityFilter::Nearest => self
                .voxel_of(p)
                .and_then(|[i, j, k]| values.get(self.index(i, j, k)))
                .map_or(0.0, |v| *v as f64),
            DensityFilter::Trilinear => {
                if !self.contains(p) || values.len() != self.data.len() {
                    return 0.0;
                }
                let w = [0, 1, 2].map(|d| self.trilinear_1d(d, p[d]));
                let mut v = 0.0;
                for (wz, kz) in [(w[2].2, w[2].1), (1.0 - w[2].2, w[2].0)] {
                    if wz == 0.0 {
                        continue;
                    }
                    for (wy, jy) in [(w[1].2, w[1].1), (1.0 - w[1].2, w[1].0)] {
                        if wy == 0.0 {
                            continue;
                        }
                        let row = (kz * self.res[1] + jy) * self.res[0];
                        let (a, b) = (values[row + w[0].0] as f64, values[row + w[0].1] as f64);
                        v += wz * wy * (a + w[0].2 * (b - a));
                    }
                }
                v
            }
        }
    }

    /// Mitsuba's 1D linear lookup along axis `d` at coordinate `x`: the two clamped voxel
    /// indices `(lo, hi)` and the weight `f` of `hi` (`1 − f` of `lo`).
    #[inline]
    fn trilinear_1d(&self, d: usize, x: f64) -> (usize, usize, f64) {
        let n = self.res[d];
        let u = (x - self.bbox_min[d]) * (n as f64 / (self.bbox_max[d] - self.bbox_min[d])) - 0.5;
        let fl = floor_fast(u);
        let f = u - fl;
        let i0 = fl as i64;
        let clamp = |i: i64| i.clamp(0, n as i64 - 1) as usize;
        (clamp(i0), clamp(i0 + 1), f)
    }

    /// The filter's 1D basis weights at coordinate `x` on axis `d`: up to two
    /// `(voxel index, weight)` pairs, weights summing to 1 inside the box, none outside
    /// (ρ(x) = Σ ρ_ijk w_i(x) w_j(y) w_k(z)). Used for exact cell averages.
    pub fn axis_weights(&self, d: usize, x: f64) -> [(usize, f64); 2] {
        if !(x >= self.bbox_min[d] && x <= self.bbox_max[d]) {
            return [(0, 0.0), (0, 0.0)];
        }
        match self.filter {
            DensityFilter::Nearest => {
                let h = self.h()[d];
                let i = (((x - self.bbox_min[d]) / h) as usize).min(self.res[d] - 1);
                [(i, 1.0), (i, 0.0)]
            }
            DensityFilter::Trilinear => {
                let (a, b, f) = self.trilinear_1d(d, x);
                [(a, 1.0 - f), (b, f)]
            }
        }
    }

    /// The coordinates along axis `d` where the filter's 1D weights have a kink: the box
    /// faces and, inside, the voxel faces (nearest) or the voxel centres (trilinear). The
    /// weights are linear in x between consecutive break points.
    pub fn axis_breaks(&self, d: usize) -> Vec<f64> {
        let n = self.res[d];
        let h = self.h()[d];
        let (lo, hi) = (self.bbox_min[d], self.bbox_max[d]);
        let mut v = Vec::with_capacity(n + 2);
        v.push(lo);
        match self.filter {
            DensityFilter::Nearest => v.extend((1..n).map(|i| lo + i as f64 * h)),
            DensityFilter::Trilinear => v.extend((0..n).map(|i| lo + (i as f64 + 0.5) * h)),
        }
        v.push(hi);
        v
    }

    /// The box (closed, in world coordinates) outside which the density is 0, or `None` for
    /// an empty grid: the occupied voxels, widened by the filter's reach (half a voxel each
    /// side for trilinear, where a voxel's hat function extends to its neighbours' centres),
    /// clipped to the medium box.
    pub fn support(&self) -> Option<([f64; 3], [f64; 3])> {
        let (lo, hi) = self.occupied_range()?;
        let h = self.h();
        let reach = match self.filter {
            DensityFilter::Nearest => 0.0,
            DensityFilter::Trilinear => 0.5,
        };
        let min = [0, 1, 2]
            .map(|d| (self.bbox_min[d] + (lo[d] as f64 - reach) * h[d]).max(self.bbox_min[d]));
        let max = [0, 1, 2].map(|d| {
            (self.bbox_min[d] + (hi[d] as f64 + 1.0 + reach) * h[d]).min(self.bbox_max[d])
        });
        Some((min, max))
    }

    /// Largest density value (0 for an empty grid).
    pub fn max_density(&self) -> f64 {
        self.data.iter().fold(0.0f32, |m, v| m.max(*v)) as f64
    }

    /// The inclusive voxel index range `(lo, hi)` of all voxels with density > 0, or `None`
    /// when the grid is empty.
    pub fn occupied_range(&self) -> Option<([usize; 3], [usize; 3])> {
        let mut lo = self.res;
        let mut hi = [0usize; 3];
        let mut any = false;
        for k in 0..self.res[2] {
            for j in 0..self.res[1] {
                for i in 0..self.res[0] {
                    if self.at(i, j, k) > 0.0 {
                        any = true;
                        for (d, c) in [i, j, k].into_iter().enumerate() {
                            lo[d] = lo[d].min(c);
                            hi[d] = hi[d].max(c);
                        }
                    }
                }
            }
        }
        any.then_some((lo, hi))
    }

    /// The same data as a [`VoxelGrid`] (x slowest, f64), e.g. for [`pn_formats::encode_vol`].
    pub fn to_voxel_grid(&self) -> VoxelGrid {
        let [nx, ny, nz] = self.res;
        let mut data = vec![0.0; nx * ny * nz];
        for k in 0..nz {
            for j in 0..ny {
                for i in 0..nx {
                    data[(i * ny + j) * nz + k] = self.at(i, j, k);
                }
            }
        }
        VoxelGrid {
            dims: self.res,
            min: self.bbox_min,
            max: self.bbox_max,
            data,
        }
    }

    /// A grid from a [`VoxelGrid`] (as read from `.vol` or `.npy`), with the given box.
    pub fn from_voxel_grid(
        g: &VoxelGrid,
        bbox_min: [f64; 3],
        bbox_max: [f64; 3],
    ) -> anyhow::Result<Self> {
        let [nx, ny, nz] = g.dims;
        let mut data = vec![0.0f32; nx * ny * nz];
        for k in 0..nz {
            for j in 0..ny {
                for i in 0..nx {
                    data[(k * ny + j) * nx + i] = g.at(i, j, k) as f32;
                }
            }
        }
        Self::new(g.dims, bbox_min, bbox_max, data)
    }
}

/// Checks that a box is finite with max > min on every axis.
pub(crate) fn check_box(min: [f64; 3], max: [f64; 3]) -> anyhow::Result<()> {
    for d in 0..3 {
        ensure!(
            min[d].is_finite() && max[d].is_finite() && max[d] > min[d],
            "bounding box must be finite with bbox_max > bbox_min on every axis, got \
             bbox_min {min:?} bbox_max {max:?}"
        );
    }
    Ok(())
}

/// The procedural media.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Procedural {
    /// A ball of density 1 (radius 0.8 of the half extent) centred in the box.
    Sphere,
    /// A box of density 1 covering the central half of the bounding box on every axis.
    Box,
    /// A noise-displaced ball with a soft, fBm-modulated density (a cumulus-like blob).
    Cloud,
    /// Several noise-displaced lobes with wispy, strongly modulated density.
    Nebula,
}

impl Procedural {
    /// Lower-case name as in the scene file.
    pub fn name(self) -> &'static str {
        match self {
            Procedural::Sphere => "sphere",
            Procedural::Box => "box",
            Procedural::Cloud => "cloud",
            Procedural::Nebula => "nebula",
        }
    }

    /// Density at `u`, the position in the box mapped to [−1, 1]³.
    pub fn density(self, u: [f64; 3], seed: u64) -> f64 {
        let r = (u[0] * u[0] + u[1] * u[1] + u[2] * u[2]).sqrt();
        match self {
            Procedural::Sphere => f64::from(r < 0.8),
            Procedural::Box => f64::from(u.iter().all(|c| c.abs() < 0.5)),
            Procedural::Cloud => {
                // Radius displaced by low-frequency fBm; density ramps up over 0.15 inside
                // the surface and is modulated by a second, finer fBm.
                // |fBm| < 1, so the surface lies inside r = 0.62 + 0.22: outside it (and
                // wherever the body is 0) the density is 0 without evaluating the noise
                // (the same values; most of the box is outside).
                if r >= 0.85 {
                    return 0.0;
                }
                let s = [u[0] * 2.0, u[1] * 2.0, u[2] * 2.0];
                let disp = 0.22 * fbm(s, seed, 4);
                let depth = 0.62 + disp - r;
                let body = smoothstep(0.0, 0.15, depth);
                if body == 0.0 {
                    return 0.0;
                }
                let detail =
                    0.6 + 0.4 * fbm([u[0] * 5.0, u[1] * 5.0, u[2] * 5.0], seed ^ 0x5bd1, 3);
                (body * detail).clamp(0.0, 1.0)
            }
            Procedural::Nebula => {
                // Three lobes (positions fixed, sizes from the seed) displaced by fBm, with a
                // strongly modulated interior: thin wisps next to dense knots.
                let lobes = [
                    ([-0.25, 0.05, 0.0], 0.45),
                    ([0.3, -0.1, 0.1], 0.38),
                    ([0.05, 0.3, -0.2], 0.3),
                ];
                let warp = [
                    0.15 * fbm([u[0] * 2.5, u[1] * 2.5, u[2] * 2.5], seed ^ 0x11, 3),
                    0.15 * fbm([u[0] * 2.5 + 7.1, u[1] * 2.5, u[2] * 2.5], seed ^ 0x22, 3),
                    0.15 * fbm([u[0] * 2.5, u[1] * 2.5 + 3.7, u[2] * 2.5], seed ^ 0x33, 3),
                ];
                let w = [u[0] + warp[0], u[1] + warp[1], u[2] + warp[2]];
                let mut depth = f64::NEG_INFINITY;
                for (n, (c, rad)) in lobes.iter().enumerate() {
                    let jitter = 1.0 + 0.2 * (unit_hash([n as i64, 0, 0], seed) - 0.5);
                    let d = ((w[0] - c[0]).powi(2) + (w[1] - c[1]).powi(2) + (w[2] - c[2]).powi(2))
                        .sqrt();
                    depth = depth.max(rad * jitter - d);
                }
                let body = smoothstep(
                    0.0,
                    0.12,
                    depth + 0.12 * fbm([u[0] * 4.0, u[1] * 4.0, u[2] * 4.0], seed, 4),
                );
                let wisps = fbm([u[0] * 6.0, u[1] * 6.0, u[2] * 6.0], seed ^ 0x77, 4);
                (body * (0.15 + 0.85 * smoothstep(0.25, 0.75, wisps))).clamp(0.0, 1.0)
            }
        }
    }

    /// The density grid of this medium at `res` over the box, sampled at voxel centres.
    pub fn grid(
        self,
        res: [usize; 3],
        bbox_min: [f64; 3],
        bbox_max: [f64; 3],
        seed: u64,
    ) -> anyhow::Result<DensityGrid> {
        let n = check_procedural_resolution(res)?;
        check_box(bbox_min, bbox_max)?;
        let mut data = vec![0.0f32; n];
        // Each voxel is a function of its centre and the seed alone: parallel, same values.
        data.par_iter_mut().enumerate().for_each(|(idx, v)| {
            let c = [
                idx % res[0],
                (idx / res[0]) % res[1],
                idx / (res[0] * res[1]),
            ];
            // Voxel centre mapped to [−1, 1].
            let u = [0, 1, 2].map(|d| 2.0 * (c[d] as f64 + 0.5) / res[d] as f64 - 1.0);
            *v = self.density(u, seed) as f32;
        });
        DensityGrid::new(res, bbox_min, bbox_max, data)
    }
}

/// Largest procedural grid (512³): bounds memory from a typo in the resolution.
pub const MAX_PROCEDURAL_VOXELS: usize = 512 * 512 * 512;

/// Checks a procedural medium's `medium.resolution` before its grid is made: positive on
/// every axis and at most [`MAX_PROCEDURAL_VOXELS`] voxels, the refusal giving the memory the
/// grid would take (4 bytes a voxel). Returns the voxel count. The scene parser checks it as
/// it reads the scene, [`Procedural::grid`] again.
pub fn check_procedural_resolution(res: [usize; 3]) -> anyhow::Result<usize> {
    ensure!(
        res.iter().all(|&n| n > 0),
        "medium.resolution must be positive on every axis, got {res:?}"
    );
    let n: u128 = res.iter().map(|&v| v as u128).product();
    ensure!(
        n <= MAX_PROCEDURAL_VOXELS as u128,
        "medium.resolution {res:?} is {n} voxels, about {} as float32; a procedural medium \
         has at most 512³ = {MAX_PROCEDURAL_VOXELS} voxels ({})",
        pn_runtime::memory_estimate::human_bytes(n.saturating_mul(4)),
        pn_runtime::memory_estimate::human_bytes(MAX_PROCEDURAL_VOXELS as u128 * 4)
    );
    Ok(n as usize)
}

/// Hermite smoothstep of `x` between `a` and `b`.
fn smoothstep(a: f64, b: f64, x: f64) -> f64 {
    let t = ((x - a) / (b - a)).clamp(0.0, 1.0);
    t * t * (3.0 - 2.0 * t)
}

/// A 64-bit mix (SplitMix64's finaliser).
fn mix64(mut z: u64) -> u64 {
    z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
    z ^ (z >> 31)
}

/// A uniform value in [0, 1) for a lattice point and a seed.
fn unit_hash(p: [i64; 3], seed: u64) -> f64 {
    let mut h = mix64(seed.wrapping_add(0x9e37_79b9_7f4a_7c15));
    for c in p {
        h = mix64(h ^ (c as u64).wrapping_mul(0x9e37_79b9_7f4a_7c15));
    }
    (h >> 11) as f64 / (1u64 << 53) as f64
}

/// Value noise in [−1, 1]: hashed lattice values, quintic-smoothed trilinear interpolation.
fn value_noise(p: [f64; 3], seed: u64) -> f64 {
    let f = p.map(f64::floor);
    let t = [0, 1, 2].map(|d| {
        let x = p[d] - f[d];
        x * x * x * (x * (x * 6.0 - 15.0) + 10.0)
    });
    let base = f.map(|v| v as i64);
    let mut v = 0.0;
    for corner in 0..8 {
        let mut w = 1.0;
        let mut q = base;
        for d in 0..3 {
            if corner >> d & 1 == 1 {
                w *= t[d];
                q[d] += 1;
            } else {
                w *= 1.0 - t[d];
            }
        }
        v += w * (2.0 * unit_hash(q, seed) - 1.0);
    }
    v
}

/// Fractal Brownian motion: `octaves` octaves of value noise, lacunarity 2, gain 0.5,
/// normalised to [−1, 1].
fn fbm(p: [f64; 3], seed: u64, octaves: u32) -> f64 {
    let (mut sum, mut amp, mut norm, mut freq) = (0.0, 1.0, 0.0, 1.0);
    for o in 0..octaves {
        sum += amp * value_noise(p.map(|c| c * freq), seed.wrapping_add(o as u64 * 0x51ed));
        norm += amp;
        amp *= 0.5;
        freq *= 2.0;
    }
    sum / norm
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn index_order_is_x_fastest_and_lookup_is_piecewise_constant() {
        let data: Vec<f32> = (0..24).map(|v| v as f32).collect();
        let g = DensityGrid::new([2, 3, 4], [0.0; 3], [2.0, 3.0, 4.0], data)
            .unwrap()
            .with_filter(DensityFilter::Nearest);
        assert_eq!(g.at(1, 0, 0), 1.0);
        assert_eq!(g.at(0, 1, 0), 2.0);
        assert_eq!(g.at(0, 0, 1), 6.0);
        // Anywhere inside voxel (1, 2, 3) gives its value; outside the box 0.
        assert_eq!(g.density_at([1.01, 2.99, 3.5]), g.at(1, 2, 3));
        assert_eq!(g.density_at([2.0, 1.0, 1.0]), 0.0);
        assert_eq!(g.density_at([-1e-9, 1.0, 1.0]), 0.0);
        // Round trip through the x-slowest VoxelGrid.
        let back = DensityGrid::from_voxel_grid(&g.to_voxel_grid(), g.bbox_min, g.bbox_max);
        assert_eq!(back.unwrap().with_filter(DensityFilter::Nearest), g);
    }

    /// Mitsuba's trilinear convention by hand on a 2×1×1 grid (values 1 and 3, box
    /// [0, 2]×[0, 1]×[0, 1], centres at x = 0.5 and 1.5): linear between the centres, the edge
    /// value in the outer half voxels, 0 outside the closed box.
    #[test]
    fn trilinear_lookup_follows_mitsuba() {
        let g = DensityGrid::new([2, 1, 1], [0.0; 3], [2.0, 1.0, 1.0], vec![1.0, 3.0]).unwrap();
        assert_eq!(g.filter, DensityFilter::Trilinear);
        let at = |x: f64| g.density_at([x, 0.3, 0.9]);
        assert_eq!(at(0.5), 1.0);
        assert_eq!(at(1.5), 3.0);
        assert!((at(1.0) - 2.0).abs() < 1e-15);
        assert!((at(0.75) - 1.5).abs() < 1e-15);
        // Outer half voxel: clamped to the edge voxel, up to the face itself.
        assert_eq!(at(0.0), 1.0);
        assert_eq!(at(0.2), 1.0);
        assert_eq!(at(1.9), 3.0);
        assert_eq!(at(2.0), 3.0);
        // y and z have one voxel: constant across the box.
        assert_eq!(g.density_at([1.0, 0.0, 1.0]), at(1.0));
        // Outside the box: 0.
        assert_eq!(at(-1e-12), 0.0);
        assert_eq!(at(2.0 + 1e-12), 0.0);
        assert_eq!(g.density_at([1.0, 1.5, 0.5]), 0.0);
        // A 2×2×2 grid: at the common corner of the centres' cube the mean of all 8; an
        // off-centre point against the explicit blend.
        let data: Vec<f32> = (0..8).map(|v| (v * v) as f32).collect();
        let g = DensityGrid::new([2; 3], [0.0; 3], [1.0; 3], data.clone()).unwrap();
        let mean = data.iter().map(|v| *v as f64).sum::<f64>() / 8.0;
        assert!((g.density_at([0.5; 3]) - mean).abs() < 1e-12);
        let p = [0.3, 0.6, 0.45];
        let f = p.map(|c: f64| c * 2.0 - 0.5);
        let mut expect = 0.0;
        for (idx, v) in data.iter().enumerate() {
            let (i, j, k) = (idx % 2, (idx / 2) % 2, idx / 4);
            let w = |b: usize, t: f64| if b == 1 { t } else { 1.0 - t };
            expect += *v as f64 * w(i, f[0]) * w(j, f[1]) * w(k, f[2]);
        }
        assert!((g.density_at(p) - expect).abs() < 1e-12);
        // The basis weights reproduce the lookup.
        let mut via = 0.0;
        for (i, wx) in g.axis_weights(0, p[0]) {
            for (j, wy) in g.axis_weights(1, p[1]) {
                for (k, wz) in g.axis_weights(2, p[2]) {
                    via += wx * wy * wz * g.at(i, j, k);
                }
            }
        }
        assert!((via - expect).abs() < 1e-12);
    }

    #[test]
    fn filter_names_parse_and_bad_ones_are_named() {
        for f in [DensityFilter::Trilinear, DensityFilter::Nearest] {
            assert_eq!(f.name().parse::<DensityFilter>().unwrap(), f);
        }
        assert_eq!(DensityFilter::default(), DensityFilter::Trilinear);
        let e = format!("{:#}", "linear".parse::<DensityFilter>().unwrap_err());
        assert!(
            e.contains("\"linear\"") && e.contains("trilinear") && e.contains("nearest"),
            "{e}"
        );
    }

    #[test]
    fn procedural_media_are_deterministic_and_seed_dependent() {
        for kind in [Procedural::Cloud, Procedural::Nebula] {
            let a = kind.grid([16; 3], [-1.0; 3], [1.0; 3], 7).unwrap();
            let b = kind.grid([16; 3], [-1.0; 3], [1.0; 3], 7).unwrap();
            let c = kind.grid([16; 3], [-1.0; 3], [1.0; 3], 8).unwrap();
            assert_eq!(a, b);
            assert_ne!(a, c);
            assert!(a.data.iter().all(|v| (0.0..=1.0).contains(v)));
            // Vacuum around the medium: the outermost voxel layer is empty.
            let (lo, hi) = a.occupied_range().unwrap();
            assert!(
                lo.iter().all(|&v| v > 0) && hi.iter().all(|&v| v < 15),
                "{kind:?}"
            );
        }
        let s = Procedural::Sphere
            .grid([8; 3], [-1.0; 3], [1.0; 3], 0)
            .unwrap();
        assert_eq!(s.density_at([0.0; 3]), 1.0);
        assert_eq!(s.density_at([0.95, 0.95, 0.0]), 0.0);
    }

    /// The cloud's shortcuts (nothing evaluated outside r = 0.85 or where the body is 0)
    /// give the same bits as the full formula, on a lattice through the whole box.
    #[test]
    fn cloud_density_shortcuts_change_no_value() {
        let full = |u: [f64; 3], seed: u64| {
            let r = (u[0] * u[0] + u[1] * u[1] + u[2] * u[2]).sqrt();
            let disp = 0.22 * fbm([u[0] * 2.0, u[1] * 2.0, u[2] * 2.0], seed, 4);
            let body = smoothstep(0.0, 0.15, 0.62 + disp - r);
            let detail = 0.6 + 0.4 * fbm([u[0] * 5.0, u[1] * 5.0, u[2] * 5.0], seed ^ 0x5bd1, 3);
            (body * detail).clamp(0.0, 1.0)
        };
        let n = 41;
        let mut nonzero = 0;
        for seed in [0, 7] {
            for idx in 0..n * n * n {
                let u = [idx % n, (idx / n) % n, idx / (n * n)]
                    .map(|c| 2.0 * c as f64 / (n - 1) as f64 - 1.0);
                let (a, b) = (Procedural::Cloud.density(u, seed), full(u, seed));
                assert_eq!(a.to_bits(), b.to_bits(), "{u:?}: {a} vs {b}");
                nonzero += usize::from(a > 0.0);
            }
        }
        assert!(nonzero > 1000, "{nonzero}");
    }

    #[test]
    fn bad_grids_are_refused() {
        assert!(DensityGrid::new([1, 1, 1], [0.0; 3], [1.0; 3], vec![-1.0]).is_err());
        assert!(DensityGrid::new([1, 1, 1], [0.0; 3], [1.0; 3], vec![f32::NAN]).is_err());
        assert!(DensityGrid::new([1, 1, 2], [0.0; 3], [1.0; 3], vec![1.0]).is_err());
        assert!(DensityGrid::new([1, 1, 1], [0.0; 3], [1.0, 0.0, 1.0], vec![1.0]).is_err());
    }
}
