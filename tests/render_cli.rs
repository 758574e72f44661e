//! `pn render` end to end on small scenes (16³ density, ≤ 16³ solve grid, 32×32 image):
//! every method runs and writes its files; the multiple-scattering part behaves as the
//! theory says; the turntable and the renderer settings; a camera or light inside the
//! medium, an empty medium and a medium out of view render finite images (black with a
//! warning for the last two); bad input gives one clear error.
#![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)] // test code

use pn_drivers::render::{render_scene, RenderOptions};
use pn_formats::read_exr_gray;
use pn_render::scene::RenderMethod;
use pn_render::RenderScene;
use std::path::{Path, PathBuf};
use std::process::Command;

/// One thread, the default memory limit, no progress bars.
fn one_thread() -> RenderOptions {
    RenderOptions {
        threads: Some(1),
        progress: false,
        ..Default::default()
    }
}

/// A homogeneous isotropic ball (radius 0.8 of the half extent) with a directional and a
/// point light; 16³ density, solve grid 8 cells across the box (cropped + margin 2).
const SCENE: &str = r#"
[medium]
kind = "sphere"
resolution = [16, 16, 16]
sigma_t_scale = 6.0
albedo = 0.9
[phase]
kind = "isotropic"
[[light]]
kind = "directional"
direction = [0.2, -1.0, -0.4]
irradiance = 1.0
[[light]]
kind = "point"
position = [1.4, 1.2, 1.3]
power = 10.0
[camera]
position = [0.0, 0.3, 3.5]
target = [0.0, 0.0, 0.0]
up = [0.0, 1.0, 0.0]
fov = 45.0
width = 32
height = 32
[solve]
method = "pn"
order = 1
resolution = [8, 8, 8]
margin = 2
tolerance = 1e-8
[render]
spp = 4
seed = 5
"#;

