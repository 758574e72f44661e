//! Malformed input that once aborted, ran out of memory or did expensive work before it was
//! refused (issue 53): deep nesting and huge flat sums in text PDEs, moment orders beyond
//! the supported range, race points checked after Mitsuba, volume files that are streams,
//! absurd thread counts and an export that left a file behind. Each must end with a clear
//! one-line cause and exit status 1 (2 for a refused argument), never a panic or an abort, and leave no output behind.
#![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)] // test code

mod support;

use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};
use support::{ok, pn, work_dir};

/// Runs `pn args`, which must fail with status 1 (an error, not an abort or a signal) and a
/// message containing every one of `want`; returns stderr.
fn refused(args: &[&str], want: &[&str]) -> String {
    let o = pn(args);
    let err = String::from_utf8_lossy(&o.stderr).to_string();
    // 1: a refused command; 2: a refused argument (clap).
    assert!(
        matches!(o.status.code(), Some(1 | 2)),
        "{args:?}: {:?} {err}",
        o.status
    );
    assert!(!err.contains("panicked"), "{args:?} panicked: {err}");
    for w in want {
        assert!(err.contains(w), "{args:?}: expected {w:?} in {err}");
    }
    err
}

fn write(dir: &Path, name: &str, text: &str) -> PathBuf {
    std::fs::create_dir_all(dir).unwrap();
    let p = dir.join(name);
    std::fs::write(&p, text).unwrap();
    p
}

/// A solve with the PDE `file` (3D point source or the 2D checkerboard).
fn solve_pde<'a>(scene: &'a str, file: &'a Path, out: &'a Path) -> Vec<&'a str> {
    vec![
        "solve",
        scene,
        "--res",
        "6",
        "--pde",
        file.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
        "--threads",
        "1",
    ]
}

/// 2,000 nested parentheses, 10,000 nested calls, 10,000 signs and 10,000 nested `for`
/// statements: a nesting limit, named with the file, line and column, not a stack overflow.
#[test]
fn deep_nesting_in_a_text_pde_is_a_clear_error() {
    let d = work_dir("bounded-nesting");
    let head = "unknown u = L(0,0)\n";
    let cases = [
        (
            "parens",
            format!(
                "{head}equation u: -lap(u) + sigma_a*u = {}Q(0,0){}\n",
                "(".repeat(2000),
                ")".repeat(2000)
            ),
        ),
        (
            "calls",
            format!(
                "{head}equation u: -lap(u) + sigma_a*u = Q(0,0) * {}1{}\n",
                "abs(".repeat(10_000),
                ")".repeat(10_000)
            ),
        ),
        (
            "signs",
            format!(
                "{head}equation u: -lap(u) + sigma_a*u = {}Q(0,0)\n",
                "- ".repeat(10_000)
            ),
        ),
        (
            "powers",
            format!(
                "{head}equation u: -lap(u) + sigma_a*u = Q(0,0) * {}1\n",
                "1^".repeat(10_000)
            ),
        ),
        (
            "loops",
            format!(
                "{head}{}equation u: -lap(u) + sigma_a*u = Q(0,0)\n",
                "for k = 0..0: ".repeat(10_000)
            ),
        ),
    ];
    for (name, src) in cases {
        let f = write(&d, &format!("{name}.pde"), &src);
        let e = refused(
            &solve_pde("pointsource", &f, &d.join("out")),
            &[&format!("{name}.pde:2:"), "nested more than 100 levels"],
        );
        assert_eq!(e.trim().lines().count(), 1, "{name}: {e}");
    }
    assert!(!d.join("out").exists());
}

/// A 5 MB equation, a flat sum of 100,000 terms (each 1/100000 of the source), solves like
/// the one term it adds up to: neither the parser nor the lowering recurses per term.
#[test]
fn a_flat_sum_of_100000_terms_solves() {
    let d = work_dir("bounded-flat-sum");
    let mut src = String::from("unknown u = L(0,0)\nequation u: -lap(u)/3 + sigma_a*u = ");
    for i in 0..100_000 {
        if i > 0 {
            src += " + ";
        }
        src += "0.0000100000*Q(0,0)*(sigma_t/sigma_t)*(sigma_a/sigma_a)";
    }
    src += "\n";
    assert!(src.len() > 5_000_000, "{}", src.len());
    let f = write(&d, "flat.pde", &src);
    let out = d.join("out");
    let o = pn(&solve_pde("pointsource", &f, &out));
    ok(&o);
    let report: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("report.json")).unwrap()).unwrap();
    assert_eq!(report["converged"], true);
}

