//! `pn solve slab`, `pn solve milne` and `--bc marshak` from the command line
//! (docs/design.md §3, "Domain and boundary"; tests/data/marshak/README.md): the report's
//! `reflection`, `transmission` and `extrapolation_length` against the README's P_N–Marshak
//! values, the per-face `--bc` syntax and the errors for what cannot take the condition.
#![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)] // test code

use std::path::PathBuf;
use std::process::{Command, Output};

fn out_dir(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("pn-marshak-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    d
}

fn run(name: &str, args: &[&str]) -> (Output, PathBuf) {
    let dir = out_dir(name);
    let out = Command::new(env!("CARGO_BIN_EXE_pn"))
        .arg("solve")
        .args(args)
        .arg("--out")
        .arg(&dir)
        .output()
        .expect("run pn");
    (out, dir)
}

fn report(name: &str, args: &[&str]) -> serde_json::Value {
    let (out, dir) = run(name, args);
    assert!(
        out.status.success(),
        "pn solve {args:?} failed: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    let r =
        serde_json::from_str(&std::fs::read_to_string(dir.join("report.json")).unwrap()).unwrap();
    let _ = std::fs::remove_dir_all(&dir);
    r
}

fn error(name: &str, args: &[&str]) -> String {
    let (out, dir) = run(name, args);
    let _ = std::fs::remove_dir_all(&dir);
    assert!(!out.status.success(), "pn solve {args:?} succeeded");
    String::from_utf8_lossy(&out.stderr).into_owned()
}

/// The README's slab (τ = 1, c = 0.9) P_3 row to 1e-4 at the default 200 cells; the
/// report names the per-face boundary and carries the 1D reference.
#[test]
fn slab_report() {
    let r = report("slab", &["slab", "--order", "3"]);
    let (refl, trans) = (
        r["reflection"].as_f64().unwrap(),
        r["transmission"].as_f64().unwrap(),
    );
    assert!((refl - 0.26935).abs() < 1e-4, "{refl}");
    assert!((trans - 0.22541).abs() < 1e-4, "{trans}");
    assert!((r["reference_reflection"].as_f64().unwrap() - 0.26935).abs() < 1e-5);
    assert!((r["reference_transmission"].as_f64().unwrap() - 0.22541).abs() < 1e-5);
    assert_eq!(r["boundary"], "x=marshak,y=neumann,z=neumann");
    let e = &r["energy_balance"];
    assert!(e["relative_imbalance"].as_f64().unwrap() < 1e-8, "{e}");
    // Outflow = R + T per unit area (the slab is 1 wide in y).
    assert!(
        (e["boundary_outflow"].as_f64().unwrap() - refl - trans).abs() < 1e-9,
        "{e}"
    );
}

/// Other τ and albedo, and the 3D grid: the discrete values sit within 2e-4 of the 1D
/// P_N–Marshak reference the report gives.
#[test]
fn slab_other_parameters_and_3d() {
    let r = report(
        "slab3d",
        &[
            "slab", "--order", "1", "--dim", "3", "--tau", "2", "--albedo", "0.5", "--res", "100",
        ],
    );
    for k in ["reflection", "transmission"] {
        let (got, want) = (
            r[k].as_f64().unwrap(),
            r[&format!("reference_{k}")].as_f64().unwrap(),
        );
        assert!((got - want).abs() < 2e-4, "{k}: {got} vs {want}");
    }
    assert_eq!(r["dim"], 3);
}

/// Milne P_5 at the default 300 cells (h = 0.1) within 1e-3 of the README's 0.70821.
#[test]
fn milne_report() {
    let r = report("milne", &["milne", "--order", "5"]);
    let z0 = r["extrapolation_length"].as_f64().unwrap();
    assert!((z0 - 0.70821).abs() < 1e-3, "{z0}");
    assert!((r["reference_extrapolation_length"].as_f64().unwrap() - 0.70821).abs() < 1e-5);
    assert_eq!(
        r["boundary"],
        "xmin=marshak,xmax=neumann,y=neumann,z=neumann"
    );
}

/// `--bc marshak` and the per-face form on another scene: a box with vacuum faces loses
/// light (positive outflow) and balances energy.
#[test]
fn bc_marshak_on_the_checkerboard() {
    for bc in ["marshak", "x=marshak,ymax=dirichlet"] {
        let r = report(
            "cb",
            &["checkerboard", "--order", "3", "--res", "21", "--bc", bc],
        );
        let e = &r["energy_balance"];
        assert!(e["boundary_outflow"].as_f64().unwrap() > 0.0, "{bc}: {e}");
        assert!(
            e["relative_imbalance"].as_f64().unwrap() < 1e-8,
            "{bc}: {e}"
        );
        assert!(r["converged"].as_bool().unwrap());
    }
}

/// What cannot take the condition is refused with a message naming the problem.
#[test]
fn bad_input() {
    let e = error("even", &["slab", "--order", "2"]);
    assert!(
        e.contains("odd order") && e.contains("--order 1 or 3"),
        "{e}"
    );
    let e = error("mf", &["slab", "--solver", "cgnr-mf"]);
    assert!(e.contains("matrix-free"), "{e}");
    let e = error("coll", &["slab", "--collocated"]);
    assert!(e.contains("staggered"), "{e}");
    let e = error("cda", &["slab", "--method", "cda"]);
    assert!(e.contains("P_N equations only"), "{e}");
    let e = error(
        "fld",
        &["checkerboard3d", "--method", "fld", "--bc", "marshak"],
    );
    assert!(e.contains("--bc does not apply"), "{e}");
    let e = error("face", &["slab", "--bc", "w=marshak"]);
    assert!(e.contains("unknown face"), "{e}");
    let e = error("tau", &["checkerboard", "--tau", "2"]);
    assert!(e.contains("--tau only applies"), "{e}");
    let e = error("albedo", &["milne", "--albedo", "0.5"]);
    assert!(e.contains("--albedo"), "{e}");
}

/// A scene file takes the per-face form as `boundary = "..."`, and `report.json` gives it back.
#[test]
fn scene_file_boundary() {
    let dir = out_dir("toml");
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("box.toml");
    let text = std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/scenes/box.toml"))
        .unwrap()
        .replace(
            "boundary = \"dirichlet\"",
            "boundary = \"marshak,z=neumann\"",
        )
        .replace("[24, 24, 24]", "[8, 8, 8]");
    std::fs::write(&path, text).unwrap();
    let r = report("toml-run", &[path.to_str().unwrap(), "--order", "3"]);
    let _ = std::fs::remove_dir_all(&dir);
    assert_eq!(r["boundary"], "x=marshak,y=marshak,z=neumann");
    let e = &r["energy_balance"];
    assert!(e["relative_imbalance"].as_f64().unwrap() < 1e-8, "{e}");
    assert!(e["boundary_outflow"].as_f64().unwrap() > 0.0, "{e}");
}

/// `pn stencil --marshak` prints the derived conditions: P_1's zero incoming partial
/// current `L_1 + (√3/2) L_0 = 0` on every axis, N(N+1)/2 = 6 per axis for P_3 in 3D (JSON
/// too); even N is refused.
#[test]
fn stencil_prints_the_conditions() {
    let pn = |args: &[&str]| {
        Command::new(env!("CARGO_BIN_EXE_pn"))
            .arg("stencil")
            .args(args)
            .output()
            .expect("run pn")
    };
    let out = pn(&["--order", "1", "--marshak"]);
    assert!(out.status.success());
    let text = String::from_utf8_lossy(&out.stdout);
    for m in ["L_1^1", "L_1^-1", "L_1^0"] {
        assert!(
            text.contains(&format!("{m} + 0.866025403784 L_0^0 = 0")),
            "{text}"
        );
    }
    let out = pn(&["--order", "3", "--marshak", "--json"]);
    assert!(out.status.success());
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let axes = v["marshak"].as_array().unwrap();
    assert_eq!(axes.len(), 3);
    for a in axes {
        assert_eq!(a["conditions"].as_array().unwrap().len(), 6, "{a}");
    }
    let out = pn(&["--order", "2", "--marshak"]);
    assert!(!out.status.success());
    assert!(String::from_utf8_lossy(&out.stderr).contains("odd order"));
}

/// `pn solve slab --pde pdes/sp3.pde`: the PDE closes the Marshak faces with its own
/// `boundary marshak` conditions (docs/pde-text.md), and the report's R and T (the flux of
/// its L_0^0 equation through the faces) are P_3's at the same 200 cells to 1e-8 — in a slab
/// SP_3 with Marshak conditions is P_3 with Marshak conditions; `pdes/sp1.pde` gives P_1's.
/// `--bc marshak` on the 2D checkerboard runs with SP_3 and balances energy.
#[test]
fn text_pdes_close_marshak_faces_with_their_own_conditions() {
    let pdes = concat!(env!("CARGO_MANIFEST_DIR"), "/pdes");
    for (file, order) in [("sp3.pde", "3"), ("sp1.pde", "1")] {
        let pde = format!("{pdes}/{file}");
        let t = report(&format!("slab-{file}"), &["slab", "--pde", &pde]);
        let p = report(&format!("slab-p{order}"), &["slab", "--order", order]);
        for key in ["reflection", "transmission"] {
            let (a, b) = (t[key].as_f64().unwrap(), p[key].as_f64().unwrap());
            assert!((a - b).abs() < 1e-8, "{file} {key}: {a} vs P_{order} {b}");
        }
        assert!(t.get("reference_reflection").is_none(), "{t}");
        let e = &t["energy_balance"];
        assert!(e["relative_imbalance"].as_f64().unwrap() < 1e-8, "{e}");
    }
    let r = report(
        "cb-sp3",
        &[
            "checkerboard",
            "--pde",
            &format!("{pdes}/sp3.pde"),
            "--bc",
            "marshak",
            "--res",
            "31",
        ],
    );
    assert_eq!(r["boundary"], "marshak");
    let e = &r["energy_balance"];
    assert!(e["relative_imbalance"].as_f64().unwrap() < 1e-8, "{e}");
    assert!(e["boundary_outflow"].as_f64().unwrap() > 0.0, "{e}");
}

/// A text PDE without `boundary marshak` statements is refused on Marshak faces, and a bad
/// statement is reported as FILE:LINE:COLUMN.
#[test]
fn text_pde_marshak_errors() {
    let dir = out_dir("pde-files");
    std::fs::create_dir_all(&dir).unwrap();
    let plain = dir.join("plain.pde");
    std::fs::write(
        &plain,
        "unknown u = L(0,0)\nequation u: -div(1/(3*sigma_t)*grad(u)) + sigma_a*u = Q(0,0)\n",
    )
    .unwrap();
    let bad = dir.join("bad.pde");
    std::fs::write(
        &bad,
        "unknown u = L(0,0)\nequation u: -div(1/(3*sigma_t)*grad(u)) + sigma_a*u = Q(0,0)\n\
         boundary marshak w: w/2 + dn(w) = 0\n",
    )
    .unwrap();
    let e = error("plain", &["slab", "--pde", plain.to_str().unwrap()]);
    assert!(e.contains("boundary marshak"), "{e}");
    let e = error("bad", &["slab", "--pde", bad.to_str().unwrap()]);
    assert!(
        e.contains("bad.pde:3:18:") && e.contains("'w' is not an unknown"),
        "{e}"
    );
    let _ = std::fs::remove_dir_all(&dir);
}
