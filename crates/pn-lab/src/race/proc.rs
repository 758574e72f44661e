//! Timed subprocesses with errors that carry the command and its stderr tail.

use anyhow::{bail, Context, Result};
use std::process::Command;
use std::time::Instant;

/// The wall time and standard output of a finished process.
#[derive(Clone, Debug)]
pub struct Timed {
    /// Seconds from spawning the process to its exit.
    pub wall: f64,
    /// Its standard output.
    pub stdout: String,
}

/// The last `n` lines of `text`.
pub fn tail(text: &str, n: usize) -> String {
    let lines: Vec<&str> = text.trim_end().lines().collect();
    lines[lines.len().saturating_sub(n)..].join("\n")
}

/// Runs `cmd` to completion, timing it; a failure is an error naming `what`, the command
/// line and the last 20 lines of its stderr.
pub fn run_timed(cmd: &mut Command, what: &str) -> Result<Timed> {
    let line = format!(
        "{} {}",
        cmd.get_program().to_string_lossy(),
        cmd.get_args()
            .map(|a| a.to_string_lossy().into_owned())
            .collect::<Vec<_>>()
            .join(" ")
    );
    let t = Instant::now();
    let out = cmd
        .output()
        .with_context(|| format!("{what}: cannot start `{line}`"))?;
    let wall = t.elapsed().as_secs_f64();
    if !out.status.success() {
        bail!(
            "{what} failed ({}): `{line}`\n{}",
            out.status,
            tail(&String::from_utf8_lossy(&out.stderr), 20)
        );
    }
    Ok(Timed {
        wall,
        stdout: String::from_utf8_lossy(&out.stdout).into_owned(),
    })
}
