//! `pn render --method pop` end to end (issue 20): a built-in scene renders a finite image
//! that is brighter than single scattering, report.json carries POP's settings, energy
//! bookkeeping and times; bad settings are one clear error.
#![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)] // test code

use pn_formats::read_exr_gray;
use std::path::{Path, PathBuf};
use std::process::Command;

fn tmp(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("pn-pop-cli-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

fn pn(args: &[&str]) -> std::process::Output {
    Command::new(env!("CARGO_BIN_EXE_pn"))
        .args(args)
        .output()
        .expect("run pn")
}

/// The built-in `cloud` (albedo 0.95, HG g = 0.3, one directional light) made small:
/// 32×32 pixels, a 32³ density grid, 16³ solve grid.
const SMALL: [&str; 10] = [
    "--set",
    "camera.width=32",
    "--set",
    "camera.height=32",
    "--set",
    "medium.resolution=[32,32,32]",
    "--solve-res",
    "16",
    "--threads",
    "2",
];

fn render(method: &str, extra: &[&str], out: &Path) -> (Vec<f32>, serde_json::Value) {
    let mut args = vec![
        "render",
        "cloud",
        "--method",
        method,
        "--out",
        out.to_str().unwrap(),
    ];
    args.extend_from_slice(&SMALL);
    args.extend_from_slice(extra);
    let o = pn(&args);
    assert!(
        o.status.success(),
        "pn {args:?}: {}",
        String::from_utf8_lossy(&o.stderr)
    );
    let (_, _, data) = read_exr_gray(&out.join("image.exr")).unwrap();
    let report: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("report.json")).unwrap()).unwrap();
    (data, report)
}

/// Test 5 of issue 20: POP adds the multiple scattering to the exact single scattering, so
/// for albedo 0.95 its image is finite, nowhere darker than single scattering (POP's field
/// is a sum of HG lobes with a ≤ g; with l ≤ 3 and g = 0.3 every term g^l a^l of the
/// in-scattering is positive — tolerance 1e-6 relative to the maximum for float rounding)
/// and brighter on average. The report carries the settings, one energy entry per iteration
/// that balances to rounding, and the time per stage.
#[test]
fn pop_render_is_brighter_than_single_scattering() {
    let dir = tmp("cloud");
    let (ss, ss_report) = render("none", &[], &dir.join("none"));
    let (pop, report) = render(
        "pop",
        &["--pop-resolution", "16", "--pop-iterations", "24"],
        &dir.join("pop"),
    );
    assert_eq!(pop.len(), 32 * 32);
    assert!(pop.iter().all(|v| v.is_finite() && *v >= 0.0));
    let max = pop.iter().fold(0.0f32, |m, v| m.max(*v));
    for (p, s) in pop.iter().zip(&ss) {
        assert!(
            *p >= *s - 1e-6 * max,
            "POP {p} darker than single scattering {s}"
        );
    }
    let (m_pop, m_ss) = (
        report["mean_radiance"].as_f64().unwrap(),
        ss_report["mean_radiance"].as_f64().unwrap(),
    );
    assert!(
        m_ss > 0.0 && m_pop > 1.2 * m_ss,
        "POP {m_pop} vs single {m_ss}"
    );
    assert_eq!(report["method"], "pop");
    let p = &report["pop"];
    assert_eq!(p["settings"]["resolution"], 16);
    assert_eq!(p["settings"]["iterations"], 24);
    assert_eq!(p["settings"]["lmax"], 3);
    let light = &p["lights"][0];
    let energy = light["energy"].as_array().unwrap();
    assert_eq!(energy.len(), 24);
    let injected = light["injected"].as_f64().unwrap();
    assert!(injected > 0.0);
    assert!(light["max_relative_imbalance"].as_f64().unwrap() < 1e-12);
    let f = light["in_flight_final_fraction"].as_f64().unwrap();
    assert!((0.0..1.0).contains(&f));
    for stage in ["medium", "initialization", "propagation", "resampling"] {
        assert!(p["seconds"][stage].as_f64().unwrap() >= 0.0, "{stage}");
    }
    assert!(report["solver"].is_null());
}

