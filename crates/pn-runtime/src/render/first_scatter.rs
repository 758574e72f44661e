//! The first-scatter source and the [`Problem`] a render scene poses on its solve grid.
//!
//! docs/design.md §6: for a directional or point light the uncollided radiance is a delta in the
//! light's travel direction d, so the first-scatter source
//! `Q(x,ω) = σ_s(x) ∫ p(ω'·ω) L_u(x,ω') dω' = σ_s T E p(d·ω)` projects onto the real SH
//! (Funk–Hecke, §2.1) as
//!
//! ```text
//! Q_l^m(x) = Σ_lights σ_s(x) T(x) E(x) λ_l p_l Y_l^m(d(x))
//! ```
//!
//! with T the deep-shadow-map transmittance and E the unattenuated irradiance (Φ/(4πr²) for
//! a point light, whose d and E depend on x). The source is evaluated at the density-voxel
//! centres (T from a deep shadow map at the voxel centres, exact optical depth through the
//! filtered density, [`super::shadow`]; σ_s there is the voxel's own scale·ρ·albedo for both
//! filters, since trilinear interpolation reproduces the values at the centres), read
//! between the centres **with the medium's filter** (trilinear: interpolated like the
//! density; nearest: constant per voxel) and volume-averaged exactly onto the solve cells
//! ([`cell_average`]). Every filter basis function integrates to one voxel volume, so the
//! total first-scatter power on any solve grid is Σ_voxels σ_s T E V for both filters. σ_t
//! and σ_s are exact cell averages of the filtered medium ([`resample`]).
//!
//! **Error.** The only approximation is the reconstruction of the source σ_s T E p between
//! voxel centres: its trilinear (or piecewise-constant) interpolant instead of the product
//! of the filtered σ_s with the exact T between the centres, an O(h_voxel²) interpolation
//! error (O(h_voxel) for nearest) of a smooth function. Its constant is not small where a
//! voxel is about one mean free path thick: the voxel-centre values integrate like the
//! midpoint rule, which underestimates the convex e^{−τ} across a voxel. Measured in issue
//! 17's study (P_5 @ 24³, source evaluated on a lattice 2× and 4× finer than the voxels,
//! docs/vacuum.md): the image mean rises by 1.0 (sphere), 1.1 (puff) and 2.7 (cumulus)
//! percentage points at 2×, and 4× changes that by ≤ 0.2 more. That source of error is
//! known and not yet removed.
//!
//! Everything is handed to the assembly as voxel fields. The solution of the P_N system
//! with this source is the collided radiance
//! L_ms (light scattered at least once); the uncollided part and single scattering are added
//! by the renderer.

use super::hull_absorber::add_hull_absorber;
use super::lights::Light;
use super::medium::DensityGrid;
use super::scene::{AbsorberPlacement, RenderScene, SolveBoundary};
use super::shadow::{cell_centre, DeepShadowMaps, Extinction};
use super::solve_setup::{add_absorbing_layer, cell_average, resample};
use crate::field::{Field, VoxelGrid};
use crate::problem::{Boundary, Grid, Phase, Problem, Scattering, SourceTerm};
use pn_stencil::quadrature::real_sh;
use std::sync::Arc;

/// The source moments `Q_l^m`, l ≤ `max_band`, at the cell centres of `grid`
/// (x slowest), for cell-averaged `sigma_s`. Bands whose phase factor λ_l p_l vanishes
/// (all l > 0 for isotropic scattering) are left out. Returns `(l, m, values)`.
pub fn source_moments(
    grid: &Grid,
    sigma_s: &[f64],
    phase: Phase,
    lights: &[Light],
    shadows: &DeepShadowMaps,
    max_band: u32,
) -> Vec<(u32, i32, Vec<f64>)> {
    let [nx, ny, nz] = grid.res;
    let mut out = Vec::new();
    for l in 0..=max_band {
        let f = phase.moment(l);
        if f == 0.0 {
            continue;
        }
        for m in -(l as i32)..=(l as i32) {
            let mut q = vec![0.0; nx * ny * nz];
            for (c, v) in q.iter_mut().enumerate() {
                if sigma_s[c] == 0.0 {
                    continue;
                }
                let x = cell_centre(grid, [c / (ny * nz), (c / nz) % ny, c % nz]);
                for (light, map) in lights.iter().zip(&shadows.maps) {
                    let inc = light.incident(x);
                    if inc.irradiance == 0.0 {
                        continue;
                    }
                    let d = inc.travel;
                    let y = real_sh(
                        l as usize,
                        m as i64,
                        d[2].clamp(-1.0, 1.0),
                        d[1].atan2(d[0]),
                    );
                    *v += sigma_s[c] * map[c] * inc.irradiance * f * y;
                }
            }
            out.push((l, m, q));
        }
    }
    out
}

