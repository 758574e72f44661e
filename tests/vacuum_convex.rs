//! Issue 17's quick test of the vacuum treatment: on a convex medium, light that leaves never
//! returns, so exact transport inside it cannot depend on the empty space around it. With the
//! graded absorber outside the medium's convex hull (`[solve] absorber = "hull"`, the default;
//! `render::hull_absorber`) the image mean must change by less than 0.5 % between a margin of
//! 2 and 8 cells and between the automatic σ_t threshold and one ten times smaller.
//!
//! Why 0.5 %: it is the bound. Measured (2026-12-02, these settings): the hull
//! treatment changes the mean by < 1e-6 with the margin (the cells it adds are all outside the
//! hull, saturated absorber) and by about 0.03 % with the threshold (vacuum inside the hull
//! is only the staircase gaps of the voxelised surface). The old treatment (`absorber = "box"`:
//! empty margin, absorber only at the grid's edge) changes the mean by about 8 % between
//! margin 2 and 8 on the sphere; the test asserts that it still differs by more than 2 %, so a
//! change that made the test insensitive would show.
#![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)] // test code

mod support;
use support::{ok, pn, work_dir};

/// The sphere (scenes/sphere.toml, σ_t = 5, albedo 0.8, two lights) at a small size, and an
/// HG box (σ_t = 8, albedo 0.95, g = 0.5) under one sun.
fn scene(kind: &str, solve: &str) -> String {
    let (medium, phase) = match kind {
        "sphere" => (
            "kind = \"sphere\"\nsigma_t_scale = 5.0\nalbedo = 0.8",
            "kind = \"isotropic\"",
        ),
        _ => (
            "kind = \"box\"\nsigma_t_scale = 8.0\nalbedo = 0.95",
            "kind = \"hg\"\ng = 0.5",
        ),
    };
    format!(
        "[medium]\n{medium}\nresolution = [16, 16, 16]\nbbox_min = [-1.0, -1.0, -1.0]\n\
         bbox_max = [1.0, 1.0, 1.0]\n[phase]\n{phase}\n\
         [[light]]\nkind = \"directional\"\ndirection = [0.0, -1.0, -0.5]\nirradiance = 1.0\n\
         [camera]\nposition = [0.0, 0.0, 4.0]\ntarget = [0.0, 0.0, 0.0]\nup = [0.0, 1.0, 0.0]\n\
         fov = 40.0\nwidth = 24\nheight = 24\n\
         [solve]\nmethod = \"pn\"\norder = 3\nresolution = [12, 12, 12]\ntolerance = 1e-7\n{solve}\n\
         [render]\nrays = 1\n"
    )
}

/// The image mean and the σ_t threshold of a render.
fn render(name: &str, text: &str) -> (f64, f64) {
    let dir = work_dir(&format!("vacuum_convex_{name}"));
    std::fs::create_dir_all(&dir).unwrap();
    let file = dir.join(format!("{name}.toml"));
    std::fs::write(&file, text).unwrap();
    let out = dir.join(name);
    let o = pn(&[
        "render",
        file.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
    ]);
    ok(&o);
    let report: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("report.json")).unwrap()).unwrap();
    let mean = report["mean_radiance"].as_f64().unwrap();
    let threshold = report["solver"]["sigma_t_min"].as_f64().unwrap_or(0.0);
    assert!(mean.is_finite() && mean > 0.0, "{name}: mean {mean}");
    (mean, threshold)
}

fn check_convex(kind: &str) {
    let (m2, auto) = render(&format!("{kind}_m2"), &scene(kind, "margin = 2"));
    let (m8, _) = render(&format!("{kind}_m8"), &scene(kind, "margin = 8"));
    // The automatic threshold applies where σ_t falls below 1e-3 of its largest value
    // anywhere (vacuum, or the weak edge of the hull absorber). Where it does not apply,
    // the threshold test compares two explicit ones (that rule's 1e-3 of the largest σ_t,
    // and ten times smaller).
    let (m2, base) = if auto > 0.0 {
        (m2, auto)
    } else {
        let t = 8.0e-3;
        let (m, _) = render(
            &format!("{kind}_t1"),
            &scene(kind, &format!("margin = 2\nsigma_t_min = {t}")),
        );
        (m, t)
    };
    let small = format!("margin = 2\nsigma_t_min = {}", base / 10.0);
    let (t10, _) = render(&format!("{kind}_t10"), &scene(kind, &small));
    let dm = (m8 / m2 - 1.0).abs();
    let dt = (t10 / m2 - 1.0).abs();
    eprintln!("{kind}: margin 2 → 8 changes the mean by {dm:.2e}, threshold /10 by {dt:.2e}");
    assert!(dm < 5e-3, "{kind}: margin changes the mean by {dm}");
    assert!(dt < 5e-3, "{kind}: threshold changes the mean by {dt}");
}

#[test]
fn the_sphere_does_not_depend_on_the_vacuum_around_it() {
    check_convex("sphere");
}

#[test]
fn an_hg_box_does_not_depend_on_the_vacuum_around_it() {
    check_convex("box");
}

#[test]
fn the_old_box_absorber_does_depend_on_the_margin() {
    let (m2, _) = render("old_m2", &scene("sphere", "margin = 2\nabsorber = \"box\""));
    let (m8, _) = render("old_m8", &scene("sphere", "margin = 8\nabsorber = \"box\""));
    let d = (m8 / m2 - 1.0).abs();
    eprintln!("box absorber: margin 2 → 8 changes the mean by {d:.2e}");
    assert!(d > 0.02, "the old treatment was margin-dependent; got {d}");
}
