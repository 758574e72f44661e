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
//! with T the transmittance to the light and E the unattenuated irradiance (Φ/(4πr²) for a
//! point light, whose d and E depend on x). The scalar factor σ_s T E is **averaged exactly
//! over each solve cell** ([`super::source_quadrature::cell_scattering_weights`]: 2×2×2
//! Gauss–Legendre on the pieces between the density filter's break points, T = e^{−τ} at
//! the nodes, τ from the render's optical-depth grid [`LightDepth`]), and d is taken at the
//! cell centre. σ_t and σ_s are exact cell averages of the filtered medium ([`resample`]).
//!
//! **Error.** The quadrature's, about (σ_t ℓ)⁴/4320 on a piece of length ℓ ≤ one voxel, and
//! for point lights the trilinear interpolation of τ between the voxel centres and d at the
//! cell centre. Until 2026-12-05 the source was σ_s T E at the density-voxel centres, read
//! between them with the filter: at the voxel centres that is the midpoint rule, which
//! underestimates the convex e^{−τ} across a voxel about one mean free path thick (the image
//! mean rose by 0.9 pp on the sphere and 2.3 pp on the cumulus at P_5 @ 24³ with the exact
//! average; issue 17, docs/vacuum.md).
//!
//! Everything is handed to the assembly as voxel fields. The solution of the P_N system
//! with this source is the collided radiance
//! L_ms (light scattered at least once); the uncollided part and single scattering are added
//! by the renderer.

use super::delta_m::LightLeg;
use super::hull_absorber::add_hull_absorber;
use super::light_depth::LightDepth;
use super::lights::Light;
use super::medium::DensityGrid;
use super::scene::{AbsorberPlacement, RenderScene, SolveBoundary};
use super::shadow::cell_centre;
#[cfg(test)]
use super::shadow::Extinction;
#[cfg(test)]
use super::shadow::{density_as_grid, DeepShadowMaps};
use super::solve_setup::{add_absorbing_layer, resample};
use super::source_quadrature::cell_scattering_weights;
use crate::sky::SkyLights;
use pn_runtime::field::{Field, VoxelGrid};
use pn_runtime::problem::{Boundary, Grid, Phase, Problem, Scattering, SourceTerm};
use pn_stencil::quadrature::real_sh;
use rayon::prelude::*;
use std::sync::Arc;

/// The source moments `Q_l^m`, l ≤ `max_band`, at the cell centres of `grid`
/// (x slowest), for cell-averaged `sigma_s` and the transmittance at the cell centres
/// (`shadows`). Bands whose phase factor λ_l p_l vanishes (all l > 0 for isotropic
/// scattering) are left out. Returns `(l, m, values)`. The tests' reference for
/// [`source_moments_weighted`].
#[cfg(test)]
pub(crate) fn source_moments(
    grid: &Grid,
    sigma_s: &[f64],
    phase: &Phase,
    lights: &[Light],
    shadows: &DeepShadowMaps,
    max_band: u32,
) -> Vec<(u32, i32, Vec<f64>)> {
    let [_, ny, nz] = grid.res;
    let weights: Vec<Vec<f64>> = lights
        .iter()
        .zip(&shadows.maps)
        .map(|(light, map)| {
            (0..sigma_s.len())
                .map(|c| {
                    if sigma_s[c] == 0.0 {
                        return 0.0;
                    }
                    let x = cell_centre(grid, [c / (ny * nz), (c / nz) % ny, c % nz]);
                    sigma_s[c] * map[c] * light.incident(x).irradiance
                })
                .collect()
        })
        .collect();
    source_moments_weighted(grid, &weights, phase, lights, None, max_band)
}

/// [`source_moments`] from the weight σ_s·T·E of each cell and light, `weights[light][cell]`
/// (e.g. [`cell_scattering_weights`]): `Q_l^m = Σ_lights weight · λ_l p_l Y_l^m(d)` with
/// the light's travel direction d at the cell centre; for the lights of `sky`, Y_l^m averaged
/// over each light's region.
pub fn source_moments_weighted(
    grid: &Grid,
    weights: &[Vec<f64>],
    phase: &Phase,
    lights: &[Light],
    sky: Option<&SkyLights>,
    max_band: u32,
) -> Vec<(u32, i32, Vec<f64>)> {
    let [nx, ny, nz] = grid.res;
    let sh = |l: u32, m: i32, d: [f64; 3]| {
        real_sh(
            l as usize,
            m as i64,
            d[2].clamp(-1.0, 1.0),
            d[1].atan2(d[0]),
        )
    };
    // One task per moment (l, m) (the moments are independent; the order is kept).
    let moments: Vec<(u32, i32, f64)> = (0..=max_band)
        .map(|l| (l, phase.moment(l)))
        .filter(|&(_, f)| f != 0.0)
        .flat_map(|(l, f)| (-(l as i32)..=(l as i32)).map(move |m| (l, m, f)))
        .collect();
    moments
        .into_par_iter()
        .map(|(l, m, f)| {
            // A directional light's Y_l^m(d) is the same in every cell (a sky brings tens); a
            // sky light's is averaged over its region (crate::sky::SkyLights::sh_average).
            let fixed: Vec<Option<f64>> = lights
                .iter()
                .enumerate()
                .map(|(i, light)| match light {
                    Light::Directional { direction, .. } => Some(
                        sky.and_then(|s| s.sh_average(i, |d| sh(l, m, d)))
                            .unwrap_or_else(|| sh(l, m, *direction)),
                    ),
                    Light::Point { .. } => None,
                })
                .collect();
            let mut q = vec![0.0; nx * ny * nz];
            for (c, v) in q.iter_mut().enumerate() {
                if weights.iter().all(|w| w[c] == 0.0) {
                    continue;
                }
                let x = cell_centre(grid, [c / (ny * nz), (c / nz) % ny, c % nz]);
                for ((light, w), y) in lights.iter().zip(weights).zip(&fixed) {
                    if w[c] == 0.0 {
                        continue;
                    }
                    let y = match y {
                        Some(y) => *y,
                        None => sh(l, m, light.incident(x).travel),
                    };
                    *v += w[c] * f * y;
                }
            }
            (l, m, q)
        })
        .collect()
}

