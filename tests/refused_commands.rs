//! Every `pn` command with a bad argument (issue 53): each must be refused before it does any
//! work, with the cause on the first line of stderr (`error: …`, nothing printed before it)
//! and exit status 1 (2 for an argument clap refuses), never a panic, and leave nothing
//! behind — no output folder, no file in the folder it ran in. The writing commands are also
//! given an output folder that cannot be made (a file in the way), which must be refused
//! before the solve, the render or the benchmark rather than after it.
#![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)] // test code

mod support;

use std::path::{Path, PathBuf};
use std::process::Command;
use support::work_dir;

/// The placeholders of a case's arguments: `OUT` (a folder that does not exist yet, inside
/// the folder the command runs in), `FILE` (a regular file, where a folder is expected),
/// `BAD` (a scene file of the wrong kind), `MISSING` (a path that does not exist).
const CASES: &[(&[&str], &str)] = &[
    (&["latex", "--order", "99"], "maximum supported order is 60"),
    (&["equations", "--order", "0"], "--order must be at least 1"),
    (&["stencil", "--order", "999"], "outside 1..=60"),
    (&["supplemental", "--out", "FILE/x"], "is not a folder"),
    (&["solve", "BAD", "--out", "OUT"], "unknown field `medium`"),
    (
        &["solve", "checkerboard", "--res", "0", "--out", "OUT"],
        "resolution must be positive",
    ),
    (
        &["solve", "checkerboard", "--out", "FILE"],
        "a file of that name is in the way",
    ),
    // Without the `distributed` feature: how to build it; with it, outside mpirun: how to
    // start it.
    (
        &["solve", "checkerboard", "--distributed", "--out", "OUT"],
        "--distributed needs",
    ),
    (
        &[
            "converge",
            "checkerboard",
            "--res",
            "8,16",
            "--distributed",
            "--out",
            "OUT",
        ],
        "pn converge does not run distributed",
    ),
    (
        &[
            "converge",
            "checkerboard",
            "--res",
            "10,20",
            "--tol",
            "0",
            "--out",
            "OUT",
        ],
        "--tol must be positive",
    ),
    (
        &[
            "converge",
            "checkerboard",
            "--res",
            "10,20",
            "--out",
            "FILE/x",
        ],
        "is not a folder",
    ),
    (
        &["bench", "--pointsource-res", "0", "--out", "OUT"],
        "--pointsource-res must be in 8..=",
    ),
    (
        &["bench", "--quick", "--reference", "MISSING", "--out", "OUT"],
        "starmap_p1_n71.csv is missing",
    ),
    (
        &["bench", "--quick", "--out", "FILE"],
        "a file of that name is in the way",
    ),
    (
        &["tradeoff", "--res", "0", "--out", "OUT"],
        "--res values must be in 8..=200",
    ),
    (
        &["tradeoff", "--quick", "--out", "FILE/x"],
        "is not a folder",
    ),
    (
        &["render", "BAD", "--out", "OUT"],
        "missing field `sigma_t_scale`",
    ),
    (
        &["render", "cloud", "--rays", "3", "--out", "OUT"],
        "must be a square number",
    ),
    (
        &["render", "cloud", "--threads", "0", "--out", "OUT"],
        "--threads",
    ),
    (&["render", "cloud", "--out", "FILE/x"], "is not a folder"),
    (
        &["figure", "cloud", "--reference", "MISSING", "--out", "OUT"],
        "cannot open",
    ),
    (
        &["figure", "cloud", "--solve-res", "0", "--out", "OUT"],
        "solve resolution must be between 1 and 4096",
    ),
    (
        &[
            "figure",
            "cloud",
            "--mitsuba",
            "--python",
            "MISSING",
            "--out",
            "OUT",
        ],
        "cannot run the Python interpreter",
    ),
    (
        &["export-mitsuba", "BAD", "--out", "OUT"],
        "missing field `sigma_t_scale`",
    ),
    (
        &["export-mitsuba", "cloud", "--out", "FILE/x"],
        "is not a folder",
    ),
    (
        &["compare", "FILE", "FILE", "--out", "OUT"],
        "cannot decode",
    ),
    (
        &[
            "race",
            "cloud",
            "--pn-points",
            "P0@16",
            "--out",
            "OUT",
            "--cache",
            "OUT-cache",
        ],
        "order 0 outside 1..=60",
    ),
    (
        &[
            "race",
            "cloud",
            "--python",
            "MISSING",
            "--out",
            "OUT",
            "--cache",
            "OUT-cache",
        ],
        "cannot run the Python interpreter",
    ),
    (
        &["race", "cloud", "--out", "OUT", "--cache", "FILE"],
        "a file of that name is in the way",
    ),
];

