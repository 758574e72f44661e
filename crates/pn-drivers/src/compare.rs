//! `pn compare a.exr b.exr`: error metrics of image `a` against the reference `b` and a
//! false-colour difference image (`pn_runtime::render::compare`).

use pn_runtime::render::compare::compare_files;
use std::io::Write;
use std::path::PathBuf;

/// What `pn compare` compares.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct CompareRequest {
    /// The image to judge (EXR).
    pub a: PathBuf,
    /// The reference image (EXR), e.g. Mitsuba's.
    pub b: PathBuf,
    /// Folder for `difference.png` (a − b, diverging colours) and `metrics.json`.
    pub out: Option<PathBuf>,
    /// Print the metrics as JSON.
    pub json: bool,
}

/// Runs `pn compare`, printing the metrics to `stdout`.
pub fn run(args: &CompareRequest, stdout: &mut dyn Write) -> anyhow::Result<()> {
    let m = compare_files(&args.a, &args.b, args.out.as_deref())?;
    if args.json {
        writeln!(stdout, "{}", serde_json::to_string_pretty(&m)?)?;
    } else {
        writeln!(stdout, "{} against {}", args.a.display(), args.b.display())?;
        writeln!(stdout, "{m}")?;
    }
    if let Some(dir) = &args.out {
        writeln!(stdout, "wrote {}", dir.join("difference.png").display())?;
    }
    Ok(())
}