fn tmp(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("pn-render-cli-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

fn scene(method: RenderMethod, order: usize) -> RenderScene {
    let mut s = RenderScene::from_toml_str(SCENE, Path::new(".")).unwrap();
    s.solve.method = method;
    s.solve.order = order;
    s
}

fn pn(args: &[&str]) -> std::process::Output {
    Command::new(env!("CARGO_BIN_EXE_pn"))
        .args(args)
        .output()
        .expect("run pn")
}

/// For isotropic scattering the first-scatter source has no l = 1 part, and eliminating the
/// staggered face moments of P_1 gives exactly the 7-point CDA stencil (docs/design.md §2.2):
/// the two images must agree to the solver tolerance (1e-8 relative residual; the paths
/// are identical because both use the same seeds, so no Monte Carlo noise enters the
/// difference). Tolerance 1e-5 relative to the image maximum.
#[test]
fn p1_equals_cda_for_isotropic_scattering() {
    let a = render_scene(&scene(RenderMethod::Pn, 1), &one_thread()).unwrap();
    let b = render_scene(&scene(RenderMethod::Cda, 1), &one_thread()).unwrap();
    let max = a.image.data.iter().fold(0.0f32, |m, v| m.max(*v)) as f64;
    assert!(max > 0.0);
    for (x, y) in a.image.data.iter().zip(&b.image.data) {
        assert!(
            ((x - y) as f64).abs() <= 1e-5 * max,
            "P_1 {x} vs CDA {y} (max {max})"
        );
    }
}

/// Multiple scattering only adds light (all sources and solutions are non-negative in
/// the mean), the same paths are sampled for every method, and P_3 / FLD add a similar
/// amount as P_1 (within a factor 2: they are different approximations of the same
/// transport on an optically thick ball, mean free path 1/6 against a radius 0.8).
#[test]
fn multiple_scattering_adds_light_and_methods_agree_roughly() {
    let none = render_scene(&scene(RenderMethod::None, 1), &one_thread()).unwrap();
    let mean = |r: &pn_drivers::render::RenderRun| r.report.mean_radiance;
    let ss = mean(&none);
    assert!(ss > 0.0);
    let mut ms = Vec::new();
    for (m, o) in [
        (RenderMethod::Pn, 1),
        (RenderMethod::Pn, 3),
        (RenderMethod::Fld, 1),
    ] {
        let r = render_scene(&scene(m, o), &one_thread()).unwrap();
        let u = r.report.unknowns.as_ref().unwrap();
        // Cropping: the ball covers 0.8 of the box, the margin keeps 2 cells: 12³ cells
        // solved against (8 + 4)³ uncropped — equal here; at the density resolution more.
        assert!(u.solved <= u.uncropped && u.solved < u.cropped_at_density_resolution);
        assert!(r.report.solver.as_ref().unwrap().converged, "{m:?}");
        ms.push(mean(&r) - ss);
    }
    assert!(ms.iter().all(|v| *v > 0.0), "{ms:?}");
    for v in &ms[1..] {
        assert!(*v / ms[0] > 0.5 && *v / ms[0] < 2.0, "{ms:?}");
    }
}

#[test]
fn pn_render_writes_images_and_report() {
    let dir = tmp("files");
    let scene_path = dir.join("ball.toml");
    std::fs::write(&scene_path, SCENE).unwrap();
    let out = dir.join("out");
    let o = pn(&[
        "render",
        scene_path.to_str().unwrap(),
        "--method",
        "pn",
        "--order",
        "3",
        "--spp",
        "2",
        "--solve-res",
        "6",
        "--stats",
        "--out",
        out.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let stdout = String::from_utf8_lossy(&o.stdout);
    assert!(stdout.contains("unknowns:"), "{stdout}");
    let (w, h, data) = read_exr_gray(&out.join("image.exr")).unwrap();
    assert_eq!((w, h), (32, 32));
    assert!(data.iter().any(|v| *v > 0.0));
    assert!(out.join("image.png").is_file());
    let report: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("report.json")).unwrap()).unwrap();
    assert_eq!(report["order"], 3);
    assert_eq!(report["spp"], 2);
    for key in ["light_depth", "sources", "solve", "render", "total"] {
        assert!(report["seconds"][key].as_f64().unwrap() >= 0.0, "{key}");
    }
    assert!(report["unknowns"]["solved"].as_u64().unwrap() > 0);
    assert!(report["peak_memory_bytes"].as_u64().is_some());
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn bad_input_is_one_clear_error() {
    let dir = tmp("errors");
    let cases: Vec<(Vec<String>, &str)> = vec![
        (vec!["render".into(), "no-such-scene".into()], "built-in"),
        (
            vec![
                "render".into(),
                dir.join("missing.toml").display().to_string(),
            ],
            "cannot read",
        ),
        (
            vec![
                "render".into(),
                "sphere".into(),
                "--method".into(),
                "magic".into(),
            ],
            "magic",
        ),
        (
            vec![
                "render".into(),
                "sphere".into(),
                "--method".into(),
                "cda".into(),
                "--order".into(),
                "3".into(),
            ],
            "--order applies",
        ),
        (
            vec!["render".into(), "sphere".into(), "--spp".into(), "0".into()],
            "spp",
        ),
        (
            vec![
                "render".into(),
                "sphere".into(),
                "--solve-res".into(),
                "4,4".into(),
            ],
            "--solve-res",
        ),
    ];
    let bad = dir.join("bad.toml");
    std::fs::write(&bad, SCENE.replace("fov = 45.0", "fov = 45.0\nzoom = 2")).unwrap();
    let mut cases = cases;
    cases.push((vec!["render".into(), bad.display().to_string()], "line"));
    // Broken and unsupported OpenVDB files (fixtures written by OpenVDB: tests/data/vdb).
    let vdb = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/vdb");
    for (file, want) in [
        ("truncated.vdb", "truncated"),
        ("half16.vdb", "half precision"),
        ("vec3.vdb", "value type"),
    ] {
        let scene = dir.join(file.replace(".vdb", ".toml"));
        let text = std::fs::read_to_string(
            Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/vdbcloud.toml"),
        )
        .unwrap()
        .replace("data/vdbcloud.vdb", &vdb.join(file).display().to_string());
        std::fs::write(&scene, text).unwrap();
        cases.push((vec!["render".into(), scene.display().to_string()], want));
    }
    for (args, want) in cases {
        let mut args = args;
        args.extend(["--out".to_string(), dir.join("out").display().to_string()]);
        let refs: Vec<&str> = args.iter().map(|s| s.as_str()).collect();
        let o = pn(&refs);
        let err = String::from_utf8_lossy(&o.stderr);
        assert!(!o.status.success(), "{args:?} should fail");
        assert!(err.contains(want), "{args:?}: {err}");
        assert!(!err.contains("panicked"), "{args:?}: {err}");
    }
    assert!(!dir.join("out").exists());
    let _ = std::fs::remove_dir_all(&dir);
}

fn report(dir: &Path) -> serde_json::Value {
    serde_json::from_str(&std::fs::read_to_string(dir.join("report.json")).unwrap()).unwrap()
}

/// `--turntable 3`: one solve, three views `view_000…002`; view 0 is the plain render of the
/// scene camera (identical pixels: the deterministic renderer has no randomness), the
/// report lists the views with their angles and times; `--renderer montecarlo` and the
/// deterministic settings reach the report.
#[test]
fn turntable_views_and_renderer_settings() {
    let dir = tmp("turntable");
    let scene_path = dir.join("ball.toml");
    std::fs::write(&scene_path, SCENE).unwrap();
    let s = scene_path.to_str().unwrap();
    let plain = dir.join("plain");
    let o = pn(&[
        "render",
        s,
        "--rays",
        "1",
        "--step",
        "1",
        "--filter",
        "nearest",
        "--out",
        plain.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let r = report(&plain);
    assert_eq!(r["renderer"], "deterministic");
    assert_eq!(r["rays_per_pixel"], 1);
    assert_eq!(r["step"], 1.0);
    assert_eq!(r["filter"], "nearest");
    assert!(r["seconds"]["light_depth"].as_f64().unwrap() >= 0.0);
    let tt = dir.join("tt");
    let o = pn(&[
        "render",
        s,
        "--rays",
        "1",
        "--step",
        "1",
        "--filter",
        "nearest",
        "--turntable",
        "3",
        "--out",
        tt.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let (_, _, a) = read_exr_gray(&plain.join("image.exr")).unwrap();
    let (_, _, b) = read_exr_gray(&tt.join("view_000.exr")).unwrap();
    assert_eq!(a, b);
    for k in 0..3 {
        assert!(
            tt.join(format!("view_{k:03}.exr")).is_file()
                && tt.join(format!("view_{k:03}.png")).is_file()
        );
    }
    let (_, _, c) = read_exr_gray(&tt.join("view_001.exr")).unwrap();
    assert_ne!(a, c, "view 1 sees the ball from another side");
    let r = report(&tt);
    let views = r["views"].as_array().unwrap();
    assert_eq!(views.len(), 3);
    assert_eq!(views[1]["angle_deg"], 120.0);
    // Camera (0, 0.3, 3.5) turned 120° right-handed about +y: x = 3.5 sin 120°, z = 3.5 cos 120°.
    let p = views[1]["position"].as_array().unwrap();
    let p: Vec<f64> = p.iter().map(|v| v.as_f64().unwrap()).collect();
    let th = 120f64.to_radians();
    assert!(
        (p[0] - 3.5 * th.sin()).abs() < 1e-9
            && (p[1] - 0.3).abs() < 1e-9
            && (p[2] - 3.5 * th.cos()).abs() < 1e-9,
        "{p:?}"
    );
    let mc = dir.join("mc");
    let o = pn(&[
        "render",
        s,
        "--renderer",
        "montecarlo",
        "--method",
        "none",
        "--spp",
        "2",
        "--out",
        mc.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let r = report(&mc);
    assert_eq!(r["renderer"], "montecarlo");
    assert!(r["step"].is_null());
    let _ = std::fs::remove_dir_all(&dir);
}

/// Documented behaviours, not errors: a camera inside the medium and a point light inside
/// it render finite images with light; an empty medium and a medium out of view give a
/// black image and a warning. No pixel is NaN.
#[test]
fn awkward_scenes_render_finite_images() {
    let dir = tmp("awkward");
    let cases: [(&str, String, bool, Option<&str>); 4] = [
        (
            "camera-inside",
            SCENE.replace("position = [0.0, 0.3, 3.5]", "position = [0.1, 0.2, 0.3]"),
            true,
            None,
        ),
        (
            "light-inside",
            SCENE.replace("position = [1.4, 1.2, 1.3]", "position = [0.1, -0.2, 0.0]"),
            true,
            None,
        ),
        (
            "empty",
            SCENE.replace("sigma_t_scale = 6.0", "sigma_t_scale = 0.0"),
            false,
            Some("empty"),
        ),
        (
            "out-of-view",
            SCENE.replace("target = [0.0, 0.0, 0.0]", "target = [0.0, 0.3, 8.0]"),
            false,
            Some("outside the camera's view"),
        ),
    ];
    for (name, text, lit, warning) in cases {
        let path = dir.join(format!("{name}.toml"));
        std::fs::write(&path, text).unwrap();
        let out = dir.join(name);
        let o = pn(&[
            "render",
            path.to_str().unwrap(),
            "--rays",
            "1",
            "--out",
            out.to_str().unwrap(),
        ]);
        let err = String::from_utf8_lossy(&o.stderr);
        assert!(o.status.success(), "{name}: {err}");
        let (_, _, data) = read_exr_gray(&out.join("image.exr")).unwrap();
        assert!(data.iter().all(|v| v.is_finite() && *v >= 0.0), "{name}");
        assert_eq!(data.iter().any(|v| *v > 0.0), lit, "{name}");
        if let Some(w) = warning {
            assert!(err.contains("warning") && err.contains(w), "{name}: {err}");
            let r = report(&out);
            assert!(r["warnings"][0].as_str().unwrap().contains(w), "{name}");
        }
    }
    let _ = std::fs::remove_dir_all(&dir);
}

/// Renderer settings out of range: one clear error naming the setting.
#[test]
fn bad_renderer_settings_are_one_clear_error() {
    let dir = tmp("bad-settings");
    let zero = dir.join("zero.toml");
    std::fs::write(&zero, SCENE.replace("width = 32", "width = 0")).unwrap();
    let cases: [(&[&str], &str); 8] = [
        (&["--rays", "3"], "square number"),
        (&["--rays", "0"], "square number"),
        (&["--step", "0"], "step must lie"),
        (&["--step", "100"], "step must lie"),
        (&["--turntable", "0"], "--turntable"),
        (&["--renderer", "magic"], "magic"),
        (&["--filter", "cubic"], "cubic"),
        (&["--step", "nan"], "step must lie"),
    ];
    for (extra, want) in cases {
        let mut args = vec!["render", "sphere", "--method", "none"];
        args.extend_from_slice(extra);
        let out = dir.join("out");
        args.extend(["--out", out.to_str().unwrap()]);
        let o = pn(&args);
        let err = String::from_utf8_lossy(&o.stderr);
        assert!(!o.status.success(), "{extra:?} should fail");
        assert!(err.contains(want), "{extra:?}: {err}");
        assert!(!err.contains("panicked"), "{extra:?}: {err}");
    }
    let o = pn(&["render", zero.to_str().unwrap()]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(!o.status.success() && err.contains("image size"), "{err}");
    assert!(!dir.join("out").exists());
    let _ = std::fs::remove_dir_all(&dir);
}

/// `--set SECTION.KEY=VALUE` overrides the scene file's keys before it is checked and is
/// recorded in report.json; an unknown key or a malformed override is one clear error.
#[test]
fn set_overrides_scene_keys_and_is_recorded() {
    let dir = tmp("set");
    let path = dir.join("ball.toml");
    std::fs::write(&path, SCENE).unwrap();
    let out = dir.join("out");
    let o = pn(&[
        "render",
        path.to_str().unwrap(),
        "--rays",
        "1",
        "--set",
        "solve.margin=3",
        "--set",
        "solve.absorber=box",
        "--stats",
        "--out",
        out.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let r = report(&out);
    assert_eq!(
        r["overrides"],
        serde_json::json!(["solve.margin=3", "solve.absorber=box"])
    );
    assert_eq!(r["scene"], "ball");
    // The margin widens the cropped solve grid: 3 + 4 absorbing cells on each side
    // against the file's 2 + 4.
    let wide = r["unknowns"]["solve_grid_res"][0].as_u64().unwrap();
    let o = pn(&[
        "render",
        path.to_str().unwrap(),
        "--rays",
        "1",
        "--out",
        out.to_str().unwrap(),
    ]);
    assert!(o.status.success());
    let r = report(&out);
    assert_eq!(r["overrides"], serde_json::json!([]));
    let narrow = r["unknowns"]["solve_grid_res"][0].as_u64().unwrap();
    assert_eq!(wide, narrow + 2, "margin 3 against 2 on both sides");
    for (set, want) in [
        ("solve.nonsense=1", "nonsense"),
        ("foo", "SECTION.KEY=VALUE"),
        ("=3", "key before '=' is empty"),
        ("solve.margin=many", "many"),
    ] {
        let o = pn(&["render", "sphere", "--method", "none", "--set", set]);
        let err = String::from_utf8_lossy(&o.stderr);
        assert!(!o.status.success(), "--set {set} should fail");
        assert!(
            err.contains(want) && err.contains("--set"),
            "--set {set}: {err}"
        );
        assert!(!err.contains("panicked"), "{err}");
    }
    let _ = std::fs::remove_dir_all(&dir);
}

/// The two FLD solvers of a render (`[solve] fld_solver`) stop on the same nonlinear
/// residual (RMS, relative to the source; docs/fld.md) and must reach the same discrete
/// solution: at tolerance 1e-10 the fluences agree to 1e-7 of their maximum (the residual
/// bound times the conditioning this small grid has; measured 3.5e-10 at 1e-9 on the puff).
/// The report names the solver.
#[test]
fn fld_picard_and_gauss_seidel_renders_agree() {
    let mut picard = scene(RenderMethod::Fld, 1);
    picard.solve.tolerance = 1e-10;
    let mut gs = picard.clone();
    gs.solve.fld_solver = pn_render::scene::FldSolver::Gs;
    assert_eq!(
        picard.solve.fld_solver,
        pn_render::scene::FldSolver::Picard,
        "Picard is the default"
    );
    let a = render_scene(&picard, &one_thread()).unwrap();
    let b = render_scene(&gs, &one_thread()).unwrap();
    let (ra, rb) = (a.report.solver.unwrap(), b.report.solver.unwrap());
    assert!(ra.solver.starts_with("fld-picard("), "{}", ra.solver);
    assert!(rb.solver.starts_with("fld-gs"), "{}", rb.solver);
    assert!(ra.converged && rb.converged);
    let (ma, mb) = (
        &a.solution.as_ref().unwrap().moments.data,
        &b.solution.as_ref().unwrap().moments.data,
    );
    let max = mb.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    assert!(max > 0.0);
    let diff = ma
        .iter()
        .zip(mb)
        .fold(0.0f64, |m, (x, y)| m.max((x - y).abs()));
    assert!(diff <= 1e-7 * max, "max |Δ| {diff:e} of max {max:e}");
}