/// The names in `dir`, sorted.
fn listing(dir: &Path) -> Vec<String> {
    let mut v: Vec<String> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    v.sort();
    v
}

#[test]
fn every_command_refuses_a_bad_argument_at_once_and_leaves_nothing() {
    let root = work_dir("refused_commands");
    let mut commands_seen = std::collections::BTreeSet::new();
    for (k, (args, want)) in CASES.iter().enumerate() {
        let case = root.join(format!("case{k:02}"));
        let inputs = case.join("inputs");
        let cwd = case.join("cwd");
        std::fs::create_dir_all(&inputs).unwrap();
        std::fs::create_dir_all(&cwd).unwrap();
        let file = inputs.join("afile");
        std::fs::write(&file, "not a folder, not an image\n").unwrap();
        // A render scene's section in a solve scene, and a render scene without its keys.
        let bad = inputs.join("bad.toml");
        std::fs::write(&bad, "[medium]\nkind = \"nonsense\"\n").unwrap();
        let out: PathBuf = cwd.join("o");
        let path = |p: &Path| p.to_str().unwrap().to_string();
        let args: Vec<String> = args
            .iter()
            .map(|a| match *a {
                "OUT" => path(&out),
                "OUT-cache" => path(&cwd.join("cache")),
                "FILE" => path(&file),
                "FILE/x" => path(&file.join("x")),
                "BAD" => path(&bad),
                "MISSING" => path(&inputs.join("missing")),
                other => other.to_string(),
            })
            .collect();
        commands_seen.insert(args[0].clone());
        let o = Command::new(env!("CARGO_BIN_EXE_pn"))
            .args(&args)
            .current_dir(&cwd)
            .env_remove("PN_MITSUBA_PYTHON")
            .output()
            .unwrap();
        let err = String::from_utf8_lossy(&o.stderr).to_string();
        assert!(
            matches!(o.status.code(), Some(1 | 2)),
            "{args:?}: {:?}\n{err}",
            o.status
        );
        assert!(!err.contains("panicked"), "{args:?} panicked: {err}");
        let first = err.lines().next().unwrap_or("");
        assert!(
            first.starts_with("error: "),
            "{args:?}: something was printed before the refusal (work was done):\n{err}"
        );
        assert!(err.contains(want), "{args:?}: expected {want:?} in:\n{err}");
        assert!(
            listing(&cwd).is_empty(),
            "{args:?} left {:?} behind in the folder it ran in",
            listing(&cwd)
        );
        assert_eq!(listing(&inputs), ["afile", "bad.toml"], "{args:?}");
    }
    // Every subcommand of `pn --help` has a case.
    let help = Command::new(env!("CARGO_BIN_EXE_pn"))
        .arg("--help")
        .output()
        .unwrap();
    let help = String::from_utf8_lossy(&help.stdout).to_string();
    let listed: Vec<&str> = help
        .lines()
        .skip_while(|l| !l.starts_with("Commands:"))
        .skip(1)
        .take_while(|l| l.starts_with("  "))
        .filter_map(|l| l.split_whitespace().next())
        .filter(|c| *c != "help")
        .collect();
    assert!(listed.len() >= 13, "{help}");
    for c in listed {
        assert!(commands_seen.contains(c), "no refusal case for `pn {c}`");
    }
}