/// The problem of a render scene on `grid`, with its deep shadow maps.
pub struct FirstScatterProblem {
    /// Fields and sources on the solve grid; Dirichlet boundary (light leaves);
    /// σ_t threshold from the scene or automatic where vacuum is present.
    pub problem: Problem,
    /// Transmittance from each density-voxel centre to each light (on [`density_as_grid`]),
    /// at the voxels near the medium ([`shadow_maps_near_medium`]; 0 elsewhere).
    pub shadows: DeepShadowMaps,
    /// Whether the σ_t threshold was chosen automatically.
    pub auto_sigma_t_min: bool,
    /// Seconds spent on the deep shadow maps.
    pub seconds_shadow_maps: f64,
    /// Seconds spent resampling the coefficients and projecting the source.
    pub seconds_sources: f64,
}

/// The density grid's voxels as a [`Grid`] (cell centres = voxel centres).
pub fn density_as_grid(density: &DensityGrid) -> Grid {
    Grid {
        dim: pn_stencil::Dim::Three,
        min: density.bbox_min,
        max: density.bbox_max,
        res: density.res,
    }
}

/// Deep shadow maps at the voxel centres of `ext`'s density grid (the cells of
/// [`density_as_grid`]), computed only where they can be read: at voxels within one voxel
/// (the 26-neighbourhood) of a voxel with non-zero density; elsewhere they hold 0. The
/// first-scatter source reads T only at voxels with σ_s > 0, and a trilinear read of τ at a
/// point of non-zero density (either filter; [`super::light_depth::LightDepth`] for point
/// lights) only reads the 8 voxel centres around it, which all lie within one voxel of a
/// non-empty voxel; so every value that is used equals [`DeepShadowMaps::compute`]'s, and
/// the rays from the empty space around the medium are not traced.
pub fn shadow_maps_near_medium(ext: &Extinction, lights: &[Light]) -> DeepShadowMaps {
    let g = ext.grid;
    let [nx, ny, nz] = g.res;
    let occupied = |i: usize, j: usize, k: usize| g.data[g.index(i, j, k)] != 0.0;
    let near = |[i, j, k]: [usize; 3]| {
        let span = |c: usize, n: usize| c.saturating_sub(1)..=(c + 1).min(n - 1);
        span(i, nx).any(|a| span(j, ny).any(|b| span(k, nz).any(|c| occupied(a, b, c))))
    };
    DeepShadowMaps::compute_where(ext, &density_as_grid(g), lights, near)
}

/// Builds the problem on the solve grid `grid`: σ_t and σ_s are cell averages of the
/// density read with its filter ([`resample`]); the source moments up to `max_band` are
/// computed **at the density resolution** — deep shadow maps at the voxel centres,
/// [`source_moments`] per voxel — and then read with the same filter and volume-averaged
/// onto the solve cells ([`cell_average`]). `density` is the scene's
/// [`RenderScene::density_grid`] (it carries the filter). So a coarse
/// solve grid still receives the exact total first-scatter power of the fine grid
/// (Σ σ_s T E V over the voxels), instead of sampling T at a coarse cell centre that may
/// lie several mean free paths deep.
pub fn first_scatter_problem(
    scene: &RenderScene,
    density: &DensityGrid,
    grid: &Grid,
    max_band: u32,
) -> anyhow::Result<FirstScatterProblem> {
    first_scatter_problem_with_shadows(scene, density, grid, max_band, None)
}

