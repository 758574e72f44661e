//! A coloured medium against Mitsuba 3, per channel (issue 22).
//!
//! Scene: scenes/rgbcloud.toml (σ_t scale, albedo and the light's irradiance all differ per
//! channel), the camera reduced to 48×48. `pn export-mitsuba` writes it for Mitsuba's
//! `scalar_rgb` variant: σ_t as an RGB `gridvolume` (density × s_c / s_max, `scale` s_max),
//! the albedo and the irradiance as `rgb` values. Both sides render single scattering only
//! (ours: the Monte Carlo renderer without a solution on each channel's grey scene; Mitsuba:
//! `volpath` with `max_depth = 2`, K seeds), so both are unbiased estimates of the same
//! integral and the difference is noise. Per channel, as in tests/mitsuba_single_scatter.rs:
//! the noise ratio R = Σ(o − m)² / Σ(se_o² + s_m²/K) must lie in (0.75, 1.25) and the image
//! means must agree within 4 standard errors. A channel swapped, an RGB volume read as grey,
//! or a light colour lost moves a channel's mean by far more than that (the channels' means
//! differ by factors of 1.3 to 2).
//!
//! Skips with a message when no Mitsuba is found, unless `PN_REQUIRE_MITSUBA=1` (CI).
#![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)] // test code

use pn_drivers::mitsuba::{self, RunOptions};
use pn_formats::read_exr_rgb;
use pn_render::mitsuba::ExportOptions;
use pn_render::Renderer;
use pn_render::CHANNELS;
use pn_render::{RenderScene, SceneOverride};
use std::path::Path;

mod support;
use support::{mitsuba_python, work_dir};

const K: usize = 4;
const MITSUBA_SPP: usize = 128;
const OURS_SPP: usize = 256;

#[test]
fn single_scattering_of_a_coloured_cloud_agrees_with_mitsuba_per_channel() {
    let Some(python) = mitsuba_python() else {
        return;
    };
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/rgbcloud.toml");
    let small: Vec<SceneOverride> = ["camera.width=48", "camera.height=48"]
        .iter()
        .map(|s| s.parse().unwrap())
        .collect();
    let scene = RenderScene::from_path_with_overrides(&path, &small).unwrap();
    assert!(scene.colours.is_some());

    let dir = work_dir("mitsuba_rgb");
    let opts = ExportOptions {
        spp: MITSUBA_SPP,
        seed: 1,
        max_depth: 2,
    };
    mitsuba::export(&scene, &dir, &opts).unwrap();
    // K Mitsuba renders: per channel, per pixel, the mean and the variance of the mean.
    let mut runs: Vec<[Vec<f32>; 3]> = Vec::new();
    for k in 0..K {
        let r = mitsuba::run_mitsuba_with(
            &dir,
            &python,
            &RunOptions {
                spp: Some(MITSUBA_SPP),
                seed: Some(1 + k as u64),
                max_depth: Some(2),
                out: Some(dir.join(format!("mitsuba_{k}.exr"))),
            },
        )
        .unwrap();
        runs.push(read_exr_rgb(&r.image).unwrap().2);
    }
    let kf = K as f64;
    let mut means = Vec::new();
    for c in 0..3 {
        let channel = scene.channel(c);
        let grid = channel.density_grid().unwrap();
        let ours = Renderer {
            scene: &channel,
            density: &grid,
            ms: None,
            light_leg: None,
        }
        .render(OURS_SPP, 777 + c as u64, None);
        let n = ours.data.len();
        let m: Vec<f64> = (0..n)
            .map(|i| runs.iter().map(|r| r[c][i] as f64).sum::<f64>() / kf)
            .collect();
        let var_m: Vec<f64> = (0..n)
            .map(|i| {
                runs.iter()
                    .map(|r| (r[c][i] as f64 - m[i]).powi(2))
                    .sum::<f64>()
                    / (kf - 1.0)
                    / kf
            })
            .collect();
        let num: f64 = (0..n).map(|i| (ours.data[i] as f64 - m[i]).powi(2)).sum();
        let den: f64 = (0..n)
            .map(|i| (ours.std_err[i] as f64).powi(2) + var_m[i])
            .sum();
        let ratio = num / den;
        let mean_o = ours.data.iter().map(|v| *v as f64).sum::<f64>() / n as f64;
        let mean_m = m.iter().sum::<f64>() / n as f64;
        let z = (mean_o - mean_m) / (den.sqrt() / n as f64);
        eprintln!(
            "channel {}: mean ours {mean_o:.4e}, Mitsuba {mean_m:.4e} ({:+.2} %), z = {z:.2}, \
             noise ratio R = {ratio:.3}",
            CHANNELS[c],
            100.0 * (mean_o / mean_m - 1.0)
        );
        assert!(
            ratio > 0.75 && ratio < 1.25,
            "channel {}: squared difference is {ratio:.3}× the noise",
            CHANNELS[c]
        );
        assert!(
            z.abs() < 4.0,
            "channel {}: means differ by {z:.2} σ",
            CHANNELS[c]
        );
        means.push(mean_m);
    }
    // The channels are really different (the test would not see a swap otherwise).
    assert!(
        means[0] > 1.25 * means[1] && means[1] > 1.25 * means[2],
        "{means:?}"
    );
}
