//! Command-line input that once failed badly: negative numbers where they are valid (and a
//! clear error where they are not), and output into a pipe whose reader has gone away.
#![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)] // test code

mod support;

use std::io::Read;
use std::process::{Command, Stdio};
use support::{ok, pn, work_dir};

/// Runs a command that must fail cleanly; returns its stderr.
fn fails(args: &[&str]) -> String {
    let o = pn(args);
    let err = String::from_utf8_lossy(&o.stderr).to_string();
    assert!(!o.status.success(), "{args:?} succeeded");
    assert!(!err.contains("panicked"), "{args:?} panicked: {err}");
    err
}

/// `--g -0.5` (back scattering) is a valid value, written with a space as well as with `=`.
/// (Floating-point flags take any value after them, so `-1e-4` is a value too: clap's
/// negative-number test knows no signed exponents.)
#[test]
fn negative_values_are_accepted_where_valid() {
    let d = work_dir("cli-input-negative");
    for (i, g) in [["--g", "-0.5"], ["--g=-0.5", ""]].iter().enumerate() {
        let out = d.join(format!("g{i}"));
        let mut args = vec![
            "solve",
            "pointsource",
            "--res",
            "6",
            "--order",
            "1",
            "--out",
            out.to_str().unwrap(),
        ];
        args.extend(g.iter().filter(|a| !a.is_empty()));
        let o = pn(&args);
        ok(&o);
        assert!(out.join("report.json").is_file());
    }
    // `pn export-mitsuba --max-depth -1` (all orders) and `pn latex --order -1`'s own check.
    let e = fails(&["latex", "--order", "-1"]);
    assert!(e.contains("--order must be at least 1"), "{e}");
}

/// Negative values where they are not valid: the flag's own message, never clap's
/// "unexpected argument '-1' found".
#[test]
fn negative_values_get_the_usual_errors() {
    let cases: &[(&[&str], &str)] = &[
        (&["--sigma-t-min", "-1"], "--sigma-t-min"),
        (&["--tol", "-1"], "--tol must be positive"),
        (&["--tol", "-1e-4"], "--tol must be positive"),
        (&["--albedo", "-0.1"], "--albedo"),
        (&["--sigma-t", "-8"], "--sigma-t"),
        (&["--half-width", "-1"], "--half-width"),
        (&["--g", "-1"], "--g"),
        (&["--order", "-1"], "--order"),
        (&["--res", "-4"], "--res"),
        (&["--method", "fld", "--omega", "-0.5"], "(0, 2)"),
        (&["--method", "fld", "--sigma-eps", "-1"], "--sigma-eps"),
    ];
    for (flags, word) in cases {
        let mut args = vec!["solve", "pointsource", "--out", "/nonexistent/pn-cli-input"];
        if !flags.contains(&"--res") {
            args.extend(["--res", "4"]);
        }
        args.extend_from_slice(flags);
        let e = fails(&args);
        assert!(!e.contains("unexpected argument"), "{flags:?}: {e}");
        assert!(e.contains(word), "{flags:?}: expected {word:?} in {e}");
    }
    let e = fails(&["tradeoff", "--tol", "-1e-4", "--res", "8"]);
    assert!(e.contains("--tol values must be in (0, 1)"), "{e}");
}

/// The conventional status of a program whose stdout pipe was closed: 128 + SIGPIPE.
const BROKEN_PIPE_STATUS: i32 = 141;

/// Spawns `pn args` with stdout piped, reads `read` bytes (0: none), closes the pipe and
/// returns the exit status and stderr.
fn with_closed_stdout(args: &[&str], read: usize) -> (Option<i32>, String) {
    let mut child = Command::new(env!("CARGO_BIN_EXE_pn"))
        .args(args)
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let mut stdout = child.stdout.take().unwrap();
    let mut buf = vec![0u8; read];
    stdout.read_exact(&mut buf).unwrap();
    drop(stdout);
    let o = child.wait_with_output().unwrap();
    (
        o.status.code(),
        String::from_utf8_lossy(&o.stderr).to_string(),
    )
}

/// `pn equations --order 12 --json | head -c 20`: the output (~360 kB) is far larger than a
/// pipe's buffer, so the write after the reader left fails; `pn` ends quietly.
#[test]
fn closed_pipe_ends_quietly() {
    let (status, err) = with_closed_stdout(&["equations", "--order", "12", "--json"], 20);
    assert!(
        !err.contains("panicked") && !err.contains("Broken pipe") && err.trim().is_empty(),
        "stderr: {err}"
    );
    assert_eq!(status, Some(BROKEN_PIPE_STATUS), "stderr: {err}");

    // `pn solve … | head -1` with the reader gone before the first line: the results are
    // written, the summary is not, and nothing panics.
    let d = work_dir("cli-input-pipe");
    let out = d.join("solve");
    let (status, err) = with_closed_stdout(
        &[
            "solve",
            "checkerboard",
            "--order",
            "1",
            "--res",
            "10",
            "--out",
            out.to_str().unwrap(),
        ],
        0,
    );
    assert!(
        !err.contains("panicked") && !err.contains("Broken pipe") && !err.contains("error"),
        "stderr: {err}"
    );
    assert_eq!(status, Some(BROKEN_PIPE_STATUS), "stderr: {err}");
    assert!(out.join("report.json").is_file());
}
