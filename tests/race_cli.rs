//! `pn race` from the command line: the quick smoke run on a tiny scene (needs Mitsuba and
//! pyoidn; skipped with a message without them unless PN_REQUIRE_MITSUBA=1), the reference
//! cache, the Markdown writer, and the errors that need no Mitsuba.
#![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)] // test code

use std::path::Path;

mod support;
use support::{mitsuba_python, ok, pn, work_dir};

/// A 16³ cloud seen in a 24×24 image: every render takes well under a second.
const TINY: &str = r#"
[medium]
kind = "cloud"
seed = 5
resolution = [16, 16, 16]
bbox_min = [-1.0, -1.0, -1.0]
bbox_max = [1.0, 1.0, 1.0]
sigma_t_scale = 10.0
albedo = 0.9
[phase]
kind = "hg"
g = 0.3
[[light]]
kind = "directional"
direction = [0.5, -1.0, -0.3]
irradiance = 1.0
[camera]
position = [0.0, 0.0, 4.0]
target = [0.0, 0.0, 0.0]
up = [0.0, 1.0, 0.0]
fov = 40.0
width = 24
height = 24
[solve]
method = "pn"
order = 1
resolution = [8, 8, 8]
[render]
spp = 4
seed = 1
"#;

/// The ablation study of the quick run: the base, one vacuum arm, and an order arm that is
/// the base's render.
const STUDY: &str = r#"
[[arm]]
name = "base"
group = "base"
point = "p1@8"

[[arm]]
name = "absorber box"
group = "vacuum"
point = "p1@8"
args = ["--set", "solve.absorber=box"]

[[arm]]
name = "p1"
group = "order"
point = "p1@8"
"#;

fn csv(path: &Path) -> Vec<std::collections::HashMap<String, String>> {
    let text = std::fs::read_to_string(path).unwrap();
    let mut lines = text.lines();
    let header: Vec<&str> = lines.next().unwrap().split(',').collect();
    lines
        .map(|l| {
            header
                .iter()
                .map(|h| h.to_string())
                .zip(l.split(',').map(str::to_string))
                .collect()
        })
        .collect()
}

#[test]
fn quick_race_writes_tables_plot_and_markdown_and_caches_the_reference() {
    let Some(python) = mitsuba_python() else {
        return;
    };
    let d = work_dir("race_cli_quick");
    std::fs::create_dir_all(&d).unwrap();
    let scene = d.join("tiny.toml");
    std::fs::write(&scene, TINY).unwrap();
    let study = d.join("study.toml");
    std::fs::write(&study, STUDY).unwrap();
    let (out, cache) = (d.join("race"), d.join("cache"));
    // P_1 and SP_1 written as text (pdes/sp1.pde, docs/pde-text.md).
    let points = format!("p1@8,{}/pdes/sp1.pde@8", env!("CARGO_MANIFEST_DIR"));
    let args = [
        "race",
        scene.to_str().unwrap(),
        "--quick",
        "--repeat",
        "2",
        "--pn-points",
        &points,
        "--ablation-study",
        study.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
        "--cache",
        cache.to_str().unwrap(),
        "--python",
        python.to_str().unwrap(),
    ];
    let o = pn(&args);
    ok(&o);
    let stdout = String::from_utf8_lossy(&o.stdout);
    assert!(stdout.contains("rendering into"), "{stdout}");
    let dir = out.join("tiny");
    for f in [
        "points.csv",
        "error_time.png",
        "crossings.txt",
        "single_scatter.csv",
    ] {
        assert!(dir.join(f).is_file(), "{f} missing");
    }
    // The exports and images are gone: the folder holds tables, plots and text only.
    assert!(!dir.join("work").exists());
    let rows = csv(&dir.join("points.csv"));
    // Mitsuba at 1 and 4 spp, plain and denoised, and the two pn points.
    let fams: Vec<&str> = rows.iter().map(|r| r["family"].as_str()).collect();
    assert_eq!(
        fams,
        [
            "mitsuba",
            "mitsuba+oidn",
            "mitsuba",
            "mitsuba+oidn",
            "p1",
            "pde:sp1"
        ]
    );
    for r in &rows {
        // Every point was timed twice (`--repeat 2`), the median run kept.
        assert_eq!(r["runs"], "2", "{r:?}");
        let e: f64 = r["rel_rmse"].parse().unwrap();
        let s: f64 = r["seconds"].parse().unwrap();
        assert!(e > 0.0 && e.is_finite() && s > 0.0, "{r:?}");
    }
    // Plain Mitsuba's error falls with the spp (4× the samples: about half the error; the
    // bound leaves room for the 32-spp reference's own noise).
    let e1: f64 = rows[0]["rel_rmse"].parse().unwrap();
    let e4: f64 = rows[2]["rel_rmse"].parse().unwrap();
    assert!(e4 < 0.8 * e1, "1 spp {e1}, 4 spp {e4}");
    let md = std::fs::read_to_string(out.join("results.md")).unwrap();
    assert!(md.contains("## tiny") && md.contains("tiny/error_time.png"));
    assert!(md.contains("pn PDE sp1"), "{md}");
    assert!(out.join("summary.csv").is_file());
    // The ablation: three arms, two renders (the order arm is the base's render).
    let ab = csv(&dir.join("ablation.csv"));
    let arms: Vec<(&str, &str, &str)> = ab
        .iter()
        .map(|r| (r["group"].as_str(), r["arm"].as_str(), r["point"].as_str()))
        .collect();
    assert_eq!(
        arms,
        [
            ("base", "base", "p1@8"),
            ("vacuum", "absorber box", "p1@8"),
            ("order", "p1", "p1@8")
        ]
    );
    assert_eq!(ab[1]["settings"], "res=8 solve.absorber=box");
    for r in &ab {
        assert!(r["error"].is_empty(), "{r:?}");
        let e: f64 = r["rel_rmse"].parse().unwrap();
        assert!(e > 0.0 && e.is_finite(), "{r:?}");
        assert_eq!(r["converged"], "true");
    }
    assert_eq!(ab[0]["bias_change_vs_base"], "0");
    assert_eq!(ab[0]["image_change_vs_base"], "0");
    assert_eq!(ab[2]["image_change_vs_base"], "0");
    assert_eq!(ab[2]["seconds"], ab[0]["seconds"]);
    // The box absorber changes the image.
    let change: f64 = ab[1]["image_change_vs_base"].parse().unwrap();
    assert!(change > 0.0 && change < 0.5, "{change}");
    assert!(
        stdout.contains("ablation  3/3 order/p1") && stdout.contains("(the render of \"base\")"),
        "{stdout}"
    );
    assert!(out.join("bias_vs_order.png").is_file());
    assert!(
        md.contains("### Ablation") && md.contains("| vacuum | absorber box |"),
        "{md}"
    );
    assert!(md.contains("bias_vs_order.png"));

    // Second run: the reference comes from the cache; only the Markdown again.
    let o = pn(&args);
    ok(&o);
    let stdout = String::from_utf8_lossy(&o.stdout);
    assert!(
        stdout.contains("cached in") && !stdout.contains("rendering into"),
        "{stdout}"
    );
    std::fs::remove_file(out.join("results.md")).unwrap();
    ok(&pn(&[
        "race",
        "--markdown-only",
        "--out",
        out.to_str().unwrap(),
    ]));
    assert!(out.join("results.md").is_file());
}

