//! The density grid of a render scene and the procedural media (sphere, box, noise-displaced
//! "cloud" and "nebula").
//!
//! **Convention (shared with the Mitsuba export).** Density is piecewise constant per voxel:
//! voxel (i, j, k) covers `bbox_min + [i, i+1)·h_x × [j, j+1)·h_y × [k, k+1)·h_z`, and the
//! density is 0 outside the box. Data are stored x fastest, index `(k·ny + j)·nx + i`, the
//! order of a `.vol` file (docs/design.md §6). σ_t(x) = `sigma_t_scale` × density(x).
//!
//! Procedural media are deterministic functions of the seed (a hash of the lattice point and
//! the seed, no global random state), evaluated at the voxel centres.

use crate::field::VoxelGrid;
use anyhow::{ensure, Context};

/// A piecewise-constant density on an axis-aligned box, x fastest (see the module docs).
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
}

impl DensityGrid {
    /// Creates a grid, checking the resolution, the box and the data (finite, ≥ 0).
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
        })
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

    /// Density at `p` (piecewise constant, 0 outside the box).
    pub fn density_at(&self, p: [f64; 3]) -> f64 {
        self.voxel_of(p).map_or(0.0, |[i, j, k]| self.at(i, j, k))
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

    /// The same data as a [`VoxelGrid`] (x slowest, f64), e.g. for [`crate::vol::encode_vol`].
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
                let s = [u[0] * 2.0, u[1] * 2.0, u[2] * 2.0];
                let disp = 0.22 * fbm(s, seed, 4);
                let depth = 0.62 + disp - r;
                let body = smoothstep(0.0, 0.15, depth);
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
        ensure!(
            res.iter().all(|&n| n > 0),
            "medium resolution must be positive on every axis, got {res:?}"
        );
        check_box(bbox_min, bbox_max)?;
        let n = res[0]
            .checked_mul(res[1])
            .and_then(|v| v.checked_mul(res[2]))
            .filter(|&n| n <= MAX_PROCEDURAL_VOXELS)
            .with_context(|| {
                format!("medium resolution {res:?} exceeds {MAX_PROCEDURAL_VOXELS} voxels")
            })?;
        let mut data = vec![0.0f32; n];
        for (idx, v) in data.iter_mut().enumerate() {
            let c = [
                idx % res[0],
                (idx / res[0]) % res[1],
                idx / (res[0] * res[1]),
            ];
            // Voxel centre mapped to [−1, 1].
            let u = [0, 1, 2].map(|d| 2.0 * (c[d] as f64 + 0.5) / res[d] as f64 - 1.0);
            *v = self.density(u, seed) as f32;
        }
        DensityGrid::new(res, bbox_min, bbox_max, data)
    }
}

/// Largest procedural grid (512³): bounds memory from a typo in the resolution.
pub const MAX_PROCEDURAL_VOXELS: usize = 512 * 512 * 512;

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
        let g = DensityGrid::new([2, 3, 4], [0.0; 3], [2.0, 3.0, 4.0], data).unwrap();
        assert_eq!(g.at(1, 0, 0), 1.0);
        assert_eq!(g.at(0, 1, 0), 2.0);
        assert_eq!(g.at(0, 0, 1), 6.0);
        // Anywhere inside voxel (1, 2, 3) gives its value; outside the box 0.
        assert_eq!(g.density_at([1.01, 2.99, 3.5]), g.at(1, 2, 3));
        assert_eq!(g.density_at([2.0, 1.0, 1.0]), 0.0);
        assert_eq!(g.density_at([-1e-9, 1.0, 1.0]), 0.0);
        // Round trip through the x-slowest VoxelGrid.
        let back = DensityGrid::from_voxel_grid(&g.to_voxel_grid(), g.bbox_min, g.bbox_max);
        assert_eq!(back.unwrap(), g);
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

    #[test]
    fn bad_grids_are_refused() {
        assert!(DensityGrid::new([1, 1, 1], [0.0; 3], [1.0; 3], vec![-1.0]).is_err());
        assert!(DensityGrid::new([1, 1, 1], [0.0; 3], [1.0; 3], vec![f32::NAN]).is_err());
        assert!(DensityGrid::new([1, 1, 2], [0.0; 3], [1.0; 3], vec![1.0]).is_err());
        assert!(DensityGrid::new([1, 1, 1], [0.0; 3], [1.0, 0.0, 1.0], vec![1.0]).is_err());
    }
}
