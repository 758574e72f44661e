//! The renderer's single scattering against an independent 1D quadrature of the
//! single-scattering integral along one ray, for a homogeneous box with a
//! directional and a point light: camera outside, camera inside the medium, point light
//! inside the medium. Plus: a vacuum scene renders exactly 0.
//!
//! Reference: `L = ∫ exp(−σ_t s(t)) σ_s Σ_lights p(d·ω_o) exp(−σ_t ℓ_light(x)) E(x) dt`, with
//! the in-medium path lengths s and ℓ computed from the box's slab intersections (not from
//! the renderer's voxel traversal) and composite Gauss–Legendre (64 panels × 16 nodes; the
//! integrand is smooth on each panel, so the quadrature error is far below the Monte Carlo
//! error). The estimate must lie within 3 standard errors of the reference (a two-sided
//! test with false-failure probability ≈ 0.3 % for a normal mean; the seeds are fixed, so
//! the outcome is deterministic).
#![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)] // test code

use pn_render::phase_value;
use pn_render::{Light, RenderScene};
use pn_render::{Renderer, Rng};
use pn_stencil::quadrature::gauss_legendre;
use std::path::Path;

const SIGMA_T: f64 = 2.0;
const ALBEDO: f64 = 0.2;

/// Homogeneous box [−0.5, 0.5]³ (the central 2×2×2 voxels of the 4³ "box" medium on
/// [−1, 1]³, read with the nearest filter), σ_t = 2, albedo 0.2, HG g = 0.3.
fn scene(point_light: [f64; 3], camera: [f64; 3], target: [f64; 3]) -> RenderScene {
    let text = format!(
        r#"
[medium]
kind = "box"
resolution = [4, 4, 4]
sigma_t_scale = {SIGMA_T}
albedo = {ALBEDO}
filter = "nearest"
[phase]
kind = "hg"
g = 0.3
[[light]]
kind = "directional"
direction = [0.3, -1.0, 0.2]
irradiance = 1.5
[[light]]
kind = "point"
position = {point_light:?}
power = 3.0
[camera]
position = {camera:?}
target = {target:?}
up = [0.0, 1.0, 0.0]
fov = 30.0
width = 8
height = 8
[solve]
method = "none"
"#
    );
    RenderScene::from_toml_str(&text, Path::new(".")).unwrap()
}

/// Length of the segment `o + t·d`, t ∈ [0, tmax], inside [−0.5, 0.5]³ (slab method).
fn inside_length(o: [f64; 3], d: [f64; 3], tmax: f64) -> f64 {
    let (mut t0, mut t1) = (0.0f64, tmax);
    for a in 0..3 {
        if d[a] == 0.0 {
            if o[a].abs() > 0.5 {
                return 0.0;
            }
            continue;
        }
        let (mut lo, mut hi) = ((-0.5 - o[a]) / d[a], (0.5 - o[a]) / d[a]);
        if lo > hi {
            std::mem::swap(&mut lo, &mut hi);
        }
        t0 = t0.max(lo);
        t1 = t1.min(hi);
    }
    (t1 - t0).max(0.0)
}

fn reference(scene: &RenderScene, o: [f64; 3], dir: [f64; 3]) -> f64 {
    // Parameter range of the ray inside the box.
    let (mut t0, mut t1) = (0.0f64, f64::INFINITY);
    for a in 0..3 {
        let (mut lo, mut hi) = ((-0.5 - o[a]) / dir[a], (0.5 - o[a]) / dir[a]);
        if lo > hi {
            std::mem::swap(&mut lo, &mut hi);
        }
        t0 = t0.max(lo);
        t1 = t1.min(hi);
    }
    assert!(t1 > t0, "the test ray must hit the box");
    let wo = dir.map(|c| -c);
    let (x, w) = gauss_legendre(16);
    let panels = 64;
    let mut sum = 0.0;
    for p in 0..panels {
        let a = t0 + (t1 - t0) * p as f64 / panels as f64;
        let b = t0 + (t1 - t0) * (p + 1) as f64 / panels as f64;
        for (xi, wi) in x.iter().zip(&w) {
            let t = 0.5 * (a + b) + 0.5 * (b - a) * xi;
            let pos = [0, 1, 2].map(|k| o[k] + t * dir[k]);
            let mut s = 0.0;
            for light in &scene.lights {
                let (travel, e, dist) = match light {
                    Light::Directional {
                        direction,
                        irradiance,
                    } => (*direction, *irradiance, f64::INFINITY),
                    Light::Point { position, power } => {
                        let v = [0, 1, 2].map(|k| pos[k] - position[k]);
                        let r = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
                        (
                            v.map(|c| c / r),
                            power / (4.0 * std::f64::consts::PI * r * r),
                            r,
                        )
                    }
                };
                let back = travel.map(|c| -c);
                let ell = inside_length(pos, back, dist);
                let cos = travel[0] * wo[0] + travel[1] * wo[1] + travel[2] * wo[2];
                s += phase_value(&scene.phase, cos) * (-SIGMA_T * ell).exp() * e;
            }
            let s_cam = inside_length(o, dir, t);
            sum += 0.5 * (b - a) * wi * (-SIGMA_T * s_cam).exp() * SIGMA_T * ALBEDO * s;
        }
    }
    sum
}