#[test]
fn bad_input_is_a_clear_error() {
    let d = work_dir("race_cli_errors");
    let out = d.join("race");
    let o = pn(&[
        "race",
        "nebula",
        "--python",
        "/nonexistent/python",
        "--out",
        out.to_str().unwrap(),
    ]);
    assert!(!o.status.success());
    assert!(String::from_utf8_lossy(&o.stderr).contains("mitsuba-venv.sh"));
    let o = pn(&["race", "nebula", "--pn-points", "p5"]);
    assert!(!o.status.success());
    assert!(String::from_utf8_lossy(&o.stderr).contains("METHOD@RES"));
    // A bad study is refused before Mitsuba is looked for, naming the file and the arm.
    std::fs::create_dir_all(&d).unwrap();
    let study = d.join("bad-study.toml");
    std::fs::write(
        &study,
        "[[arm]]\nname = \"base\"\ngroup = \"base\"\npoint = \"p3@24\"\n\
         [[arm]]\nname = \"wide\"\ngroup = \"vacuum\"\npoint = \"p3@24\"\n\
         args = [\"--set\", \"solve.nonsense=8\"]\n",
    )
    .unwrap();
    let o = pn(&[
        "race",
        "sphere",
        "--ablation-study",
        study.to_str().unwrap(),
        "--python",
        "/nonexistent/python",
    ]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(!o.status.success());
    assert!(
        err.contains("bad-study.toml")
            && err.contains("arm 2 (\"wide\")")
            && err.contains("nonsense"),
        "{err}"
    );
    std::fs::write(
        &study,
        "[[arm]]\nname = \"base\"\ngroup = \"base\"\npoint = \"p3\"\n",
    )
    .unwrap();
    let o = pn(&[
        "race",
        "sphere",
        "--ablation-study",
        study.to_str().unwrap(),
    ]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(!o.status.success());
    assert!(
        err.contains("arm 1 (\"base\")") && err.contains("METHOD@RES"),
        "{err}"
    );
    let o = pn(&[
        "race",
        "--markdown-only",
        "--out",
        d.join("none").to_str().unwrap(),
    ]);
    assert!(!o.status.success());
    assert!(String::from_utf8_lossy(&o.stderr).contains("summary.csv"));
}