/// Orders above 60 (where the solver's orders stop) are refused in 3D and in 2D, where an
/// odd l + m once dropped the moment silently; L(99999, 0) once asked for 40 TB.
#[test]
fn moment_orders_beyond_the_supported_range_are_refused() {
    let d = work_dir("bounded-orders");
    for (i, (l, use_q)) in [(99999, false), (61, false), (61, true)].iter().enumerate() {
        let src = if *use_q {
            format!("unknown u = L(0,0)\nequation u: -lap(u) + sigma_a*u = Q({l},0)\n")
        } else {
            format!("unknown u = L({l},0)\nequation u: -lap(u) + sigma_a*u = Q(0,0)\n")
        };
        let f = write(&d, &format!("o{i}.pde"), &src);
        for scene in ["pointsource", "checkerboard"] {
            refused(
                &solve_pde(scene, &f, &d.join("out")),
                &[
                    &format!("o{i}.pde:"),
                    &format!("the order l = {l} is above the largest supported, 60"),
                ],
            );
        }
    }
    let f = write(
        &d,
        "phase.pde",
        "unknown u = L(0,0)\nequation u: -lap(u) + sigma_a*phase(1000000)*u = Q(0,0)\n",
    );
    refused(
        &solve_pde("pointsource", &f, &d.join("out")),
        &["phase.pde:2:", "above the largest supported order"],
    );
    assert!(!d.join("out").exists());
}

/// `pn race` checks its points (a text PDE's parameters and syntax), scenes and output
/// path before it looks for Mitsuba (with it installed, the references would come first
/// and take minutes), and a refusal leaves no output folder.
#[test]
fn race_checks_points_and_scenes_before_mitsuba() {
    let d = work_dir("bounded-race");
    let fpn = Path::new(env!("CARGO_MANIFEST_DIR")).join("pdes/fpn.pde");
    let fpn = fpn.to_str().unwrap();
    let unclosed = write(
        &d,
        "unclosed.pde",
        "unknown u = L(0,0)\nequation u: -lap(u) + sigma_a*u = (Q(0,0)\n",
    );
    let unclosed = format!("{}@8", unclosed.display());
    let out = d.join("race/out");
    let cases: Vec<(String, Vec<&str>)> = vec![
        (
            format!("{fpn}@8:N=-1"),
            vec!["fpn.pde", "N = -1 is outside"],
        ),
        (
            format!("{fpn}@8:N=1e9"),
            vec!["fpn.pde", "N = 1000000000 is outside"],
        ),
        (unclosed.clone(), vec!["unclosed.pde:2:", "unclosed '('"]),
    ];
    for (point, want) in &cases {
        let mut want = want.clone();
        want.push("pn point");
        let e = refused(
            &[
                "race",
                "sphere",
                "--pn-points",
                point,
                "--python",
                "/nonexistent/python",
                "--out",
                out.to_str().unwrap(),
            ],
            &want,
        );
        assert!(
            !e.contains("mitsuba-venv.sh"),
            "Mitsuba looked for first: {e}"
        );
        assert!(
            !d.join("race").exists(),
            "{point}: an output folder was left"
        );
    }
    // A scene file that does not parse, and one that does not exist.
    let bad = write(&d, "bad-scene.toml", "[medium]\nkind = 7\n");
    for scene in [bad.to_str().unwrap(), "no/such/scene.toml"] {
        let e = refused(
            &[
                "race",
                scene,
                "--python",
                "/nonexistent/python",
                "--out",
                out.to_str().unwrap(),
            ],
            &["race on"],
        );
        assert!(!e.contains("mitsuba-venv.sh"), "{e}");
    }
    // An output path under a file; and with good input, the Mitsuba refusal leaves no folder.
    let file = write(&d, "a-file", "x");
    refused(
        &[
            "race",
            "sphere",
            "--python",
            "/nonexistent/python",
            "--out",
            file.join("out").to_str().unwrap(),
        ],
        &["cannot create"],
    );
    refused(
        &[
            "race",
            "sphere",
            "--python",
            "/nonexistent/python",
            "--out",
            out.to_str().unwrap(),
        ],
        &["mitsuba-venv.sh"],
    );
    assert!(!d.join("race").exists());
}

