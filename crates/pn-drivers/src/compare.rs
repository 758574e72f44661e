//! `pn compare a.exr b.exr`: error metrics of image `a` against the reference `b` and a
//! false-colour difference image (`pn_runtime::render::compare`).

use clap::Args;
use pn_runtime::render::compare::compare_files;
use std::path::PathBuf;

/// Arguments of `pn compare`.
#[derive(Args, Debug)]
pub struct CompareArgs {
    /// The image to judge (EXR).
    pub a: PathBuf,
    /// The reference image (EXR), e.g. Mitsuba's.
    pub b: PathBuf,
    /// Folder for difference.png (a − b, diverging colours) and metrics.json.
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Print the metrics as JSON.
    #[arg(long)]
    pub json: bool,
}

/// Runs `pn compare`.
pub fn run(args: &CompareArgs) -> anyhow::Result<()> {
    let m = compare_files(&args.a, &args.b, args.out.as_deref())?;
    if args.json {
        println!("{}", serde_json::to_string_pretty(&m)?);
    } else {
        println!("{} against {}", args.a.display(), args.b.display());
        println!("{m}");
    }
    if let Some(dir) = &args.out {
        println!("wrote {}", dir.join("difference.png").display());
    }
    Ok(())
}
