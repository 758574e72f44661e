//! The solve grid of a render scene: cropping to the medium and resampling the density.
//!
//! The solve grid has `solve.resolution` cells across the medium box (cell size
//! `h_d = extent_d / res_d`, possibly coarser than the density grid). It is cropped to the
//! solve cells that overlap a voxel with density > 0, plus `margin` empty cells on every
//! side (these may reach outside the medium box, where the density is 0): light leaves
//! through the Dirichlet boundary of the cropped grid ("model only what the
//! scene requires"). The uncropped alternative, for the statistics, is the whole medium box
//! plus the same margin.
//!
//! Around the margin lies an **absorbing layer** ([`add_absorbing_layer`]): light that leaves
//! the medium's box never comes back, so it may be absorbed out there. Without it the
//! Dirichlet-zero closure, which fixes *all* moments (outgoing ones included) to 0, reaches
//! through the nearly transparent vacuum (σ_t = σ_t,min) to the medium's surface and drains
//! the multiple scattering: on the built-in sphere P_3 recovered 42 % of Mitsuba's
//! multiple scattering without the layer and 82 % with it (P_5: 44 % → 90 %).
//!
//! σ_t and σ_s on the solve grid are **exact volume averages** of the piecewise-constant
//! density over each solve cell (separable overlap weights per axis), so coarsening
//! conserves the total extinction ∫σ_t dV.

use super::medium::DensityGrid;
use super::scene::MediumSpec;
use crate::problem::Grid;
use anyhow::ensure;
use pn_stencil::Dim;

/// A solve grid placed on the medium.
#[derive(Clone, Debug, PartialEq)]
pub struct SolveGrid {
    /// The grid (3D).
    pub grid: Grid,
    /// Index of its first cell in the (unbounded) lattice of solve cells whose cell 0 starts
    /// at the medium box's lower corner.
    pub offset: [i64; 3],
}

/// Smallest number of cells per axis of a solve grid (FLD keeps a boundary layer on each
/// side and needs an interior).
pub const MIN_SOLVE_CELLS: usize = 3;

/// The solve grid over the medium: cropped to the occupied voxels plus `margin` (when
/// `crop`), or the whole box plus `margin`. `None` when the medium is empty (density 0
/// everywhere: there is nothing to solve).
pub fn solve_grid(
    density: &DensityGrid,
    resolution: [usize; 3],
    margin: usize,
    crop: bool,
) -> anyhow::Result<Option<SolveGrid>> {
    ensure!(
        resolution.iter().all(|&n| n > 0),
        "solve resolution must be positive, got {resolution:?}"
    );
    let Some((lo, hi)) = density.occupied_range() else {
        return Ok(None);
    };
    let hv = density.h();
    let mut offset = [0i64; 3];
    let mut res = [0usize; 3];
    let (mut min, mut max) = ([0.0; 3], [0.0; 3]);
    for d in 0..3 {
        let extent = density.bbox_max[d] - density.bbox_min[d];
        let h = extent / resolution[d] as f64;
        let (a, b) = if crop {
            // Occupied interval in units of solve cells; a small tolerance keeps faces that
            // coincide (up to rounding) from adding a cell.
            let u0 = lo[d] as f64 * hv[d] / h;
            let u1 = (hi[d] + 1) as f64 * hv[d] / h;
            ((u0 + 1e-9).floor() as i64, (u1 - 1e-9).ceil() as i64)
        } else {
            (0, resolution[d] as i64)
        };
        let (mut a, mut b) = (a - margin as i64, b + margin as i64);
        while ((b - a) as usize) < MIN_SOLVE_CELLS {
            a -= 1;
            b += 1;
        }
        offset[d] = a;
        res[d] = (b - a) as usize;
        min[d] = density.bbox_min[d] + a as f64 * h;
        max[d] = density.bbox_min[d] + b as f64 * h;
    }
    let grid = Grid {
        dim: Dim::Three,
        min,
        max,
        res,
    };
    grid.validate()?;
    Ok(Some(SolveGrid { grid, offset }))
}

/// Optical depth of the outermost cell of the absorbing layer (σ_t·h); the layer's σ_t
/// grows quadratically from 0 to this over its cells, so that the P_N waves enter it without
/// a jump in σ_t (a graded absorber reflects less than an abrupt one).
pub const ABSORBER_OPTICAL_DEPTH_PER_CELL: f64 = 3.0;