/// The problem of a render scene on `grid`, with the optical depth to its lights.
pub struct FirstScatterProblem {
    /// Fields and sources on the solve grid; Dirichlet boundary (light leaves);
    /// σ_t threshold from the scene or automatic where vacuum is present.
    pub problem: Problem,
    /// The optical depth from the medium to each light ([`LightDepth::compute`]), which the
    /// source's quadrature read; the renderer's camera rays read the same.
    pub depth: Arc<LightDepth>,
    /// Whether the σ_t threshold was chosen automatically.
    pub auto_sigma_t_min: bool,
    /// Seconds spent computing `depth` (0 when it was given).
    pub seconds_light_depth: f64,
    /// Seconds spent resampling the coefficients and projecting the source.
    pub seconds_sources: f64,
}

/// Builds the problem on the solve grid `grid`: σ_t and σ_s are cell averages of the
/// density read with its filter ([`resample`]); the source moments up to `max_band` are
/// [`source_moments_weighted`] with the weights σ_s T E averaged over each solve cell by
/// quadrature on the density's own pieces ([`cell_scattering_weights`]), T from the optical
/// depth to the lights ([`LightDepth::compute`]). `density` is the scene's
/// [`RenderScene::density_grid`] (it carries the filter). So a coarse solve grid still
/// receives the total first-scatter power ∫ σ_s T E dx of the medium, instead of sampling T
/// at a coarse cell centre that may lie several mean free paths deep. (The pipeline calls
/// [`first_scatter_problem_with_depth`]; this is the tests' shorthand.)
#[cfg(test)]
pub(crate) fn first_scatter_problem(
    scene: &RenderScene,
    density: &DensityGrid,
    grid: &Grid,
    max_band: u32,
) -> anyhow::Result<FirstScatterProblem> {
    let leg = LightLeg::none(scene);
    first_scatter_problem_with_depth(scene, density, grid, max_band, None, &leg)
}

