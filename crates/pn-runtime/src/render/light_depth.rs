//! The optical depth from every point of the medium to each light, precomputed on a grid
//! for the deterministic renderer ([`super::march`]).
//!
//! The nodes are the **density-voxel centres**; at each node the optical depth τ to the
//! light is the exact integral of [`Extinction::optical_depth`] (traversal of the filter's
//! lattice, [`super::shadow`]) — the same rays as the first-scatter source's deep shadow maps,
//! so a render that solved first takes τ = −ln T from those ([`LightDepth::from_shadow_maps`])
//! instead of tracing them again. Between the nodes τ is interpolated trilinearly (clamped
//! to the outermost centres in the outer half voxel) and the transmittance is `exp(−τ)`:
//! interpolating τ rather than T keeps the interpolant exact for a τ linear in x (a
//! homogeneous slab lit along an axis) and avoids the bias of interpolating a convex
//! function of depth (between two nodes of very different depth, interpolating T
//! overestimates e^{−τ}).
//!
//! The interpolation error is O(h²·|∂²τ|) with h the voxel size (O(h·|∇τ|) in the outer half
//! voxel, where the density of a medium with vacuum around it is 0); it does not shrink with
//! the renderer's step (see the error budget in [`super::march`]). τ is continuous
//! everywhere (also for a point light inside the medium, where it behaves like σ_t·r), so
//! the interpolant is too.

use super::lights::Light;
use super::medium::DensityGrid;
use super::shadow::{DeepShadowMaps, Extinction};
use rayon::prelude::*;

/// Largest stored optical depth: e^{−745} is the smallest positive f64, so deeper is black
/// (and a transmittance of exactly 0 maps to this finite depth).
pub const MAX_TAU: f64 = 745.0;

/// τ to each light at the density-voxel centres.
#[derive(Clone, Debug)]
pub struct LightDepth {
    /// World position of node (0, 0, 0): the centre of voxel (0, 0, 0).
    origin: [f64; 3],
    /// Node spacing (the voxel size).
    h: [f64; 3],
    /// Nodes per axis (the density resolution).
    res: [usize; 3],
    /// `tau[light][(i·ny + j)·nz + k]` (x slowest, the order of [`DeepShadowMaps`]).
    tau: Vec<Vec<f64>>,
}

impl LightDepth {
    /// Traces τ at the nodes for every light, in parallel: the nodes within one voxel of an
    /// occupied voxel (the only ones a lookup inside the density's support reaches); the
    /// others hold 0.
    pub fn compute(ext: &Extinction, lights: &[Light]) -> Self {
        let g = ext.grid;
        let mut ld = Self::empty(g, lights.len());
        let Some((lo, hi)) = g.occupied_range() else {
            return ld;
        };
        let first = lo.map(|c| c.saturating_sub(1));
        let last = [0, 1, 2].map(|d| (hi[d] + 1).min(g.res[d] - 1));
        let [_, ny, nz] = g.res;
        let centres = ld.origin;
        let h = ld.h;
        for (light, tau) in lights.iter().zip(&mut ld.tau) {
            tau.par_chunks_mut(ny * nz)
                .enumerate()
                .filter(|(i, _)| (first[0]..=last[0]).contains(i))
                .for_each(|(i, plane)| {
                    for j in first[1]..=last[1] {
                        for k in first[2]..=last[2] {
                            let x = [
                                centres[0] + i as f64 * h[0],
                                centres[1] + j as f64 * h[1],
                                centres[2] + k as f64 * h[2],
                            ];
                            let inc = light.incident(x);
                            plane[j * nz + k] = if inc.distance == 0.0 {
                                0.0
                            } else {
                                ext.optical_depth(x, inc.travel.map(|c| -c), inc.distance)
                                    .min(MAX_TAU)
                            };
                        }
                    }
                });
        }
        ld
    }

    /// τ = −ln T from deep shadow maps computed at the voxel centres of `density` (as
    /// [`super::first_scatter::first_scatter_problem`] does), one map per light; `None` when
    /// the maps do not have one value per voxel.
    pub fn from_shadow_maps(density: &DensityGrid, maps: &DeepShadowMaps) -> Option<Self> {
        let n: usize = density.res.iter().product();
        if maps.maps.iter().any(|m| m.len() != n) {
            return None;
        }
        let mut ld = Self::empty(density, 0);
        ld.tau = maps
            .maps
            .iter()
            .map(|m| {
                m.iter()
                    .map(|t| {
                        if *t > 0.0 {
                            (-t.ln()).min(MAX_TAU)
                        } else {
                            MAX_TAU
                        }
                    })
                    .collect()
            })
            .collect();
        Some(ld)
    }

