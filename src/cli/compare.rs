//! `pn compare`: its arguments.

use clap::Args;
use pn_drivers::compare::CompareRequest;
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

impl CompareArgs {
    /// The driver's request.
    pub fn request(&self) -> CompareRequest {
        CompareRequest {
            a: self.a.clone(),
            b: self.b.clone(),
            out: self.out.clone(),
            json: self.json,
        }
    }
}