/// [`first_scatter_problem`] with the optical depth to the lights given, when another scene
/// with the same σ_t and the same light positions and directions computed it (the channels
/// of a coloured scene with an achromatic σ_t): it depends on nothing else. `None` computes
/// it ([`LightDepth::compute`]).
///
/// `light_leg` is the extinction between the lights and the medium: with a delta-M share
/// f > 0 ([`crate::delta_m`]) the depth and the transmittance are those of σ_t′ = σ_t − f σ_s,
/// the source is `σ_s (λ_l p_l − f) T′ E Y_l^m(d)` for l ≤ `max_band`, and the problem carries
/// σ_t′, σ_s′ = (1 − f) σ_s and the truncated phase of order `light_leg`'s N (the same P_N
/// operator; the transport sweeps read these).
pub fn first_scatter_problem_with_depth(
    scene: &RenderScene,
    density: &DensityGrid,
    grid: &Grid,
    max_band: u32,
    depth: Option<Arc<LightDepth>>,
    light_leg: &LightLeg,
) -> anyhow::Result<FirstScatterProblem> {
    let t0 = std::time::Instant::now();
    let ext = light_leg.extinction(density);
    let sky_from = scene.sky_lights.as_ref().map(|s| s.first);
    let depth = match depth {
        Some(d) => {
            anyhow::ensure!(
                d.lights() == scene.lights.len(),
                "internal: the given optical-depth grid has {} lights, the scene {}",
                d.lights(),
                scene.lights.len()
            );
            d
        }
        None => Arc::new(LightDepth::compute_with_sky(&ext, &scene.lights, sky_from)),
    };
    let seconds_light_depth = t0.elapsed().as_secs_f64();
    let t1 = std::time::Instant::now();
    let (mut sigma_t, sigma_s) = resample(density, &scene.medium, grid);
    if scene.solve.absorber == AbsorberPlacement::Hull {
        add_hull_absorber(grid, scene.solve.ramp_cells(), &mut sigma_t);
    }
    add_absorbing_layer(grid, scene.solve.layer_cells(), &mut sigma_t);
    // σ_s·T·E per solve cell and light, averaged exactly over the cell (module docs).
    let mut weights = cell_scattering_weights(
        density,
        &scene.medium,
        &ext,
        &scene.lights,
        &depth,
        grid,
        sky_from,
    );
    // Delta-M: σ_s (λ_l p_l − f) = σ_s′ p′_l with σ_s′ = (1 − f) σ_s.
    let (phase, f) = light_leg.solve_phase(&scene.phase);
    if f > 0.0 {
        for w in weights.iter_mut().flatten() {
            *w *= 1.0 - f;
        }
        // σ_t′ = σ_t − f σ_s (the absorber's addition to σ_t is kept), σ_s′ = (1 − f) σ_s.
        for (t, s) in sigma_t.iter_mut().zip(&sigma_s) {
            *t -= f * s;
        }
    }
    let sigma_s: Vec<f64> = sigma_s.iter().map(|s| (1.0 - f) * s).collect();
    let voxel = |data: Vec<f64>| -> anyhow::Result<Field> {
        Ok(Field::Voxel(Arc::new(VoxelGrid::new(
            grid.res, grid.min, grid.max, data,
        )?)))
    };
    let sky = scene.sky_lights.as_deref();
    let sources = source_moments_weighted(grid, &weights, &phase, &scene.lights, sky, max_band)
        .into_iter()
        .map(|(l, m, q)| {
            Ok(SourceTerm {
                l,
                m,
                field: voxel(q)?,
            })
        })
        .collect::<anyhow::Result<Vec<_>>>()?;
    let mut problem = Problem {
        grid: grid.clone(),
        sigma_t: voxel(sigma_t)?,
        scattering: Scattering::SigmaS(voxel(sigma_s)?),
        phase,
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
        depth,
        auto_sigma_t_min: auto.is_some(),
        seconds_light_depth,
        seconds_sources: t1.elapsed().as_secs_f64(),
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::lights::phase_value;
    use crate::test_box_grid;
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
            &Phase::HenyeyGreenstein(0.5),
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
        let q = source_moments(&g, &[2.0], &phase, &lights, &shadows, 5);
        let quad = SphereQuadrature::new(48, 96);
        for (l, m, v) in q {
            let mut s = 0.0;
            for (p, w) in quad.points.iter().zip(&quad.weights) {
                let (dir, mu, phi) = p;
                let cos = dir[0] * d[0] + dir[1] * d[1] + dir[2] * d[2];
                s += w
                    * 2.0
                    * 0.5
                    * phase_value(&phase, cos)
                    * real_sh(l as usize, m as i64, *mu, *phi);
            }
            assert!((v[0] - s).abs() < 1e-9, "Q_{l}^{m}: {} vs {s}", v[0]);
        }
    }

    /// The source's total power Σ √(4π) Q_0^0 V is ∫ σ_s T E dx whatever the solve grid:
    /// a coarse grid (5³, padded) and the density's own voxels (12³) agree to 1e-3 (they put
    /// their Gauss nodes at other points, where the point light's τ is interpolated between
    /// the voxel centres: 3.5e-4 seen), and both exceed the voxel-centre (midpoint) sum, which misses the convex
    /// e^{−τ} across the voxels (source_quadrature module docs).
    #[test]
    fn coarse_solve_grid_keeps_the_first_scatter_power() {
        let mut scene = RenderScene::builtin("sphere").unwrap();
        scene.medium.resolution = [12; 3];
        let density = scene.density_grid().unwrap();
        let sg = crate::solve_setup::solve_grid(&density, [5; 3], 1, true)
            .unwrap()
            .unwrap();
        let power = |grid: &Grid| {
            let fs = first_scatter_problem(&scene, &density, grid, 0).unwrap();
            let pn_runtime::field::Field::Voxel(q) = &fs.problem.sources[0].field else {
                panic!("voxel source expected")
            };
            q.data.iter().sum::<f64>() * grid.cell_volume() * (4.0 * std::f64::consts::PI).sqrt()
        };
        let vgrid = density_as_grid(&density);
        let (coarse, fine) = (power(&sg.grid), power(&vgrid));
        let mut midpoint = 0.0;
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
                midpoint += sigma_s * ext.transmittance_to(x, l) * l.incident(x).irradiance;
            }
        }
        midpoint *= vgrid.cell_volume();
        assert!(midpoint > 0.0);
        assert!((coarse - fine).abs() < 1e-3 * fine, "{coarse} vs {fine}");
        assert!(fine > 1.02 * midpoint, "{fine} vs {midpoint}");
        // `[solve] boundary` reaches the problem.
        let fs = first_scatter_problem(&scene, &density, &sg.grid, 0).unwrap();
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
        let q = source_moments(&g, &[1.0], &Phase::Isotropic, &lights, &shadows, 3);
        assert_eq!(q.len(), 1);
        // E = Φ/(4π r²) at r = 3, Q_0^0 = σ_s E Y_0^0.
        let expect = 1.0 / (4.0 * std::f64::consts::PI * 9.0) / (4.0 * std::f64::consts::PI).sqrt();
        assert!((q[0].2[0] - expect).abs() < 1e-15);
    }
}