fn estimate(scene: &RenderScene, o: [f64; 3], dir: [f64; 3], n: usize) -> (f64, f64) {
    let density = scene.density_grid().unwrap();
    let r = Renderer {
        scene,
        density: &density,
        ms: None,
        light_leg: None,
    };
    let mut rng = Rng::new(12345, 0);
    let (mut s, mut s2) = (0.0, 0.0);
    for _ in 0..n {
        let v = r.sample(o, dir, &mut rng);
        s += v;
        s2 += v * v;
    }
    let m = s / n as f64;
    let var = (s2 / n as f64 - m * m) * n as f64 / (n - 1) as f64;
    (m, (var / n as f64).sqrt())
}

fn unit(v: [f64; 3]) -> [f64; 3] {
    let n = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
    v.map(|c| c / n)
}

fn check(scene: &RenderScene, o: [f64; 3], dir: [f64; 3]) {
    let dir = unit(dir);
    let want = reference(scene, o, dir);
    let (got, se) = estimate(scene, o, dir, 200_000);
    assert!(want > 0.0 && se > 0.0);
    assert!(
        (got - want).abs() < 3.0 * se,
        "estimate {got:.6e} ± {se:.2e} vs quadrature {want:.6e} ({:.2} σ)",
        (got - want) / se
    );
    // The test has power: the standard error is small against the value.
    assert!(
        se < 0.01 * want,
        "standard error {se:.2e} too large for {want:.3e}"
    );
}

#[test]
fn camera_outside_matches_quadrature() {
    let s = scene([1.5, 1.0, 0.8], [0.3, 0.2, 3.0], [0.0; 3]);
    check(&s, [0.3, 0.2, 3.0], [-0.25, -0.1, -1.0]);
}

#[test]
fn camera_inside_the_medium_matches_quadrature() {
    let s = scene([1.5, 1.0, 0.8], [0.1, -0.2, 0.0], [1.0, 0.0, 0.3]);
    check(&s, [0.1, -0.2, 0.0], [1.0, 0.2, 0.3]);
    // The whole image renders (finite, positive where the medium is seen).
    let density = s.density_grid().unwrap();
    let img = Renderer {
        scene: &s,
        density: &density,
        ms: None,
        light_leg: None,
    }
    .render(64, 1, None);
    // 64 samples per pixel: the chance that all escape (P ≈ e^{−1.8} each) is ~1e-49.
    assert!(img.data.iter().all(|v| v.is_finite() && *v > 0.0));
}

#[test]
fn point_light_inside_the_medium_matches_quadrature() {
    let s = scene([0.2, 0.1, -0.1], [0.0, 0.0, 3.0], [0.0; 3]);
    // The ray passes 0.2–0.3 from the light: E stays bounded along it.
    check(&s, [0.0, 0.0, 3.0], [0.0, -0.05, -1.0]);
}

#[test]
fn vacuum_renders_exactly_zero() {
    let mut s = scene([1.5, 1.0, 0.8], [0.0, 0.0, 3.0], [0.0; 3]);
    s.medium.sigma_t_scale = 0.0;
    let density = s.density_grid().unwrap();
    let img = Renderer {
        scene: &s,
        density: &density,
        ms: None,
        light_leg: None,
    }
    .render(8, 1, None);
    assert!(img.data.iter().all(|v| *v == 0.0));
}
