//! Coloured scenes ([`crate::colour`]): one grey solve and render per channel,
//! combined into RGB images. Radiative transfer does not couple wavelengths, so channel c of
//! the image is exactly the grey image of [`RenderScene::channel`]`(c)`. A channel is not
//! recomputed when an earlier channel has the same medium and lights whose strengths differ
//! by one common factor k ([`crate::colour::Colours::light_scale`]): transport is linear in the sources, so
//! the channel is k × that channel's image (the solve's error scales with it). Equal channels
//! (k = 1) are copies: they give the grey image exactly, at the cost of one channel. Channels
//! with the same σ_t scale share the optical depth to the lights, which depends on nothing
//! else, and start their solve from the earlier channels' solutions (the
//! albedo enters the operator, so each channel is still its own system; docs/inputs.md).

use super::grey::render_grey_views;
use super::report::{ChannelReport, RenderReport, Timings};
use super::{mean, rms, RenderOptions, RenderRun, SharedWork};
use crate::colour::CHANNELS;
use crate::renderer::Image;
use crate::scene::Albedo;
use crate::RenderScene;
use anyhow::{Context, Result};

/// The channel images of a coloured render.
#[derive(Clone, Debug)]
pub struct RgbImages {
    /// R, G and B of the image (view 0 of a turntable).
    pub image: [Image; 3],
    /// R, G and B of each turntable view, view 0 first (empty for a single view).
    pub views: Vec<[Image; 3]>,
}

impl RgbImages {
    /// The three channels' pixel values of the image (`view` None) or of a turntable view.
    pub fn planes(&self, view: Option<usize>) -> [&[f32]; 3] {
        planes(match view {
            None => &self.image,
            Some(k) => &self.views[k],
        })
    }
}

/// The three channels' pixel values.
fn planes(im: &[Image; 3]) -> [&[f32]; 3] {
    [&im[0].data, &im[1].data, &im[2].data]
}

