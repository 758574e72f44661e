//! Sky lights against Mitsuba 3 (issue 50): single scattering of a medium lit by an
//! environment map with one bright patch, ours (deterministic: the sky cut into directional
//! lights, docs/sky.md) against `volpath` with `max_depth = 2` and the same `envmap`.
//!
//! The map is asymmetric on purpose: a bright patch on the +X side, above the horizon, over
//! a dim sky, so a flipped u (the patch on −X) or v (below the horizon) lights the sphere
//! from elsewhere. The test checks it can tell: our render with the map mirrored must fail
//! the same comparison by a wide margin.
//!
//! **Metrics and thresholds** (the reference is K Mitsuba renders with different seeds; its
//! per-pixel variance of the mean `s²_i/K` from their spread; ours has no noise):
//!
//! 1. Bias of the image mean: |mean(o)/mean(m) − 1| ≤ 1 % + 3 σ, σ the reference mean's
//!    relative standard error (issue 50 asks for |bias| ≤ 1 %; the 3 σ keep a noisy
//!    reference from failing a correct render). The sky is cut into 64 lights: the cut's
//!    quadrature and the sky lights' coarse optical-depth planes cost −0.3 to −0.5 % on the
//!    scenes measured in docs/sky.md.
//! 2. Error within the reference's own noise: `R = Σ (o_i − m_i)² / Σ s²_i/K` ≤ 1.5. With a
//!    noise-free render, E[R] = 1 + (our squared error)/(reference noise); 1.5 allows our
//!    own per-pixel error up to 70 % of the reference's noise.
//! 3. The mirrored map (u flipped) gives R > 4 and moves the intensity centroid by more than
//!    a pixel: the comparison can fail.
//!
//! Skips with a message when no Python with Mitsuba is found, unless `PN_REQUIRE_MITSUBA=1`.
#![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)] // test code

use pn_drivers::mitsuba::{self, RunOptions};
use pn_render::mitsuba::ExportOptions;
use pn_render::{compare, render_scene, RenderOptions, RenderScene};
use std::path::Path;

mod support;
use support::{mitsuba_python, work_dir};

/// Independent Mitsuba renders (seeds).
const K: usize = 4;
/// Samples per pixel of each.
const SPP: usize = 256;
const W: usize = 64;
const H: usize = 32;

/// The map: a dim sky (0.2) with a bright patch (8.0) on the +X side above the horizon;
/// `mirror` flips u (the patch on the −X side).
fn write_map(path: &Path, mirror: bool) {
    let mut v = vec![0.2f32; W * H];
    for j in 0..H {
        for i in 0..W {
            let u = (i as f64 + 0.5) / W as f64;
            let u = if mirror { 1.0 - u } else { u };
            let t = j as f64 / (H - 1) as f64;
            // φ = 2πu ∈ (54°, 108°): direction ≈ +X; θ ∈ (45°, 81°): above the horizon.
            if (0.15..0.30).contains(&u) && (0.25..0.45).contains(&t) {
                v[j * W + i] = 8.0;
            }
        }
    }
    pn_formats::write_exr_rgb(path, W, H, [&v, &v, &v]).unwrap();
}

fn scene(dir: &Path, map: &str) -> RenderScene {
    let text = format!(
        r#"
[medium]
kind = "sphere"
resolution = [32, 32, 32]
sigma_t_scale = 4.0
albedo = 0.6
[phase]
kind = "hg"
g = 0.4
[[light]]
kind = "envmap"
file = "{map}"
directions = 64
[camera]
position = [0.3, 0.4, 3.5]
target = [0.0, 0.0, 0.0]
up = [0.0, 1.0, 0.0]
fov = 40.0
width = 48
height = 48
[solve]
method = "none"
[render]
hide_emitters = true
"#
    );
    RenderScene::from_toml_str(&text, dir).unwrap()
}

