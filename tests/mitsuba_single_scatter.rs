//! Our renderer and Mitsuba 3 agree on single scattering.
//!
//! Scene: the built-in "lowalbedo" (scenes/lowalbedo.toml: a 32³ procedural cloud, albedo
//! 0.15, HG g = 0.4, an off-axis directional light and a point light, a 64×48 camera off the
//! axes), chosen asymmetric so that a mirrored image, a flipped axis, a wrong light direction
//! or a wrong phase-function sign would show.
//!
//! * Ours: `Renderer` with no multiple-scattering solution (method "none"): single
//!   scattering only, per-pixel standard errors from the samples.
//! * Mitsuba: `volpath` with `max_depth = 2` (single scattering only), K independent renders
//!   with different seeds; its per-pixel variance is estimated from their spread.
//!
//! Both are unbiased estimators of the same integral (same piecewise-constant medium, same
//! camera rays over the pixel footprint), so the difference is pure noise. **Metrics and
//! thresholds:**
//!
//! 1. Noise ratio `R = Σ_i (o_i − m_i)² / Σ_i (se_o,i² + s_i²/K)`, with `m_i` the mean of the
//!    K Mitsuba renders and `s_i²` their sample variance: for unbiased estimators E[numerator]
//!    = E[denominator], and both sums run over ~3000 pixels, so R concentrates near 1 (its
//!    spread is ~√(2/N_eff) ≈ 5% with the heavy-tailed pixels included). We require
//!    `0.75 < R < 1.25`: a systematic error of 1/3 of the per-pixel noise level in every lit
//!    pixel (≈ 2–3 % of the radiance at these sample counts) already adds ≈ 11 % and a
//!    mirrored or shifted image adds several hundred percent; the lower bound catches a noise
//!    model that overestimates the error.
//! 2. Image mean: `z = (mean(o) − mean(m)) / √(se_o,mean² + se_m,mean²)` with the standard
//!    errors of the means from the same per-pixel variances (pixels are independent);
//!    require `|z| < 4` (a 4σ bound: false alarms at 6·10⁻⁵).
//! 3. The blob is in the same place: the intensity centroids agree within 0.25 pixel.
//!
//! The test skips with a message when no Python with Mitsuba is found, unless
//! `PN_REQUIRE_MITSUBA=1` (CI), where that is a failure.
#![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)] // test code

use pn_runtime::render::mitsuba::{self, ExportOptions, RunOptions};
use pn_runtime::render::renderer::Renderer;
use pn_runtime::render::scene::Albedo;
use pn_runtime::render::{compare, RenderScene};
use std::path::Path;

mod support;
use std::time::Instant;
use support::{mitsuba_python, work_dir};

/// Independent Mitsuba renders (seeds) per comparison.
const K: usize = 4;
/// Samples per pixel of each Mitsuba render.
const MITSUBA_SPP: usize = 256;
/// Samples per pixel of ours (half of Mitsuba's K·spp: our renderer is the slower one).
const OURS_SPP: usize = 512;

/// K Mitsuba renders of the exported scene in `dir`: per-pixel mean and variance of the mean.
fn mitsuba_mean(
    dir: &Path,
    python: &Path,
    spp: usize,
    max_depth: i64,
    seed0: u64,
) -> (compare::GrayImage, Vec<f64>, f64) {
    let mut runs = Vec::new();
    let mut seconds = 0.0;
    for k in 0..K {
        let out = dir.join(format!("mitsuba_d{max_depth}_{k}.exr"));
        let r = mitsuba::run_mitsuba_with(
            dir,
            python,
            &RunOptions {
                spp: Some(spp),
                seed: Some(seed0 + k as u64),
                max_depth: Some(max_depth),
                out: Some(out),
            },
        )
        .unwrap();
        seconds += r.seconds;
        runs.push(compare::read_gray(&r.image).unwrap());
    }
    let n = runs[0].data.len();
    let kf = K as f64;
    let mean: Vec<f64> = (0..n)
        .map(|i| runs.iter().map(|r| r.data[i]).sum::<f64>() / kf)
        .collect();
    // Sample variance across the K renders, divided by K: the variance of the mean.
    let var_mean: Vec<f64> = (0..n)
        .map(|i| {
            runs.iter()
                .map(|r| (r.data[i] - mean[i]).powi(2))
                .sum::<f64>()
                / (kf - 1.0)
                / kf
        })
        .collect();
    let img = compare::GrayImage {
        width: runs[0].width,
        height: runs[0].height,
        data: mean,
    };
    (img, var_mean, seconds)
}

fn centroid(img: &compare::GrayImage) -> (f64, f64) {
    let (mut s, mut sx, mut sy) = (0.0, 0.0, 0.0);
    for (i, v) in img.data.iter().enumerate() {
        s += v;
        sx += v * ((i % img.width) as f64 + 0.5);
        sy += v * ((i / img.width) as f64 + 0.5);
    }
    (sx / s, sy / s)
}