/// A grid medium of `file` in a tiny render scene.
fn grid_scene(dir: &Path, name: &str, file: &str) -> PathBuf {
    write(
        dir,
        name,
        &format!(
            "[medium]\nkind = \"grid\"\nfile = \"{file}\"\nsigma_t_scale = 1.0\nalbedo = 0.9\n\
             [[light]]\nkind = \"directional\"\ndirection = [0.0, -1.0, 0.0]\nirradiance = 1.0\n\
             [camera]\nposition = [0.0, 0.0, 4.0]\ntarget = [0.0, 0.0, 0.0]\n\
             up = [0.0, 1.0, 0.0]\nfov = 40.0\nwidth = 8\nheight = 8\n"
        ),
    )
}

/// A volume file that is a stream (`/dev/zero`, under a `.vol`, `.npy` or `.vdb` name) is
/// refused at once instead of read until memory ends; so is a scene or PDE file that is
/// one; a header that declares more data than the file has is refused before any is read.
#[test]
fn streams_and_lying_headers_are_refused_at_once() {
    let d = work_dir("bounded-streams");
    std::fs::create_dir_all(&d).unwrap();
    let out = d.join("out");
    for ext in ["vol", "npy", "vdb"] {
        let link = d.join(format!("zero.{ext}"));
        std::os::unix::fs::symlink("/dev/zero", &link).unwrap();
        let scene = grid_scene(&d, &format!("zero-{ext}.toml"), link.to_str().unwrap());
        let t = Instant::now();
        refused(
            &[
                "render",
                scene.to_str().unwrap(),
                "--out",
                out.to_str().unwrap(),
            ],
            &["not a regular file"],
        );
        assert!(
            t.elapsed() < Duration::from_secs(3),
            "{ext}: {:?}",
            t.elapsed()
        );
    }
    let zero_scene = d.join("zero.toml");
    std::os::unix::fs::symlink("/dev/zero", &zero_scene).unwrap();
    let zero_pde = d.join("zero.pde");
    std::os::unix::fs::symlink("/dev/zero", &zero_pde).unwrap();
    let t = Instant::now();
    refused(
        &[
            "render",
            zero_scene.to_str().unwrap(),
            "--out",
            out.to_str().unwrap(),
        ],
        &["not a regular file"],
    );
    refused(
        &solve_pde("pointsource", &zero_pde, &out),
        &["not a regular file"],
    );
    assert!(t.elapsed() < Duration::from_secs(3), "{:?}", t.elapsed());
    // A .vol header of 2³⁰ voxels on a file of 48 bytes, and an .npy shape likewise.
    let mut vol = b"VOL\x03".to_vec();
    for v in [1i32, 1024, 1024, 1024, 1] {
        vol.extend(v.to_le_bytes());
    }
    for v in [-1.0f32, -1.0, -1.0, 1.0, 1.0, 1.0] {
        vol.extend(v.to_le_bytes());
    }
    std::fs::write(d.join("huge.vol"), &vol).unwrap();
    let scene = grid_scene(&d, "huge-vol.toml", d.join("huge.vol").to_str().unwrap());
    refused(
        &[
            "render",
            scene.to_str().unwrap(),
            "--out",
            out.to_str().unwrap(),
        ],
        &["header says 1024×1024×1024"],
    );
    let header = "{'descr': '<f8', 'fortran_order': False, 'shape': (4096, 4096, 4096), }";
    let mut npy = b"\x93NUMPY\x01\x00".to_vec();
    npy.extend((header.len() as u16).to_le_bytes());
    npy.extend(header.as_bytes());
    std::fs::write(d.join("huge.npy"), &npy).unwrap();
    let scene = grid_scene(&d, "huge-npy.toml", d.join("huge.npy").to_str().unwrap());
    refused(
        &[
            "render",
            scene.to_str().unwrap(),
            "--out",
            out.to_str().unwrap(),
        ],
        &["shape [4096, 4096, 4096] needs"],
    );
    assert!(!out.exists());
}

/// `--threads 1000000` is refused against the machine before a thread starts.
#[test]
fn absurd_thread_counts_are_refused_at_once() {
    let d = work_dir("bounded-threads");
    let out = d.join("out");
    let t = Instant::now();
    for cmd in [
        vec!["solve", "pointsource", "--res", "4"],
        vec!["render", "sphere"],
    ] {
        let mut args = cmd.clone();
        args.extend(["--threads", "1000000", "--out", out.to_str().unwrap()]);
        refused(
            &args,
            &["--threads 1000000 is more than this machine can use"],
        );
    }
    assert!(t.elapsed() < Duration::from_secs(3), "{:?}", t.elapsed());
    assert!(!out.exists());
}