fn ours(scene: &RenderScene) -> compare::GrayImage {
    let opts = RenderOptions {
        progress: false,
        ..RenderOptions::default()
    };
    let run = render_scene(scene, &opts).unwrap();
    compare::GrayImage {
        width: run.image.width,
        height: run.image.height,
        data: run.image.data.iter().map(|v| *v as f64).collect(),
    }
}

fn centroid_x(img: &compare::GrayImage) -> f64 {
    let (mut s, mut sx) = (0.0, 0.0);
    for (i, v) in img.data.iter().enumerate() {
        s += v;
        sx += v * ((i % img.width) as f64 + 0.5);
    }
    sx / s
}

#[test]
fn sky_single_scattering_agrees_with_mitsuba_and_a_mirrored_map_does_not() {
    let Some(python) = mitsuba_python() else {
        return;
    };
    let dir = work_dir("mitsuba_sky");
    std::fs::create_dir_all(&dir).unwrap();
    write_map(&dir.join("patch.exr"), false);
    write_map(&dir.join("mirrored.exr"), true);
    let s = scene(&dir, "patch.exr");
    let o = ours(&s);
    let mirrored = ours(&scene(&dir, "mirrored.exr"));

    let export = dir.join("export");
    let opts = ExportOptions {
        spp: SPP,
        seed: 1,
        max_depth: 2,
    };
    mitsuba::export(&s, &export, &opts).unwrap();
    let mut runs = Vec::new();
    for k in 0..K {
        let r = mitsuba::run_mitsuba_with(
            &export,
            &python,
            &RunOptions {
                spp: Some(SPP),
                seed: Some(1 + k as u64),
                max_depth: Some(2),
                out: Some(export.join(format!("mitsuba_{k}.exr"))),
            },
        )
        .unwrap();
        runs.push(compare::read_gray(&r.image).unwrap());
    }
    let n = runs[0].data.len();
    let kf = K as f64;
    let m: Vec<f64> = (0..n)
        .map(|i| runs.iter().map(|r| r.data[i]).sum::<f64>() / kf)
        .collect();
    let var_mean: Vec<f64> = (0..n)
        .map(|i| runs.iter().map(|r| (r.data[i] - m[i]).powi(2)).sum::<f64>() / (kf - 1.0) / kf)
        .collect();
    let reference = compare::GrayImage {
        width: runs[0].width,
        height: runs[0].height,
        data: m,
    };
    let noise: f64 = var_mean.iter().sum();
    let ratio = |img: &compare::GrayImage| {
        img.data
            .iter()
            .zip(&reference.data)
            .map(|(a, b)| (a - b).powi(2))
            .sum::<f64>()
            / noise
    };
    let mean = |img: &compare::GrayImage| img.data.iter().sum::<f64>() / n as f64;
    let bias = mean(&o) / mean(&reference) - 1.0;
    let se_rel = noise.sqrt() / n as f64 / mean(&reference);
    let (r, r_mirrored) = (ratio(&o), ratio(&mirrored));
    let (cx, cx_ref, cx_mirrored) = (
        centroid_x(&o),
        centroid_x(&reference),
        centroid_x(&mirrored),
    );
    eprintln!(
        "sky single scattering: bias {:+.2} % (reference ±{:.2} %), R = {r:.3}, mirrored R = \
         {r_mirrored:.1}; centroid x {cx:.2} / Mitsuba {cx_ref:.2} / mirrored {cx_mirrored:.2}",
        100.0 * bias,
        100.0 * se_rel
    );
    assert!(
        bias.abs() <= 0.01 + 3.0 * se_rel,
        "bias {:+.2} %",
        100.0 * bias
    );
    assert!(r <= 1.5, "R = {r}: our error exceeds the reference's noise");
    assert!(
        r_mirrored > 4.0,
        "the mirrored map is not told apart: R = {r_mirrored}"
    );
    assert!((cx - cx_ref).abs() < 0.25, "centroid {cx} against {cx_ref}");
    assert!(
        (cx_mirrored - cx_ref).abs() > 1.0,
        "mirrored centroid {cx_mirrored}"
    );
}
