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
//! Both are unbiased estimators of the same integral (same medium read with the same density
//! filter, same camera rays over the pixel footprint), so the difference is pure noise. The
//! comparison runs for the default trilinear filter and for nearest. **Metrics and
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
//! The same comparison runs on `scenes/vdbcloud.toml`, a cloud read from an OpenVDB file.
//!
//! `mitsuba_reads_voxels_as_documented` checks the filter convention itself (values at the
//! voxel centres, the edge value clamped in the outer half voxel) against an independent
//! deterministic integral on a 4-voxel grid.
//!
//! The tests skip with a message when no Python with Mitsuba is found, unless
//! `PN_REQUIRE_MITSUBA=1` (CI), where that is a failure.
#![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)] // test code

use pn_drivers::mitsuba::{self, RunOptions};
use pn_render::mitsuba::ExportOptions;
use pn_render::scene::Albedo;
use pn_render::Renderer;
use pn_render::{compare, DensityFilter, RenderScene, SceneOverride};
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

/// The default: trilinear density, as Mitsuba's default `gridvolume`.
#[test]
fn single_scattering_agrees_with_mitsuba_volpath_max_depth_2() {
    let scene = RenderScene::builtin("lowalbedo").unwrap();
    single_scattering_agrees(scene, DensityFilter::Trilinear, "lowalbedo");
}

/// The piecewise-constant alternative (`filter = "nearest"` on both sides).
#[test]
fn single_scattering_agrees_with_mitsuba_nearest() {
    let scene = RenderScene::builtin("lowalbedo").unwrap();
    single_scattering_agrees(scene, DensityFilter::Nearest, "lowalbedo");
}

/// A medium read from an OpenVDB file (scenes/vdbcloud.toml: OpenVDB's own file, its
/// transform and sparse active voxels) against Mitsuba loading the same voxels through the
/// exported `.vol`: a misplaced, mirrored or mis-scaled grid would move or reshape the cloud
/// (centroid, noise ratio), a lost tile or voxel would darken it (mean). The camera is
/// reduced to 64×64 to keep the test short; the other settings are the scene's.
#[test]
fn single_scattering_of_a_vdb_cloud_agrees_with_mitsuba() {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/vdbcloud.toml");
    let small: Vec<SceneOverride> = ["camera.width=64", "camera.height=64"]
        .iter()
        .map(|s| s.parse().unwrap())
        .collect();
    let scene = RenderScene::from_path_with_overrides(&path, &small).unwrap();
    single_scattering_agrees(scene, DensityFilter::Trilinear, "vdbcloud");
}

fn single_scattering_agrees(mut scene: RenderScene, filter: DensityFilter, label: &str) {
    let Some(python) = mitsuba_python() else {
        return;
    };
    scene.medium.filter = filter;
    let grid = scene.density_grid().unwrap();
    assert_eq!(grid.filter, filter);

    let t = Instant::now();
    let ours = Renderer {
        scene: &scene,
        density: &grid,
        ms: None,
        light_leg: None,
    }
    .render(OURS_SPP, 12345, None);
    let ours_seconds = t.elapsed().as_secs_f64();
    let o = compare::GrayImage {
        width: ours.width,
        height: ours.height,
        data: ours.data.iter().map(|v| *v as f64).collect(),
    };
    let var_o: Vec<f64> = ours.std_err.iter().map(|s| (*s as f64).powi(2)).collect();

    let dir = work_dir(&format!("mitsuba_single_scatter_{label}_{}", filter.name()));
    let opts = ExportOptions {
        spp: MITSUBA_SPP,
        seed: 1,
        max_depth: 2,
    };
    mitsuba::export(&scene, &dir, &opts).unwrap();
    let (m, var_m, mitsuba_seconds) = mitsuba_mean(&dir, &python, MITSUBA_SPP, 2, 1);

    let metrics = compare::metrics(&o, &m).unwrap();
    pn_drivers::compare::write_difference_png(
        &dir.join("difference.png"),
        &o,
        &m,
        "ours − Mitsuba",
    )
    .unwrap();
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
        "{label}, filter {filter}: ours {OURS_SPP} spp in {ours_seconds:.2} s; Mitsuba {K}×{MITSUBA_SPP} spp in \
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

/// One convention of reading a 4×1×1 grid along x (box [−1, 1]³, voxel centres at
/// x = −0.75, −0.25, 0.25, 0.75), written here independently of `pn_runtime`'s lookup.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Convention {
    /// Mitsuba's documented default as we read it: linear between centres, the edge value
    /// (clamped) in the outer half voxels.
    TrilinearClamped,
    /// Linear between centres, falling linearly to 0 at the box faces (zero padding).
    TrilinearZeroBorder,
    /// Piecewise constant per voxel.
    Nearest,
}