/// `pn export-mitsuba` that cannot write its script writes nothing (once it left a 1 MB
/// `density.vol`); into a folder it would create, it leaves no folder.
#[test]
fn export_mitsuba_writes_all_or_nothing() {
    let d = work_dir("bounded-export");
    let out = d.join("export");
    std::fs::create_dir_all(out.join("render_mitsuba.py")).unwrap();
    refused(
        &[
            "export-mitsuba",
            "lowalbedo",
            "--out",
            out.to_str().unwrap(),
        ],
        &["render_mitsuba.py"],
    );
    let left: Vec<_> = std::fs::read_dir(&out)
        .unwrap()
        .map(|e| e.unwrap().file_name())
        .collect();
    assert_eq!(left, vec![std::ffi::OsString::from("render_mitsuba.py")]);
    let file = write(&d, "a-file", "x");
    refused(
        &[
            "export-mitsuba",
            "lowalbedo",
            "--out",
            file.join("sub/export").to_str().unwrap(),
        ],
        &["cannot create"],
    );
    assert!(!file.join("sub").exists());
}

/// Found by the fuzzer: definitions substituted into each other multiplied the nesting (64
/// `let`s of 95 signs each overflowed the stack), and nested derivatives made the
/// discretization's terms double each time (`dx` 30 deep never finished). Both are refused
/// with their position; just under the nesting limit still solves.
#[test]
fn definitions_and_derivatives_cannot_nest_without_bound() {
    let d = work_dir("bounded-lets");
    let chain = |wrap: &dyn Fn(&str) -> String, n: usize| {
        let mut s = String::from("unknown u = L(0,0)\nlet a0 = 2\n");
        for i in 1..n {
            s += &format!("let a{i} = {}\n", wrap(&format!("a{}", i - 1)));
        }
        s + &format!(
            "equation u: -lap(u) + sigma_a*u*a{}*a{} = Q(0,0)\n",
            n - 1,
            n - 1
        )
    };
    let signs = |x: &str| format!("{}{x}", "-".repeat(95));
    let calls = |x: &str| format!("{}{x}{}", "abs(".repeat(95), ")".repeat(95));
    for (name, src) in [("signs", chain(&signs, 64)), ("calls", chain(&calls, 64))] {
        let f = write(&d, &format!("{name}.pde"), &src);
        refused(
            &solve_pde("pointsource", &f, &d.join("out")),
            &[&format!("{name}.pde:"), "nests more than 200 levels deep"],
        );
    }
    let f = write(
        &d,
        "dx.pde",
        &format!(
            "unknown u = L(0,0)\nequation u: -lap(u) + sigma_a*u + 0.001*{}u{} = Q(0,0)\n",
            "dx(".repeat(30),
            ")".repeat(30)
        ),
    );
    let t = Instant::now();
    refused(
        &solve_pde("pointsource", &f, &d.join("out")),
        &[
            "dx.pde:2:",
            "derivatives nested 9 deep, more than the 8 supported",
        ],
    );
    assert!(t.elapsed() < Duration::from_secs(10), "{:?}", t.elapsed());
    // Two definitions of 95 levels each: 190 levels, under the limit, solve.
    let f = write(&d, "near.pde", &chain(&calls, 3));
    ok(&pn(&solve_pde("pointsource", &f, &d.join("near"))));
}

/// Found by the fuzzer: a 410-byte EXR whose data window is 2¹⁸ times wider than its display
/// window took 3.4 GB and 16 s to decode; its header is checked first now.
#[test]
fn an_exr_data_window_is_checked_before_decoding() {
    let exr =
        Path::new(env!("CARGO_MANIFEST_DIR")).join("fuzz/regressions/exr/huge-data-window.exr");
    let d = work_dir("bounded-exr");
    let t = Instant::now();
    refused(
        &[
            "compare",
            exr.to_str().unwrap(),
            exr.to_str().unwrap(),
            "--out",
            d.join("out").to_str().unwrap(),
        ],
        &["an EXR data window of -218103807×2 pixels"],
    );
    assert!(t.elapsed() < Duration::from_secs(3), "{:?}", t.elapsed());
    assert!(!d.join("out").exists());
}