    fn empty(g: &DensityGrid, lights: usize) -> Self {
        let h = g.h();
        let n: usize = g.res.iter().product();
        Self {
            origin: [0, 1, 2].map(|d| g.bbox_min[d] + 0.5 * h[d]),
            h,
            res: g.res,
            tau: vec![vec![0.0; n]; lights],
        }
    }

    /// Lights held.
    pub fn lights(&self) -> usize {
        self.tau.len()
    }

    /// Optical depth from `x` to light `light`, trilinear between the voxel centres
    /// (clamped to the outermost ones).
    #[inline]
    pub fn tau(&self, light: usize, x: [f64; 3]) -> f64 {
        let mut lo = [0usize; 3];
        let mut hi = [0usize; 3];
        let mut t = [0.0f64; 3];
        for d in 0..3 {
            let top = (self.res[d] - 1) as f64;
            let u = ((x[d] - self.origin[d]) / self.h[d]).clamp(0.0, top);
            let f = u.floor();
            lo[d] = f as usize;
            hi[d] = (lo[d] + 1).min(self.res[d] - 1);
            t[d] = u - f;
        }
        let [_, ny, nz] = self.res;
        let data = &self.tau[light];
        let at = |i: usize, j: usize, k: usize| data[(i * ny + j) * nz + k];
        let lerp = |a: f64, b: f64, s: f64| a + s * (b - a);
        let c00 = lerp(at(lo[0], lo[1], lo[2]), at(lo[0], lo[1], hi[2]), t[2]);
        let c01 = lerp(at(lo[0], hi[1], lo[2]), at(lo[0], hi[1], hi[2]), t[2]);
        let c10 = lerp(at(hi[0], lo[1], lo[2]), at(hi[0], lo[1], hi[2]), t[2]);
        let c11 = lerp(at(hi[0], hi[1], lo[2]), at(hi[0], hi[1], hi[2]), t[2]);
        lerp(lerp(c00, c01, t[1]), lerp(c10, c11, t[1]), t[0])
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn linear_depth_is_interpolated_exactly_and_matches_the_traversal() {
        // Homogeneous box [0,2]×[0,1]×[0,1], light straight down (−y): τ = σ_t (1 − y),
        // linear, so trilinear interpolation is exact (to rounding).
        let g = DensityGrid::new([4, 3, 2], [0.0; 3], [2.0, 1.0, 1.0], vec![1.0; 24]).unwrap();
        let ext = Extinction {
            grid: &g,
            scale: 3.0,
        };
        let light = Light::Directional {
            direction: [0.0, -1.0, 0.0],
            irradiance: 1.0,
        };
        let ld = LightDepth::compute(&ext, std::slice::from_ref(&light));
        assert_eq!(ld.lights(), 1);
        // Between the outermost centres (y ∈ [1/6, 5/6]).
        for x in [[0.3, 0.2, 0.7], [1.99, 0.8, 0.01], [1.0, 0.5, 0.5]] {
            let want = 3.0 * (1.0 - x[1]);
            assert!((ld.tau(0, x) - want).abs() < 1e-12, "{x:?}");
        }
        // An oblique point light: at the nodes the grid holds the exact traversal.
        let p = Light::Point {
            position: [2.5, 1.5, 0.3],
            power: 1.0,
        };
        let ld = LightDepth::compute(&ext, std::slice::from_ref(&p));
        let x = [0.75, 0.5, 0.25];
        let inc = p.incident(x);
        let exact = ext.optical_depth(x, inc.travel.map(|c| -c), inc.distance);
        assert!((ld.tau(0, x) - exact).abs() < 1e-12);
        // The same from the deep shadow maps' transmittance (τ = −ln T).
        let maps = DeepShadowMaps::compute(
            &ext,
            &crate::render::first_scatter::density_as_grid(&g),
            std::slice::from_ref(&p),
        );
        let from_maps = LightDepth::from_shadow_maps(&g, &maps).unwrap();
        assert!((from_maps.tau(0, x) - exact).abs() < 1e-12);
    }

    #[test]
    fn an_empty_medium_has_zero_depth() {
        let g = DensityGrid::new([2, 2, 2], [0.0; 3], [1.0; 3], vec![0.0; 8]).unwrap();
        let ext = Extinction {
            grid: &g,
            scale: 3.0,
        };
        let light = Light::Directional {
            direction: [0.0, -1.0, 0.0],
            irradiance: 1.0,
        };
        let ld = LightDepth::compute(&ext, &[light]);
        assert_eq!(ld.tau(0, [0.5; 3]), 0.0);
    }
}