fn density_1d(v: &[f64; 4], x: f64, c: Convention) -> f64 {
    if !(-1.0..=1.0).contains(&x) {
        return 0.0;
    }
    let u = (x + 1.0) / 0.5; // voxel units, 0..4
    match c {
        Convention::Nearest => v[(u as usize).min(3)],
        Convention::TrilinearClamped | Convention::TrilinearZeroBorder => {
            let s = u - 0.5;
            let i0 = s.floor();
            let f = s - i0;
            let get = |i: f64| {
                if (0.0..=3.0).contains(&i) {
                    v[i as usize]
                } else if c == Convention::TrilinearClamped {
                    v[i.clamp(0.0, 3.0) as usize]
                } else {
                    0.0
                }
            };
            (1.0 - f) * get(i0) + f * get(i0 + 1.0)
        }
    }
}

/// Single scattering of the 4-voxel scene for one camera ray, by a fine midpoint rule on the
/// part of the ray inside the box: the light travels along −y and the density does not
/// depend on y or z, so the transmittance to the light is exp(−σ_t(x)·(1 − y)) exactly.
fn ray_single_scatter(
    v: &[f64; 4],
    c: Convention,
    (scale, albedo, e): (f64, f64, f64),
    o: [f64; 3],
    d: [f64; 3],
) -> f64 {
    let (mut t0, mut t1) = (0.0f64, f64::INFINITY);
    for a in 0..3 {
        if d[a] == 0.0 {
            if o[a].abs() > 1.0 {
                return 0.0;
            }
            continue;
        }
        let (mut p, mut q) = ((-1.0 - o[a]) / d[a], (1.0 - o[a]) / d[a]);
        if p > q {
            std::mem::swap(&mut p, &mut q);
        }
        t0 = t0.max(p);
        t1 = t1.min(q);
    }
    if t0 >= t1 {
        return 0.0;
    }
    let steps = 1500;
    let dt = (t1 - t0) / steps as f64;
    let (mut tau, mut sum) = (0.0, 0.0);
    for s in 0..steps {
        let t = t0 + (s as f64 + 0.5) * dt;
        let x = [0, 1, 2].map(|a| o[a] + t * d[a]);
        let st = scale * density_1d(v, x[0], c);
        // Transmittance to the midpoint: half of this step's optical depth.
        let t_cam = (-(tau + 0.5 * st * dt)).exp();
        let t_light = (-st * (1.0 - x[1])).exp();
        sum += t_cam * albedo * st * t_light * e / (4.0 * std::f64::consts::PI) * dt;
        tau += st * dt;
    }
    sum
}