/// Raises σ_t in the outer `layers` cells of `grid` to a graded pure absorber: at depth
/// `d` cells from the boundary (0 = outermost), σ_t ≥ ((layers − d)/layers)²·τ/h with
/// τ = [`ABSORBER_OPTICAL_DEPTH_PER_CELL`]. σ_s is left as it is (0 out there, where the
/// layer lies outside the medium's box or in its empty margin). `sigma_t` is in the cell
/// order of [`cell_average`] (x slowest).
pub fn add_absorbing_layer(grid: &Grid, layers: usize, sigma_t: &mut [f64]) {
    if layers == 0 {
        return;
    }
    let [nx, ny, nz] = grid.res;
    let h = (0..3).map(|d| grid.h(d)).fold(f64::INFINITY, f64::min);
    for i in 0..nx {
        for j in 0..ny {
            for k in 0..nz {
                let depth = [i, j, k, nx - 1 - i, ny - 1 - j, nz - 1 - k]
                    .into_iter()
                    .min()
                    .unwrap_or(0);
                if depth < layers {
                    let t = (layers - depth) as f64 / layers as f64;
                    let c = (i * ny + j) * nz + k;
                    sigma_t[c] = sigma_t[c].max(t * t * ABSORBER_OPTICAL_DEPTH_PER_CELL / h);
                }
            }
        }
    }
}

/// Per-axis overlap weights: for each solve cell the density voxels it overlaps and the
/// overlapping fraction of the solve cell.
fn overlaps(density: &DensityGrid, grid: &Grid, d: usize) -> Vec<Vec<(usize, f64)>> {
    let hv = density.h()[d];
    let n = density.res[d];
    let h = grid.h(d);
    (0..grid.res[d])
        .map(|c| {
            let x0 = grid.min[d] + c as f64 * h;
            let x1 = x0 + h;
            let v0 = ((x0 - density.bbox_min[d]) / hv).floor().max(0.0) as usize;
            let v1 = (((x1 - density.bbox_min[d]) / hv).ceil().max(0.0) as usize).min(n);
            (v0..v1)
                .filter_map(|v| {
                    let a = density.bbox_min[d] + v as f64 * hv;
                    let len = (x1.min(a + hv) - x0.max(a)).max(0.0);
                    (len > 0.0).then_some((v, len / h))
                })
                .collect()
        })
        .collect()
}

/// The volume average over each cell of `grid` of a piecewise-constant per-voxel quantity
/// `value([i, j, k], index)` (voxel coordinates and density index; 0 outside the density
/// box), x slowest (`(i·ny + j)·nz + k`, the order of [`crate::field::VoxelGrid`]). Voxels
/// with density 0 are skipped (every quantity averaged here vanishes there).
pub fn cell_average(
    density: &DensityGrid,
    grid: &Grid,
    value: impl Fn([usize; 3], usize) -> f64,
) -> Vec<f64> {
    let w = [0, 1, 2].map(|d| overlaps(density, grid, d));
    let [nx, ny, nz] = grid.res;
    let mut out = vec![0.0; nx * ny * nz];
    for i in 0..nx {
        for j in 0..ny {
            for k in 0..nz {
                let mut sum = 0.0;
                for &(vx, wx) in &w[0][i] {
                    for &(vy, wy) in &w[1][j] {
                        for &(vz, wz) in &w[2][k] {
                            let idx = density.index(vx, vy, vz);
                            if density.data[idx] > 0.0 {
                                sum += wx * wy * wz * value([vx, vy, vz], idx);
                            }
                        }
                    }
                }
                out[(i * ny + j) * nz + k] = sum;
            }
        }
    }
    out
}

/// Cell averages of σ_t and σ_s over the cells of `grid` (see [`cell_average`]).
pub fn resample(density: &DensityGrid, medium: &MediumSpec, grid: &Grid) -> (Vec<f64>, Vec<f64>) {
    let st = |idx: usize| medium.sigma_t_scale * density.data[idx] as f64;
    let sigma_t = cell_average(density, grid, |_, idx| st(idx));
    let sigma_s = cell_average(density, grid, |_, idx| st(idx) * medium.albedo_at(idx));
    let sigma_s = sigma_s
        .iter()
        .zip(&sigma_t)
        .map(|(s, t)| s.min(*t))
        .collect();
    (sigma_t, sigma_s)
}

