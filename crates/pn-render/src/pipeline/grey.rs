//! One grey scene: the density grid, the multiple scattering of its method, the views and
//! the report.

use super::methods::{method_for, MsSolution, PreparedScene};
use super::{
    mean, rms, turntable_camera, RenderOptions, RenderReport, RenderRun, SharedWork, Timings,
    ViewReport, MAX_VIEWS,
};
use crate::light_depth::LightDepth;
use crate::march::{MarchSettings, Marcher};
use crate::renderer::{Image, MsField, Renderer};
use crate::scene::RendererKind;
use crate::shadow::Extinction;
use crate::{DensityGrid, LightLeg, RenderScene};
use anyhow::{ensure, Result};
use std::sync::Arc;
use std::time::Instant;

/// [`super::render_views`] of a grey scene; `shared`: what a scene with the same σ_t and
/// light geometry computed (the optical depth to the lights, reused instead of computed;
/// solutions to start from).
pub(super) fn render_grey_views(
    scene: &RenderScene,
    options: &RenderOptions,
    views: usize,
    shared: SharedWork<'_>,
) -> Result<RenderRun> {
    ensure!(
        scene.colours.is_none(),
        "internal: a coloured scene must be rendered channel by channel"
    );
    ensure!(
        (1..=MAX_VIEWS).contains(&views),
        "the number of views must lie in 1..={MAX_VIEWS}, got {views}"
    );
    let t_all = Instant::now();
    let t0 = Instant::now();
    let density = scene.density_grid()?;
    if shared.light_depth.is_none() {
        check_light_depth_memory(scene, &density, options)?;
    }
    let mut timings = Timings {
        density: t0.elapsed().as_secs_f64(),
        ..Timings::default()
    };
    let method = method_for(scene, options.pde.as_ref())?;
    // Delta-M (crate::delta_m): the light leg's σ_t′ serves the source and the camera's
    // single scattering alike.
    let light_leg = LightLeg::new(
        scene,
        &density,
        crate::delta_m::truncation(scene, method.delta_m_order()),
    );
    let prepared = PreparedScene {
        scene,
        density: &density,
        options,
        light_depth: shared.light_depth.clone(),
        guesses: &shared.guesses,
        light_leg: &light_leg,
    };
    let MsSolution {
        field: ms,
        unknowns,
        solver,
        light_depth,
        staggered,
        pop,
        sweeps,
        seconds,
        mut notes,
    } = method.solve(&prepared)?;
    if let Some((order, f)) = light_leg.truncation() {
        let rule = if scene.solve.similarity {
            "the similarity relation"
        } else {
            "delta-M"
        };
        notes.push(format!(
            "{rule}: the forward peak f = {f:.4} (λ_{} p_{} of {}) travels on unscattered; the \
             solve carries the truncated phase, the camera's single scattering the full one",
            order + 1,
            order + 1,
            scene.phase.describe()
        ));
    }
    if let pn_runtime::problem::Phase::Tabulated(t) = &scene.phase {
        if (t.normalisation() - 1.0).abs() > 1e-6 {
            notes.push(format!(
                "the tabulated phase was normalised (2π∫p dμ = 1): its values were multiplied by {:.6}",
                t.normalisation()
            ));
        }
    }
    timings.light_depth = seconds.light_depth;
    timings.sources = seconds.sources;
    timings.solve = seconds.solve;
    timings.sweeps = seconds.sweeps;
    let mut warnings: Vec<String> = pop.iter().flat_map(|p| p.warnings.clone()).collect();
    let support = density
        .support()
        .filter(|_| scene.medium.sigma_t_scale > 0.0);
    if support.is_none() {
        warnings.push(
            "the medium is empty (no density > 0, or sigma_t_scale = 0): the image is black"
                .to_string(),
        );
    }
    let deterministic = scene.render.renderer == RendererKind::Deterministic;
    // The solve's optical depth to the lights (or an earlier channel's) serves the camera
    // rays too; a render without a solve computes it here.
    let mut light_depth = light_depth;
    if deterministic {
        light_depth = light_depth.or(shared.light_depth);
        if light_depth.is_none() {
            let t_ld = Instant::now();
            light_depth = Some(compute_light_depth(
                &light_leg.extinction(&density),
                scene,
                options.threads,
            )?);
            timings.light_depth = t_ld.elapsed().as_secs_f64();
        }
    }
    let views_out = render_images(
        &ViewsInput {
            scene,
            density: &density,
            ms: ms.as_ref(),
            light_depth: light_depth.as_deref().filter(|_| deterministic),
            light_leg: &light_leg,
            options,
            support,
        },
        views,
        &mut warnings,
    )?;
    timings.render += views_out.seconds;
    notes.extend(warnings.iter().map(|w| format!("warning: {w}")));
    timings.total = t_all.elapsed().as_secs_f64();
    let image = views_out.images[0].clone();
    let report = RenderReport {
        method: method.name().to_string(),
        order: method.order(),
        unknowns,
        solver,
        sweeps,
        pop,
        seconds: timings,
        views: views_out.reports,
        warnings,
        ..grey_report(scene, &density, &image, options.threads)
    };
    Ok(RenderRun {
        image,
        views: if views > 1 {
            views_out.images
        } else {
            Vec::new()
        },
        rgb: None,
        solution: ms,
        light_depth,
        staggered,
        report,
        notes,
    })
}