/// The isotropic residuum (§5.4) from the command line: the report says where it switched
/// and that the power in flight fell to ε_L; the propagation went on past the fixed count,
/// so the image is brighter than the 24-iteration one (more of the scattered light counted)
/// and still finite and non-negative.
#[test]
fn pop_residuum_runs_to_epsilon_l_and_reports_it() {
    let dir = tmp("residuum");
    let (fixed, fixed_report) = render(
        "pop",
        &["--pop-resolution", "16", "--pop-iterations", "24"],
        &dir.join("fixed"),
    );
    let (res, report) = render(
        "pop",
        &[
            "--pop-resolution",
            "16",
            "--pop-residuum",
            "--pop-epsilon-l",
            "1e-3",
        ],
        &dir.join("residuum"),
    );
    assert_eq!(res.len(), fixed.len());
    assert!(res.iter().all(|v| v.is_finite() && *v >= 0.0));
    let light = &report["pop"]["lights"][0];
    let r = &light["residuum"];
    assert_eq!(r["reached_epsilon_l"], true, "{r}");
    let switch = r["switch_iteration"].as_u64().unwrap();
    let iso = r["isotropic_iterations"].as_u64().unwrap();
    assert!(switch >= 16 && iso > 0, "{r}");
    assert_eq!(
        light["energy"].as_array().unwrap().len() as u64,
        switch + iso
    );
    assert!(light["in_flight_final_fraction"].as_f64().unwrap() <= 1e-3);
    assert!(light["max_relative_imbalance"].as_f64().unwrap() < 1e-12);
    assert!(fixed_report["pop"]["lights"][0]["residuum"].is_null());
    let (m_res, m_fixed) = (
        report["mean_radiance"].as_f64().unwrap(),
        fixed_report["mean_radiance"].as_f64().unwrap(),
    );
    assert!(
        m_res > m_fixed,
        "residuum {m_res} vs 24 iterations {m_fixed}"
    );
}

/// Test 6 of issue 20 on the command line: POP grid resolution 0 or 513, 0 iterations,
/// the POP flags with another method, a backward HG lobe, a misspelt method: each fails
/// with one message naming the problem, no panic.
#[test]
fn bad_pop_input_is_one_clear_error() {
    let dir = tmp("bad");
    let out = dir.to_str().unwrap();
    for (extra, want) in [
        (
            vec!["--method", "pop", "--pop-resolution", "0"],
            "pop_resolution must lie in 1..=512",
        ),
        (
            vec!["--method", "pop", "--pop-resolution", "513"],
            "pop_resolution must lie in 1..=512",
        ),
        (
            vec!["--method", "pop", "--pop-iterations", "0"],
            "pop_iterations must lie in",
        ),
        (
            vec!["--method", "pn", "--pop-iterations", "5"],
            "--pop-iterations applies to --method pop only",
        ),
        (
            vec!["--method", "pn", "--pop-residuum"],
            "--pop-residuum applies to --method pop only",
        ),
        (
            vec![
                "--method",
                "pop",
                "--pop-residuum",
                "--pop-epsilon-a",
                "1.5",
            ],
            "pop_epsilon_a must lie in (0, 1)",
        ),
        (
            vec!["--method", "pop", "--pop-residuum", "--pop-epsilon-l", "0"],
            "pop_epsilon_l must lie in (0, 1)",
        ),
        (
            vec!["--method", "pop", "--set", "phase.g=-0.3"],
            "POP needs a Henyey–Greenstein g in [0, 1)",
        ),
        (
            vec!["--method", "pop", "--set", "solve.pop_resolution=0"],
            "pop_resolution must lie in 1..=512",
        ),
        (
            vec!["--method", "popp"],
            "expected pn, cda, fld, pop or none",
        ),
    ] {
        let mut args = vec!["render", "cloud", "--out", out];
        args.extend_from_slice(&SMALL);
        args.extend_from_slice(&extra);
        let o = pn(&args);
        let err = String::from_utf8_lossy(&o.stderr);
        assert!(!o.status.success(), "{extra:?} succeeded");
        assert!(err.contains(want), "{extra:?}: {err}");
        assert!(!err.contains("panicked"), "{extra:?}: {err}");
    }
}