/// [`first_scatter_problem`] with the deep shadow maps given, when another scene with the same
/// σ_t and the same light positions and directions computed them (the channels of a coloured
/// scene with an achromatic σ_t): they depend on nothing else. `None` computes them.
pub fn first_scatter_problem_with_shadows(
    scene: &RenderScene,
    density: &DensityGrid,
    grid: &Grid,
    max_band: u32,
    shadows: Option<DeepShadowMaps>,
) -> anyhow::Result<FirstScatterProblem> {
    let t0 = std::time::Instant::now();
    let ext = Extinction {
        grid: density,
        scale: scene.medium.sigma_t_scale,
    };
    let vgrid = density_as_grid(density);
    let shadows = match shadows {
        Some(s) => {
            anyhow::ensure!(
                s.maps.len() == scene.lights.len()
                    && s.maps.iter().all(|m| m.len() == vgrid.cells()),
                "internal: the given shadow maps do not fit the lights and the density grid"
            );
            s
        }
        None => shadow_maps_near_medium(&ext, &scene.lights),
    };
    let seconds_shadow_maps = t0.elapsed().as_secs_f64();
    let t1 = std::time::Instant::now();
    let (mut sigma_t, sigma_s) = resample(density, &scene.medium, grid);
    if scene.solve.absorber == AbsorberPlacement::Hull {
        add_hull_absorber(grid, scene.solve.ramp_cells(), &mut sigma_t);
    }
    add_absorbing_layer(grid, scene.solve.layer_cells(), &mut sigma_t);
    // σ_s per voxel in the Grid order (x slowest) of `vgrid`.
    let [nx, ny, nz] = density.res;
    let fine_index = |[i, j, k]: [usize; 3]| (i * ny + j) * nz + k;
    let mut sigma_s_fine = vec![0.0; nx * ny * nz];
    for k in 0..nz {
        for j in 0..ny {
            for i in 0..nx {
                let idx = density.index(i, j, k);
                sigma_s_fine[fine_index([i, j, k])] = scene.medium.sigma_t_scale
                    * density.data[idx] as f64
                    * scene.medium.albedo_at(idx);
            }
        }
    }
    let fine = source_moments(
        &vgrid,
        &sigma_s_fine,
        scene.phase,
        &scene.lights,
        &shadows,
        max_band,
    );
    let voxel = |data: Vec<f64>| -> anyhow::Result<Field> {
        Ok(Field::Voxel(Arc::new(VoxelGrid::new(
            grid.res, grid.min, grid.max, data,
        )?)))
    };
    let sources = fine
        .into_iter()
        .map(|(l, m, q)| {
            let avg = cell_average(density, grid, |v, _| q[fine_index(v)]);
            Ok(SourceTerm {
                l,
                m,
                field: voxel(avg)?,
            })
        })
        .collect::<anyhow::Result<Vec<_>>>()?;
    let mut problem = Problem {
        grid: grid.clone(),
        sigma_t: voxel(sigma_t)?,
        scattering: Scattering::SigmaS(voxel(sigma_s)?),
        phase: scene.phase,
        sources,
        boundary: match scene.solve.boundary {
            SolveBoundary::Dirichlet => Boundary::Dirichlet,
            SolveBoundary::Marshak => Boundary::Marshak,
        },
        sigma_t_min: scene.solve.sigma_t_min,
    };
    let auto = problem.auto_sigma_t_min();
    if auto.is_some() {
        problem.sigma_t_min = auto;
    }
    problem.validate()?;
    Ok(FirstScatterProblem {
        problem,
        shadows,
        auto_sigma_t_min: auto.is_some(),
        seconds_shadow_maps,
        seconds_sources: t1.elapsed().as_secs_f64(),
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::render::lights::phase_value;
    use crate::render::test_box_grid;
    use pn_stencil::quadrature::SphereQuadrature;

    /// Total source power ∫∫Q dω dV = Σ_cells √(4π) Q_0^0 V equals Σ σ_s T E V for a
    /// homogeneous, optically thin box lit from +z (T = exp(−σ_t (1 − z)) exactly, cell
    /// centres), to rounding (1e-12 relative).
    #[test]
    fn total_source_power_is_sigma_s_t_e() {
        let n = 6;
        let g = test_box_grid([n; 3]);
        let density = DensityGrid::new([n; 3], [-1.0; 3], [1.0; 3], vec![1.0; n * n * n]).unwrap();
        let (st, alb, e) = (0.2, 0.7, 1.7);
        let ext = Extinction {
            grid: &density,
            scale: st,
        };
        let lights = [Light::Directional {
            direction: [0.0, 0.0, -1.0],
            irradiance: e,
        }];
        let shadows = DeepShadowMaps::compute(&ext, &g, &lights);
        let sigma_s = vec![alb * st; n * n * n];
        let q = source_moments(
            &g,
            &sigma_s,
            Phase::HenyeyGreenstein(0.5),
            &lights,
            &shadows,
            1,
        );
        let q00 = &q.iter().find(|t| t.0 == 0).unwrap().2;
        let v = g.cell_volume();
        let total: f64 = q00.iter().sum::<f64>() * (4.0 * std::f64::consts::PI).sqrt() * v;
        let mut expect = 0.0;
        for c in 0..n * n * n {
            let z = cell_centre(&g, [c / (n * n), (c / n) % n, c % n])[2];
            expect += alb * st * (-st * (1.0 - z)).exp() * e * v;
        }
        assert!(
            (total - expect).abs() < 1e-12 * expect,
            "{total} vs {expect}"
        );
        // Q_1^0 (z) of light travelling along −z is negative: Y_1^0(d) = −√(3/4π).
        let q10 = &q.iter().find(|t| t.0 == 1 && t.1 == 0).unwrap().2;
        assert!(q10.iter().all(|v| *v < 0.0));
    }

    /// Q_l^m equals the projection ∫ σ_s T E p(d·ω) Y_l^m(ω) dω computed by quadrature, for
    /// an oblique direction and HG g = 0.3, l ≤ 5. Quadrature of the smooth HG lobe with
    /// 48 × 96 nodes converges to ~1e-12; tolerance 1e-9.
    #[test]
    fn source_moments_match_quadrature_of_the_phase_lobe() {
        let g = test_box_grid([1; 3]);
        let d = [0.3f64, -0.8, 0.52];
        let len = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
        let d = d.map(|c| c / len);
        let lights = [Light::Directional {
            direction: d,
            irradiance: 1.0,
        }];
        let shadows = DeepShadowMaps {
            maps: vec![vec![0.5]],
        };
        let phase = Phase::HenyeyGreenstein(0.3);
        let q = source_moments(&g, &[2.0], phase, &lights, &shadows, 5);
        let quad = SphereQuadrature::new(48, 96);
        for (l, m, v) in q {
            let mut s = 0.0;
            for (p, w) in quad.points.iter().zip(&quad.weights) {
                let (dir, mu, phi) = p;
                let cos = dir[0] * d[0] + dir[1] * d[1] + dir[2] * d[2];
                s += w
                    * 2.0
                    * 0.5
                    * phase_value(phase, cos)
                    * real_sh(l as usize, m as i64, *mu, *phi);
            }
            assert!((v[0] - s).abs() < 1e-9, "Q_{l}^{m}: {} vs {s}", v[0]);
        }
    }

    /// On a coarse solve grid the source keeps the fine grid's total power
    /// Σ √(4π) Q_0^0 V (volume averaging is exact; rounding only).
    #[test]
    fn coarse_solve_grid_keeps_the_first_scatter_power() {
        let mut scene = RenderScene::builtin("sphere").unwrap();
        scene.medium.resolution = [12; 3];
        let density = scene.density_grid().unwrap();
        let sg = crate::render::solve_setup::solve_grid(&density, [5; 3], 1, true)
            .unwrap()
            .unwrap();
        let fs = first_scatter_problem(&scene, &density, &sg.grid, 0).unwrap();
        let crate::field::Field::Voxel(q) = &fs.problem.sources[0].field else {
            panic!("voxel source expected")
        };
        let coarse: f64 = q.data.iter().sum::<f64>() * sg.grid.cell_volume();
        let vgrid = density_as_grid(&density);
        let mut fine = 0.0;
        for c in 0..density.data.len() {
            let [nx, ny, _] = density.res;
            let (i, j, k) = (c % nx, (c / nx) % ny, c / (nx * ny));
            let x = cell_centre(&vgrid, [i, j, k]);
            let sigma_s = scene.medium.sigma_t_scale * density.data[c] as f64 * 0.8;
            let ext = Extinction {
                grid: &density,
                scale: scene.medium.sigma_t_scale,
            };
            for l in &scene.lights {
                fine += sigma_s * ext.transmittance_to(x, l) * l.incident(x).irradiance;
            }
        }
        fine *= vgrid.cell_volume() / (4.0 * std::f64::consts::PI).sqrt();
        assert!(fine > 0.0);
        assert!((coarse - fine).abs() < 1e-12 * fine, "{coarse} vs {fine}");
        // `[solve] boundary` reaches the problem.
        assert!(matches!(fs.problem.boundary, Boundary::Dirichlet));
        scene.solve.boundary = SolveBoundary::Marshak;
        let fs = first_scatter_problem(&scene, &density, &sg.grid, 0).unwrap();
        assert!(matches!(fs.problem.boundary, Boundary::Marshak));
    }

    #[test]
    fn isotropic_scattering_has_only_the_first_band() {
        let g = test_box_grid([1; 3]);
        let lights = [Light::Point {
            position: [3.0, 0.0, 0.0],
            power: 1.0,
        }];
        let shadows = DeepShadowMaps {
            maps: vec![vec![1.0]],
        };
        let q = source_moments(&g, &[1.0], Phase::Isotropic, &lights, &shadows, 3);
        assert_eq!(q.len(), 1);
        // E = Φ/(4π r²) at r = 3, Q_0^0 = σ_s E Y_0^0.
        let expect = 1.0 / (4.0 * std::f64::consts::PI * 9.0) / (4.0 * std::f64::consts::PI).sqrt();
        assert!((q[0].2[0] - expect).abs() < 1e-15);
    }
}