/// Refuses a render whose optical-depth grids ([`LightDepth`]) would exceed the memory
/// limit, with their size, before anything is traced (issue 53). They are the largest
/// allocation of a finely voxelised medium: on the built-in cloud at 128³–512³ about 100
/// bytes per medium voxel for its one directional light, within 4 % of the whole process's
/// measured peak.
fn check_light_depth_memory(
    scene: &RenderScene,
    density: &DensityGrid,
    options: &RenderOptions,
) -> Result<()> {
    use pn_runtime::memory_estimate::{default_limit_bytes, human_bytes};
    let sky_from = scene.sky_lights.as_ref().map(|s| s.first);
    let bytes = LightDepth::estimate_bytes(density, &scene.lights, sky_from);
    let limit = options.max_memory.unwrap_or_else(default_limit_bytes);
    ensure!(
        bytes <= limit,
        "the optical depth to the {} light{} over the {}×{}×{} medium voxels needs about {}, \
         more than the memory limit of {} (raise it with --max-memory, or lower the medium's \
         resolution)",
        scene.lights.len(),
        if scene.lights.len() == 1 { "" } else { "s" },
        density.res[0],
        density.res[1],
        density.res[2],
        human_bytes(u128::from(bytes)),
        human_bytes(u128::from(limit))
    );
    Ok(())
}

/// The optical depth to the lights of a render without a solve.
fn compute_light_depth(
    ext: &Extinction<'_>,
    scene: &RenderScene,
    threads: Option<usize>,
) -> Result<Arc<LightDepth>> {
    let sky_from = scene.sky_lights.as_ref().map(|s| s.first);
    Ok(Arc::new(pn_runtime::with_threads(threads, || {
        LightDepth::compute_with_sky(ext, &scene.lights, sky_from)
    })?))
}

/// What the views are rendered from.
struct ViewsInput<'a> {
    scene: &'a RenderScene,
    density: &'a DensityGrid,
    ms: Option<&'a MsField>,
    /// The optical depth to the lights for the deterministic renderer (None: Monte Carlo).
    light_depth: Option<&'a LightDepth>,
    /// The extinction on the way from the lights.
    light_leg: &'a LightLeg,
    options: &'a RenderOptions,
    /// The medium's box (None: empty).
    support: Option<([f64; 3], [f64; 3])>,
}

/// The rendered views.
struct Views {
    images: Vec<Image>,
    /// Per view of a turntable (empty for one view).
    reports: Vec<ViewReport>,
    /// Seconds rendering, all views.
    seconds: f64,
}