/// g → 1 (HG g = 1 − 1e−13, a delta lobe in POP) renders a finite image, no NaN. (Not
/// necessarily non-negative: the moments of a delta lobe truncated at lmax = 3,
/// Σ_{l≤3} (2l+1)/(4π) P_l, ring below zero away from d; the renderer's g^l ≈ 1 does not
/// damp them. A documented limit of handing POP's lobes on as SH moments.)
#[test]
fn delta_lobe_renders_a_finite_image() {
    let dir = tmp("delta");
    let (pop, report) = render(
        "pop",
        &["--set", "phase.g=0.9999999999999", "--pop-resolution", "12"],
        &dir,
    );
    let (lo, hi) = pop
        .iter()
        .fold((f32::INFINITY, f32::NEG_INFINITY), |(a, b), v| {
            (a.min(*v), b.max(*v))
        });
    eprintln!("delta lobe: pixels in [{lo}, {hi}]");
    assert!(pop.iter().all(|v| v.is_finite()));
    assert!(report["mean_radiance"].as_f64().unwrap().is_finite());
    let light = &report["pop"]["lights"][0];
    assert!(light["max_relative_imbalance"].as_f64().unwrap() < 1e-12);
}

/// Point lights are propagated on radial grids (§6, issue 52): the built-in `sphere` (one
/// directional and one point light) renders with no warning, the report has one entry per
/// light, the point light's with its radial grid, and each balances to rounding. Without
/// its point light the image is darker everywhere the point light's multiple scattering
/// reaches (isotropic phase: the field is A_0 ≥ 0) and darker on average.
#[test]
fn point_lights_are_propagated_on_radial_grids() {
    let dir = tmp("sphere");
    let render = |extra: &[&str], out: &Path| -> (Vec<f32>, serde_json::Value) {
        let mut args = vec![
            "render",
            "sphere",
            "--method",
            "pop",
            "--set",
            "camera.width=24",
            "--set",
            "camera.height=24",
            "--solve-res",
            "12",
            "--pop-resolution",
            "10",
            "--out",
            out.to_str().unwrap(),
        ];
        args.extend_from_slice(extra);
        let o = pn(&args);
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        let (_, _, data) = read_exr_gray(&out.join("image.exr")).unwrap();
        let report: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(out.join("report.json")).unwrap())
                .unwrap();
        (data, report)
    };
    let (both, report) = render(&[], &dir.join("both"));
    assert!(
        report["warnings"].as_array().unwrap().is_empty(),
        "{}",
        report["warnings"]
    );
    let lights = report["pop"]["lights"].as_array().unwrap();
    assert_eq!(lights.len(), 2);
    assert_eq!(lights[0]["kind"], "directional");
    assert_eq!(lights[1]["kind"], "point");
    assert_eq!(lights[1]["light"], 1);
    let radial = &lights[1]["radial"];
    assert_eq!(radial["angular"], 10);
    assert!(radial["r_min"].as_f64().unwrap() > 0.0);
    assert!(radial["shells"].as_u64().unwrap() >= 1);
    for l in lights {
        assert!(l["injected"].as_f64().unwrap() > 0.0);
        assert!(l["max_relative_imbalance"].as_f64().unwrap() < 1e-12);
    }
    // The same scene with the point light's power at 0: its single and multiple
    // scattering gone.
    let (dark, dark_report) = render(&["--set", "light.1.power=0"], &dir.join("dark"));
    let max = both.iter().fold(0.0f32, |m, v| m.max(*v));
    for (b, d) in both.iter().zip(&dark) {
        assert!(*b >= *d - 1e-6 * max, "{b} < {d}");
    }
    let (m_both, m_dark) = (
        report["mean_radiance"].as_f64().unwrap(),
        dark_report["mean_radiance"].as_f64().unwrap(),
    );
    assert!(m_both > m_dark, "{m_both} vs {m_dark}");
}