/// A procedural medium whose optical-depth grids would not fit is refused with their size
/// before a ray is traced (the estimate is the lattices' exact size; docs/stability.md).
#[test]
fn optical_depth_grids_beyond_the_memory_limit_are_refused_with_their_size() {
    let out = work_dir("bounded_light_depth");
    let err = refused(
        &[
            "render",
            "cloud",
            "--set",
            "medium.resolution=[256,256,256]",
            "--set",
            "solve.resolution=[8,8,8]",
            "--max-memory",
            "100M",
            "--out",
            out.to_str().unwrap(),
        ],
        &[
            "optical depth to the 1 light over the 256×256×256 medium voxels needs about",
            "GiB",
            "100.00 MiB",
        ],
    );
    assert!(err.starts_with("error: "), "{err}");
    assert!(!out.exists());
}

/// A file of `len` bytes that takes no disk (sparse): a huge input for the size checks.
fn sparse_file(path: &Path, len: u64) {
    std::fs::File::create(path).unwrap().set_len(len).unwrap();
}

/// Per parser, deep nesting and a huge input: scene TOML (render and solve scenes, from a
/// file and through `--set`), text PDEs, `.npy` headers and images (the volume files' huge
/// and streamed inputs are `streams_and_lying_headers_are_refused_at_once`'s, the text
/// PDEs' deep nesting `deep_nesting_in_a_text_pde_is_a_clear_error`'s). Each refused at
/// once with its cause, never a stack overflow or a read of the whole input.
#[test]
fn every_parser_refuses_deep_nesting_and_huge_input() {
    let d = work_dir("bounded-per-parser");
    std::fs::create_dir_all(&d).unwrap();
    let out = d.join("out");
    let o = out.to_str().unwrap();
    let t = Instant::now();
    // Scene TOML: 100,000 nested arrays, and 100,000 nested inline tables.
    let n = 100_000;
    let arrays = write(
        &d,
        "arrays.toml",
        &format!("[medium]\nx = {}{}\n", "[".repeat(n), "]".repeat(n)),
    );
    let tables = write(
        &d,
        "tables.toml",
        &format!("a = {}1{}\n", "{b=".repeat(n), "}".repeat(n)),
    );
    for scene in [&arrays, &tables] {
        let s = scene.to_str().unwrap();
        refused(&["render", s, "--out", o], &["recursion limit exceeded"]);
        refused(&["solve", s, "--out", o], &["recursion limit exceeded"]);
    }
    // `--set` values are TOML too.
    let deep = format!("medium.x={}{}", "[".repeat(20_000), "]".repeat(20_000));
    refused(
        &["render", "cloud", "--set", &deep, "--out", o],
        &["is not valid TOML: recursion limit exceeded"],
    );
    // Scene and PDE files beyond the text inputs' 64 MiB, refused by their size.
    let huge_scene = d.join("huge.toml");
    sparse_file(&huge_scene, (64 << 20) + 1);
    let huge_pde = d.join("huge.pde");
    sparse_file(&huge_pde, (64 << 20) + 1);
    refused(
        &["render", huge_scene.to_str().unwrap(), "--out", o],
        &["more than the 64 MiB a text input may have"],
    );
    refused(
        &["solve", huge_scene.to_str().unwrap(), "--out", o],
        &["more than the 64 MiB a text input may have"],
    );
    refused(
        &solve_pde("pointsource", &huge_pde, &out),
        &["more than the 64 MiB a text input may have"],
    );
    // An .npy header of 100,000 nested parentheses.
    let header = format!(
        "{{'descr': '<f8', 'fortran_order': False, 'shape': {}{}, }}",
        "(".repeat(n),
        ")".repeat(n)
    );
    let mut npy = b"\x93NUMPY\x02\x00".to_vec();
    npy.extend((header.len() as u32).to_le_bytes());
    npy.extend(header.as_bytes());
    std::fs::write(d.join("deep.npy"), &npy).unwrap();
    let scene = grid_scene(&d, "deep-npy.toml", d.join("deep.npy").to_str().unwrap());
    refused(
        &["render", scene.to_str().unwrap(), "--out", o],
        &["invalid .npy file"],
    );
    // Images (`pn compare`, environment maps): a stream, and a huge file that is no image.
    let zero = d.join("zero.exr");
    std::os::unix::fs::symlink("/dev/zero", &zero).unwrap();
    let z = zero.to_str().unwrap();
    refused(&["compare", z, z], &["not a regular file"]);
    let huge_exr = d.join("huge.exr");
    sparse_file(&huge_exr, 1 << 40);
    let h = huge_exr.to_str().unwrap();
    refused(&["compare", h, h], &["cannot decode", "as an image"]);
    assert!(t.elapsed() < Duration::from_secs(20), "{:?}", t.elapsed());
    assert!(!out.exists());
}