/// Renders the `views` turntable views (one: the scene's camera), warning about views that
/// do not see the medium.
fn render_images(
    input: &ViewsInput<'_>,
    views: usize,
    warnings: &mut Vec<String>,
) -> Result<Views> {
    let ViewsInput {
        scene,
        density,
        ms,
        light_depth,
        light_leg,
        options,
        support,
    } = *input;
    let r = &scene.render;
    let threads = options.threads;
    let rows = options.rows.as_ref();
    let settings = MarchSettings {
        rays: r.rays,
        step: r.step,
        cutoff: r.cutoff,
        exact_transmittance: r.exact_transmittance,
        sky_grid: r.sky_grid,
    };
    let marcher = light_depth.map(|ld| {
        Marcher::new(scene, density, ms, ld, settings)
            .with_light_extinction(light_leg.extinction(density))
    });
    let mut out = Views {
        images: Vec::with_capacity(views),
        reports: Vec::new(),
        seconds: 0.0,
    };
    for k in 0..views {
        let camera = turntable_camera(&scene.camera, k, views);
        if let Some((lo, hi)) = support {
            if !camera.sees_box(lo, hi) {
                let which = if views > 1 {
                    format!("view {k}: ")
                } else {
                    String::new()
                };
                warnings.push(format!(
                    "{which}the medium (box {lo:?} to {hi:?}) is outside the camera's view: \
                     the image is black"
                ));
            }
        }
        let t2 = Instant::now();
        let image = match &marcher {
            Some(m) => pn_runtime::with_threads(threads, || m.render(&camera, rows))?,
            None => {
                let view_scene;
                let sc = if k == 0 {
                    scene
                } else {
                    view_scene = RenderScene {
                        camera: camera.clone(),
                        ..scene.clone()
                    };
                    &view_scene
                };
                let renderer = Renderer {
                    scene: sc,
                    density,
                    ms,
                    light_leg: Some(light_leg),
                };
                pn_runtime::with_threads(threads, || renderer.render(r.spp, r.seed, rows))?
            }
        };
        let secs = t2.elapsed().as_secs_f64();
        out.seconds += secs;
        if views > 1 {
            out.reports.push(ViewReport {
                index: k,
                angle_deg: 360.0 * k as f64 / views as f64,
                position: camera.position,
                render_seconds: secs,
                mean_radiance: mean(&image.data),
            });
        }
        out.images.push(image);
    }
    Ok(out)
}

/// The report's fields that describe the scene, the renderer and the image (the method's,
/// the timings, the views and the warnings are filled by the caller).
fn grey_report(
    scene: &RenderScene,
    density: &DensityGrid,
    image: &Image,
    threads: Option<usize>,
) -> RenderReport {
    let r = &scene.render;
    let deterministic = r.renderer == RendererKind::Deterministic;
    let hmin = density.h().iter().fold(f64::INFINITY, |m, v| m.min(*v));
    RenderReport {
        scene: scene.name.clone(),
        method: String::new(),
        order: None,
        renderer: r.renderer.name().into(),
        rays_per_pixel: if deterministic { r.rays } else { r.spp },
        step: deterministic.then_some(r.step),
        step_length: deterministic.then_some(r.step * hmin),
        cutoff: deterministic.then_some(r.cutoff),
        exact_transmittance: deterministic.then_some(r.exact_transmittance),
        filter: density.filter.name().into(),
        spp: r.spp,
        seed: r.seed,
        width: image.width,
        height: image.height,
        density_resolution: density.res,
        tracking: tracking(deterministic, r.exact_transmittance).into(),
        unknowns: None,
        solver: None,
        sweeps: 0,
        pop: None,
        seconds: Timings::default(),
        mean_radiance: mean(&image.data),
        rms_standard_error: rms(&image.std_err),
        peak_memory_bytes: pn_runtime::peak_memory_bytes(),
        threads: pn_runtime::effective_threads(threads),
        views: Vec::new(),
        warnings: Vec::new(),
        overrides: Vec::new(),
        channels: Vec::new(),
    }
}

/// How the image was integrated (the report's `tracking`).
fn tracking(deterministic: bool, exact_transmittance: bool) -> &'static str {
    if deterministic {
        if exact_transmittance {
            "ray marching, exponential midpoint rule on the filter's lattice pieces; \
             exact transmittance to the lights (traversal at every step)"
        } else {
            "ray marching, exponential midpoint rule on the filter's lattice pieces; \
             transmittance to the lights from the optical-depth grid at the voxel \
             centres"
        }
    } else {
        "delta tracking with the global majorant; next-event estimation with exact \
         voxel-traversal transmittance"
    }
}