/// A point-lit scene: POP adds the point light's multiple scattering to its exact single
/// scattering (isotropic phase, so the field is A_0 ≥ 0 and POP's image is nowhere darker
/// than single scattering, and brighter on average); the bilateral upsampling renders a
/// finite, non-negative image and says so in the report.
#[test]
fn a_point_lit_scene_is_brighter_than_single_scattering() {
    let dir = tmp("point");
    let out = |name: &str| dir.join(name).to_str().unwrap().to_owned();
    let common = [
        "--set",
        "light.0.irradiance=0",
        "--set",
        "camera.width=24",
        "--set",
        "camera.height=24",
        "--solve-res",
        "12",
        "--set",
        "solve.pop_resolution=16",
    ];
    let mut images = Vec::new();
    for (method, extra, name) in [
        ("none", vec![], "none"),
        ("pop", vec![], "pop"),
        (
            "pop",
            vec!["--set", "solve.pop_upsample=bilateral"],
            "bilateral",
        ),
    ] {
        let o_ = out(name);
        let mut args = vec!["render", "sphere", "--method", method, "--out", o_.as_str()];
        args.extend_from_slice(&common);
        args.extend_from_slice(&extra);
        // The directional light (light 0) is switched off: only the point light remains.
        let o = pn(&args);
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        let (_, _, data) = read_exr_gray(&dir.join(name).join("image.exr")).unwrap();
        let report: serde_json::Value = serde_json::from_str(
            &std::fs::read_to_string(dir.join(name).join("report.json")).unwrap(),
        )
        .unwrap();
        images.push((data, report));
    }
    let (ss, pop, bil) = (&images[0], &images[1], &images[2]);
    let max = pop.0.iter().fold(0.0f32, |m, v| m.max(*v));
    for (p, s) in pop.0.iter().zip(&ss.0) {
        assert!(
            p.is_finite() && *p >= *s - 1e-6 * max,
            "POP {p} vs single {s}"
        );
    }
    let mean = |r: &serde_json::Value| r["mean_radiance"].as_f64().unwrap();
    assert!(
        mean(&pop.1) > 1.05 * mean(&ss.1),
        "{} vs {}",
        mean(&pop.1),
        mean(&ss.1)
    );
    assert!(bil.0.iter().all(|v| v.is_finite() && *v >= 0.0));
    assert_eq!(bil.1["pop"]["options"]["upsample"], "bilateral");
    assert_eq!(pop.1["pop"]["options"]["upsample"], "trilinear");
}

/// A point light inside the medium (the paper's Fig. 10 has its light at the centre of a
/// ball): the sphere's point light moved to the centre renders a finite, non-negative image
/// (isotropic phase) brighter than its single scattering, and the report says the light is
/// inside, with an innermost radius of half a voxel (the sphere's 32³ voxels over [−1, 1]³:
/// 1/32) and a balanced propagation.
#[test]
fn a_point_light_inside_the_medium_renders() {
    let dir = tmp("inside");
    let mut reports = Vec::new();
    for method in ["none", "pop"] {
        let out = dir.join(method);
        let o = pn(&[
            "render",
            "sphere",
            "--method",
            method,
            "--set",
            "light.0.irradiance=0",
            "--set",
            "light.1.position=[0.0,0.0,0.0]",
            "--set",
            "camera.width=24",
            "--set",
            "camera.height=24",
            "--solve-res",
            "12",
            "--out",
            out.to_str().unwrap(),
        ]);
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        let (_, _, data) = read_exr_gray(&out.join("image.exr")).unwrap();
        assert!(data.iter().all(|v| v.is_finite() && *v >= 0.0));
        let report: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(out.join("report.json")).unwrap())
                .unwrap();
        reports.push(report);
    }
    let light = &reports[1]["pop"]["lights"][1];
    assert_eq!(light["radial"]["inside"], true);
    assert!((light["radial"]["r_min"].as_f64().unwrap() - 1.0 / 32.0).abs() < 1e-12);
    assert!(light["max_relative_imbalance"].as_f64().unwrap() < 1e-12);
    let mean = |r: &serde_json::Value| r["mean_radiance"].as_f64().unwrap();
    assert!(mean(&reports[1]) > mean(&reports[0]));
}

/// Bad point-light input on the command line, each one clear error naming the key:
/// `pop_shells` 0 or 513, an unknown `pop_upsample`, a non-positive `pop_upsample_sigma`.
#[test]
fn bad_point_light_input_is_one_clear_error() {
    let dir = tmp("bad-point");
    let out = dir.to_str().unwrap();
    for (set, want) in [
        ("solve.pop_shells=0", "pop_shells must lie in 1..=512"),
        ("solve.pop_shells=513", "pop_shells must lie in 1..=512"),
        ("solve.pop_upsample=\"cubic\"", "pop_upsample"),
        (
            "solve.pop_upsample_sigma=0",
            "pop_upsample_sigma must be finite and positive",
        ),
    ] {
        let o = pn(&[
            "render",
            "sphere",
            "--method",
            "pop",
            "--set",
            "camera.width=8",
            "--set",
            "camera.height=8",
            "--solve-res",
            "8",
            "--set",
            set,
            "--out",
            out,
        ]);
        let err = String::from_utf8_lossy(&o.stderr);
        assert!(!o.status.success(), "{set} succeeded");
        assert!(err.contains(want), "{set}: {err}");
        assert!(!err.contains("panicked"), "{set}: {err}");
    }
}