#[test]
fn single_scattering_agrees_with_mitsuba_volpath_max_depth_2() {
    let Some(python) = mitsuba_python() else {
        return;
    };
    let scene = RenderScene::builtin("lowalbedo").unwrap();
    let grid = scene.density_grid().unwrap();

    let t = Instant::now();
    let ours = Renderer {
        scene: &scene,
        density: &grid,
        ms: None,
    }
    .render(OURS_SPP, 12345, false);
    let ours_seconds = t.elapsed().as_secs_f64();
    let o = compare::GrayImage {
        width: ours.width,
        height: ours.height,
        data: ours.data.iter().map(|v| *v as f64).collect(),
    };
    let var_o: Vec<f64> = ours.std_err.iter().map(|s| (*s as f64).powi(2)).collect();

    let dir = work_dir("mitsuba_single_scatter");
    let opts = ExportOptions {
        spp: MITSUBA_SPP,
        seed: 1,
        max_depth: 2,
    };
    mitsuba::export(&scene, &dir, &opts).unwrap();
    let (m, var_m, mitsuba_seconds) = mitsuba_mean(&dir, &python, MITSUBA_SPP, 2, 1);

    let metrics = compare::metrics(&o, &m).unwrap();
    compare::write_difference_png(&dir.join("difference.png"), &o, &m, "ours − Mitsuba").unwrap();
    let num: f64 = o
        .data
        .iter()
        .zip(&m.data)
        .map(|(a, b)| (a - b).powi(2))
        .sum();
    let den: f64 = var_o.iter().zip(&var_m).map(|(a, b)| a + b).sum();
    let ratio = num / den;
    let n = o.data.len() as f64;
    let se_mean = (den).sqrt() / n;
    let z = (metrics.mean_a - metrics.mean_b) / se_mean;
    let (co, cm) = (centroid(&o), centroid(&m));
    eprintln!(
        "ours {OURS_SPP} spp in {ours_seconds:.2} s; Mitsuba {K}×{MITSUBA_SPP} spp in \
         {mitsuba_seconds:.2} s (render only)\n{metrics}\nnoise ratio R = {ratio:.4} \
         (noise RMS {:.3e}); mean z = {z:.3}; centroid ours {co:.3?} Mitsuba {cm:.3?}",
        (den / n).sqrt()
    );
    assert!(
        ratio > 0.75 && ratio < 1.25,
        "squared difference is {ratio:.3}× the Monte Carlo noise"
    );
    assert!(
        z.abs() < 4.0,
        "image means differ by {z:.2} standard errors"
    );
    assert!(
        (co.0 - cm.0).abs() < 0.25 && (co.1 - cm.1).abs() < 0.25,
        "centroids differ: ours {co:?}, Mitsuba {cm:?}"
    );
}

/// `max_depth = 2` is exactly single scattering: the image is linear in the albedo (same
/// seed, same random numbers: the ratio is 2 to float rounding), while full transport
/// (`max_depth = -1`) is brighter by the multiple scattering, which is small at albedo 0.15.
#[test]
fn mitsuba_max_depth_2_is_single_scattering_only() {
    let Some(python) = mitsuba_python() else {
        return;
    };
    let scene = RenderScene::builtin("lowalbedo").unwrap();
    let spp = 64;
    let opts = ExportOptions {
        spp,
        seed: 3,
        max_depth: 2,
    };
    let dir = work_dir("mitsuba_depth2");
    mitsuba::export(&scene, &dir, &opts).unwrap();
    let single = compare::read_gray(&mitsuba::run_mitsuba(&dir, &python).unwrap()).unwrap();

    let mut doubled = scene.clone();
    let Albedo::Constant(a) = scene.medium.albedo else {
        panic!("lowalbedo has a constant albedo");
    };
    doubled.medium.albedo = Albedo::Constant(2.0 * a);
    let dir2 = work_dir("mitsuba_depth2_doubled");
    mitsuba::export(&doubled, &dir2, &opts).unwrap();
    let single2 = compare::read_gray(&mitsuba::run_mitsuba(&dir2, &python).unwrap()).unwrap();
    let max = single.data.iter().fold(0.0f64, |m, v| m.max(*v));
    assert!(max > 0.0);
    for (x, y) in single.data.iter().zip(&single2.data) {
        // f32 images: relative rounding ~1e-7 per operation.
        assert!((y - 2.0 * x).abs() <= 1e-5 * max, "{y} != 2·{x}");
    }

    // Full transport: K renders each, compare image means.
    let (full, var_full, _) = mitsuba_mean(&dir, &python, spp, -1, 100);
    let (ss, var_ss, _) = mitsuba_mean(&dir, &python, spp, 2, 200);
    let n = full.data.len() as f64;
    let mean = |v: &[f64]| v.iter().sum::<f64>() / n;
    let diff = mean(&full.data) - mean(&ss.data);
    let se = (var_full.iter().chain(&var_ss).sum::<f64>()).sqrt() / n;
    let fraction = diff / mean(&ss.data);
    eprintln!(
        "multiple scattering adds {:.2}% ({:.1} standard errors) at albedo {a}",
        100.0 * fraction,
        diff / se
    );
    // Higher orders are present in full transport (≥ 5σ) and small at this albedo (the
    // second order scales like albedo·(optical size) ≈ 0.15·O(1)).
    assert!(
        diff > 5.0 * se,
        "full transport is not brighter: {diff} ± {se}"
    );
    assert!(
        fraction < 0.2,
        "multiple scattering is {fraction} of single"
    );
}