/// [`super::render_views`] of a coloured scene: each distinct channel solved and rendered as
/// a grey scene, the images combined.
pub(super) fn render_views_rgb(
    scene: &RenderScene,
    options: &RenderOptions,
    views: usize,
) -> Result<RenderRun> {
    let colours = scene
        .colours
        .as_ref()
        .context("internal: render_views_rgb needs a coloured scene")?;
    // With delta-M the light leg's σ_t′ = σ_t − f σ_s depends on the albedo.
    let leg_reads_albedo = crate::delta_m::truncation(
        scene,
        super::methods::method_for(scene, options.pde.as_ref())?.delta_m_order(),
    )
    .is_some();
    let mut runs: Vec<Option<RenderRun>> = Vec::new();
    let mut copied: [Option<(usize, f64)>; 3] = [None; 3];
    let mut depth_from: [Option<usize>; 3] = [None; 3];
    let mut warm_from: [Vec<usize>; 3] = Default::default();
    for c in 0..3 {
        // Only computed channels are sources, so a copy never points to a copy.
        copied[c] = (0..c)
            .filter(|&p| copied[p].is_none())
            .find_map(|p| colours.light_scale(p, c).map(|k| (p, k)));
        if copied[c].is_some() {
            runs.push(None);
            continue;
        }
        // The optical depth to the lights depends on σ_t, the lights' geometry and (with
        // delta-M, σ_t′ = σ_t − f σ_s) the albedo only: an earlier channel with the same σ_t
        // scale and albedo has it.
        depth_from[c] = (0..c).find(|&p| {
            colours.sigma_t_scale[p] == colours.sigma_t_scale[c]
                && (!leg_reads_albedo || colours.albedo.is_none_or(|a| a[p] == a[c]))
                && runs[p].as_ref().is_some_and(|r| r.light_depth.is_some())
        });
        let light_depth = depth_from[c].and_then(|p| runs[p].as_ref()?.light_depth.clone());
        // Earlier channels with the same σ_t were solved on the same grid and layout: their
        // solutions start this channel's iteration (same tolerance, fewer iterations).
        let same_sigma_t: Vec<usize> = (0..c)
            .filter(|&p| colours.sigma_t_scale[p] == colours.sigma_t_scale[c])
            .filter(|&p| runs[p].as_ref().is_some_and(|r| r.staggered.is_some()))
            .collect();
        let guesses: Vec<&[f64]> = same_sigma_t
            .iter()
            .filter_map(|&p| runs[p].as_ref()?.staggered.as_deref())
            .collect();
        warm_from[c] = same_sigma_t;
        let shared = SharedWork {
            light_depth,
            guesses,
        };
        let run = render_grey_views(&scene.channel(c), options, views, shared)
            .with_context(|| format!("channel {}", CHANNELS[c]))?;
        runs.push(Some(run));
    }
    // Channel c's run and the factor on its images.
    let run_of = |c: usize| -> Result<(&RenderRun, f64)> {
        let (src, k) = copied[c].unwrap_or((c, 1.0));
        let run = runs[src]
            .as_ref()
            .context("internal: a copied channel's source was not rendered")?;
        Ok((run, k))
    };
    let src = [run_of(0)?, run_of(1)?, run_of(2)?];
    let r = src[0].0;
    let image = src.map(|(run, k)| scaled(&run.image, k));
    let views_rgb: Vec<[Image; 3]> = (0..r.views.len())
        .map(|v| src.map(|(run, k)| scaled(&run.views[v], k)))
        .collect();
    let mean_image = mean_of(&image);
    let mean_views: Vec<Image> = views_rgb.iter().map(mean_of).collect();

    let computed: Vec<&RenderRun> = runs.iter().flatten().collect();
    // Each computed channel's notes, channel by channel.
    let notes = computed
        .iter()
        .flat_map(|run| run.notes.iter().cloned())
        .collect();
    let mut report: RenderReport = r.report.clone();
    report.seconds = sum_timings(computed.iter().map(|run| &run.report.seconds));
    report.solver = None;
    report.mean_radiance = mean(&mean_image.data);
    report.rms_standard_error = rms(&mean_image.std_err);
    report.peak_memory_bytes = pn_runtime::peak_memory_bytes();
    for (k, v) in report.views.iter_mut().enumerate() {
        v.mean_radiance = mean(&mean_views[k].data);
        v.render_seconds = computed
            .iter()
            .map(|run| run.report.views[k].render_seconds)
            .sum();
    }
    report.warnings = computed
        .iter()
        .flat_map(|run| run.report.warnings.iter().cloned())
        .collect::<std::collections::BTreeSet<_>>()
        .into_iter()
        .collect();
    report.channels = (0..3)
        .map(|c| -> Result<ChannelReport> {
            let ch = scene.channel(c);
            let (run, _) = run_of(c)?;
            Ok(ChannelReport {
                channel: CHANNELS[c].into(),
                sigma_t_scale: ch.medium.sigma_t_scale,
                albedo: match ch.medium.albedo {
                    Albedo::Constant(a) => Some(a),
                    Albedo::Voxels(_) => None,
                },
                light_strength: ch.lights.iter().map(|l| l.strength()).collect(),
                copied_from: copied[c].map(|(p, _)| CHANNELS[p].to_string()),
                copy_scale: copied[c].map(|(_, k)| k),
                light_depth_from: depth_from[c].map(|p| CHANNELS[p].to_string()),
                solve_started_from: warm_from[c]
                    .iter()
                    .map(|&p| CHANNELS[p].to_string())
                    .collect(),
                mean_radiance: mean(&image[c].data),
                solver: copied[c]
                    .is_none()
                    .then(|| run.report.solver.clone())
                    .flatten(),
                seconds: copied[c].is_none().then(|| run.report.seconds.clone()),
            })
        })
        .collect::<Result<_>>()?;
    Ok(RenderRun {
        image: mean_image,
        views: mean_views,
        rgb: Some(RgbImages {
            image,
            views: views_rgb,
        }),
        solution: None,
        light_depth: None,
        staggered: None,
        report,
        notes,
    })
}

/// `k` × an image (a copy for k = 1).
fn scaled(im: &Image, k: f64) -> Image {
    if k == 1.0 {
        return im.clone();
    }
    let k = k as f32;
    Image {
        width: im.width,
        height: im.height,
        data: im.data.iter().map(|v| v * k).collect(),
        std_err: im.std_err.iter().map(|v| v * k.abs()).collect(),
    }
}

/// The per-pixel mean of three channel images; its standard error √(Σ se_c²)/3 treats the
/// channels' errors as independent.
fn mean_of(c: &[Image; 3]) -> Image {
    let n = c[0].data.len();
    Image {
        width: c[0].width,
        height: c[0].height,
        data: (0..n)
            // In f64, so that three equal values give that value exactly.
            .map(|i| {
                let s: f64 = c.iter().map(|im| f64::from(im.data[i])).sum();
                (s / 3.0) as f32
            })
            .collect(),
        std_err: (0..n)
            .map(|i| {
                let v: f32 = c.iter().map(|im| im.std_err[i].powi(2)).sum();
                v.sqrt() / 3.0
            })
            .collect(),
    }
}

fn sum_timings<'a>(t: impl Iterator<Item = &'a Timings>) -> Timings {
    let mut s = Timings::default();
    for x in t {
        s.density += x.density;
        s.sources += x.sources;
        s.solve += x.solve;
        s.sweeps += x.sweeps;
        s.light_depth += x.light_depth;
        s.render += x.render;
        s.total += x.total;
    }
    s
}