/// Mitsuba 3's `gridvolume` convention, measured: a 4×1×1 grid with very different values
/// (dense edge voxels, so the outer half voxels matter), lit from +y, single scattering
/// (`max_depth = 2`), against the image mean of an independent deterministic integral of
/// each candidate convention (8×8 rays per pixel, 1500 steps per ray). Mitsuba must match
/// "trilinear, clamped in the outer half voxel" with `filter_type = "trilinear"` and
/// "piecewise constant" with "nearest", each within 4 standard errors of its own noise
/// (K = 4 seeds × 1024 spp) plus the deterministic integral's error (bounded by its change
/// from 4×4 to 8×8 rays per pixel); the other conventions must lie far outside.
#[test]
fn mitsuba_reads_voxels_as_documented() {
    let Some(python) = mitsuba_python() else {
        return;
    };
    let v = [2.0, 0.2, 1.0, 3.0];
    let (scale, albedo, e) = (1.5, 0.6, 2.0);
    let dir = work_dir("mitsuba_filter_convention");
    std::fs::create_dir_all(&dir).unwrap();
    let grid = pn_render::DensityGrid::new(
        [4, 1, 1],
        [-1.0; 3],
        [1.0; 3],
        v.iter().map(|x| *x as f32).collect(),
    )
    .unwrap();
    std::fs::write(
        dir.join("four.vol"),
        pn_formats::encode_vol(&grid.to_voxel_grid()),
    )
    .unwrap();
    // pn's lookup is the convention verified below, for both filters.
    for q in 0..=200 {
        let x = -1.0 + q as f64 / 100.0;
        for (f, c) in [
            (DensityFilter::Trilinear, Convention::TrilinearClamped),
            (DensityFilter::Nearest, Convention::Nearest),
        ] {
            let g = grid.clone().with_filter(f);
            let (a, b) = (g.density_at([x, 0.3, -0.6]), density_1d(&v, x, c));
            // x = 1 (the max face) belongs to no voxel for nearest (half-open cells).
            if !(f == DensityFilter::Nearest && q == 200) {
                // The grid stores f32 (0.2 is off by 3e-9).
                assert!((a - b).abs() < 1e-7, "{f} at x = {x}: {a} vs {b}");
            }
        }
    }
    let toml = format!(
        r#"
[medium]
kind = "grid"
file = "four.vol"
bbox_min = [-1.0, -1.0, -1.0]
bbox_max = [1.0, 1.0, 1.0]
sigma_t_scale = {scale:?}
albedo = {albedo:?}
[[light]]
kind = "directional"
direction = [0.0, -1.0, 0.0]
irradiance = {e:?}
[camera]
position = [0.4, 0.7, 5.0]
target = [0.0, 0.0, 0.0]
up = [0.0, 1.0, 0.0]
fov = 30.0
width = 24
height = 24
"#
    );
    let base = RenderScene::from_toml_str(&toml, &dir).unwrap();
    let cam = base.camera.clone();
    let frame = cam.frame();
    let image_mean = |c: Convention, sub: usize| -> f64 {
        let mut s = 0.0;
        for py in 0..cam.height {
            for px in 0..cam.width {
                for q in 0..sub * sub {
                    let (sx, sy) = (
                        ((q % sub) as f64 + 0.5) / sub as f64,
                        ((q / sub) as f64 + 0.5) / sub as f64,
                    );
                    let d = cam.ray_dir(&frame, px as f64 + sx, py as f64 + sy);
                    s += ray_single_scatter(&v, c, (scale, albedo, e), cam.position, d);
                }
            }
        }
        s / (cam.width * cam.height * sub * sub) as f64
    };
    let conventions = [
        Convention::TrilinearClamped,
        Convention::TrilinearZeroBorder,
        Convention::Nearest,
    ];
    let ours: Vec<(f64, f64)> = conventions
        .iter()
        .map(|c| {
            let fine = image_mean(*c, 8);
            (fine, (fine - image_mean(*c, 4)).abs())
        })
        .collect();
    for (filter, want) in [(DensityFilter::Trilinear, 0), (DensityFilter::Nearest, 2)] {
        let mut scene = base.clone();
        scene.medium.filter = filter;
        let sub = dir.join(filter.name());
        let opts = ExportOptions {
            spp: 1024,
            seed: 1,
            max_depth: 2,
        };
        mitsuba::export(&scene, &sub, &opts).unwrap();
        let (m, var_m, _) = mitsuba_mean(&sub, &python, 1024, 2, 11);
        let n = m.data.len() as f64;
        let mean = m.data.iter().sum::<f64>() / n;
        let se = var_m.iter().sum::<f64>().sqrt() / n;
        for (k, c) in conventions.iter().enumerate() {
            let (o, qerr) = ours[k];
            let z = (mean - o) / se;
            eprintln!(
                "Mitsuba {} mean {mean:.6e} ± {se:.1e}; integral {c:?} {o:.6e} \
                 (quadrature ±{qerr:.1e}): rel {:+.3}%, z = {z:.1}",
                filter.name(),
                100.0 * (mean - o) / o
            );
            if k == want {
                assert!(
                    (mean - o).abs() < 4.0 * se + qerr,
                    "Mitsuba {} does not follow {c:?}: z = {z:.2}",
                    filter.name()
                );
            } else {
                assert!(
                    (mean - o).abs() > 10.0 * se + qerr,
                    "{c:?} is not distinguished from {want}: z = {z:.2}"
                );
            }
        }
    }
}