#[cfg(test)]
mod tests {
    #[test]
    fn absorbing_layer_is_graded_and_leaves_the_interior_alone() {
        let grid = Grid {
            dim: Dim::Three,
            min: [0.0; 3],
            max: [2.0, 2.0, 2.0],
            res: [10, 10, 10],
        };
        let mut sigma_t = vec![0.5; 1000];
        add_absorbing_layer(&grid, 3, &mut sigma_t);
        let at = |i: usize, j: usize, k: usize| sigma_t[(i * 10 + j) * 10 + k];
        let h = 0.2;
        // Outermost cell: the full optical depth per cell; then (2/3)², (1/3)² of it.
        assert!((at(0, 5, 5) - ABSORBER_OPTICAL_DEPTH_PER_CELL / h).abs() < 1e-12);
        assert!((at(5, 9, 5) - ABSORBER_OPTICAL_DEPTH_PER_CELL / h).abs() < 1e-12);
        assert!((at(1, 5, 5) - 4.0 / 9.0 * ABSORBER_OPTICAL_DEPTH_PER_CELL / h).abs() < 1e-12);
        assert!((at(5, 5, 7) - 1.0 / 9.0 * ABSORBER_OPTICAL_DEPTH_PER_CELL / h).abs() < 1e-12);
        // Depth 3 and beyond: untouched; never lowered.
        assert_eq!(at(3, 5, 5), 0.5);
        assert_eq!(at(5, 5, 5), 0.5);
        let mut none = vec![0.5; 1000];
        add_absorbing_layer(&grid, 0, &mut none);
        assert!(none.iter().all(|&v| v == 0.5));
    }

    use super::*;
    use crate::render::scene::{Albedo, MediumSource};
    use crate::render::Procedural;

    fn medium(scale: f64, albedo: f64) -> MediumSpec {
        MediumSpec {
            source: MediumSource::Procedural(Procedural::Box),
            seed: 0,
            resolution: [8; 3],
            bbox_min: [-1.0; 3],
            bbox_max: [1.0; 3],
            sigma_t_scale: scale,
            albedo: Albedo::Constant(albedo),
            filter: crate::render::DensityFilter::Trilinear,
        }
    }

    #[test]
    fn cropping_keeps_the_medium_plus_margin() {
        // Box medium: density 1 on the central half, [-0.5, 0.5)³, of 8³ voxels.
        let g = Procedural::Box
            .grid([8; 3], [-1.0; 3], [1.0; 3], 0)
            .unwrap();
        let sg = solve_grid(&g, [4; 3], 1, true).unwrap().unwrap();
        // Solve cells of 0.5: occupied cells 1..3, plus one cell each side: 0..4.
        assert_eq!(sg.grid.res, [4; 3]);
        assert_eq!(sg.offset, [0; 3]);
        let sg = solve_grid(&g, [8; 3], 2, true).unwrap().unwrap();
        assert_eq!(sg.grid.res, [8; 3]);
        assert_eq!(sg.grid.min, [-1.0; 3]);
        let full = solve_grid(&g, [8; 3], 2, false).unwrap().unwrap();
        assert_eq!(full.grid.res, [12; 3]);
        assert_eq!(full.grid.min, [-1.5; 3]);
        let empty = DensityGrid::new([2; 3], [0.0; 3], [1.0; 3], vec![0.0; 8]).unwrap();
        assert!(solve_grid(&empty, [4; 3], 1, true).unwrap().is_none());
    }

    #[test]
    fn resampling_conserves_total_extinction() {
        let g = Procedural::Cloud
            .grid([12; 3], [-1.0; 3], [1.0; 3], 3)
            .unwrap();
        let m = medium(7.0, 0.6);
        let sg = solve_grid(&g, [5; 3], 2, true).unwrap().unwrap();
        let (t, s) = resample(&g, &m, &sg.grid);
        let fine: f64 =
            g.data.iter().map(|v| 7.0 * *v as f64).sum::<f64>() * g.h().iter().product::<f64>();
        let coarse: f64 = t.iter().sum::<f64>() * sg.grid.cell_volume();
        // Exact up to rounding of sums of a few thousand terms.
        assert!((fine - coarse).abs() < 1e-12 * fine, "{fine} vs {coarse}");
        for (a, b) in t.iter().zip(&s) {
            assert!((b - 0.6 * a).abs() <= 1e-14 * a);
        }
    }
}
