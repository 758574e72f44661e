//! `pn figure`: its arguments.

use clap::Args;
use pn_drivers::figure::FigureRequest;
use std::path::PathBuf;

use super::Env;

/// Arguments of `pn figure`.
#[derive(Args, Debug, Clone)]
pub struct FigureArgs {
    /// The scene: a built-in name (default nebula) or a .toml file.
    #[arg(default_value = "nebula")]
    pub scene: String,
    /// Output directory (default out/figure-<scene>).
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Samples per pixel (default: the scene's).
    #[arg(long, allow_negative_numbers = true)]
    pub spp: Option<usize>,
    /// Solve-grid cells per axis across the medium box (default: the scene's).
    #[arg(long, allow_negative_numbers = true)]
    pub solve_res: Option<usize>,
    /// Mitsuba reference EXR (default: <out>/mitsuba.exr when it exists).
    #[arg(long)]
    pub reference: Option<PathBuf>,
    /// Export the scene and render the reference with Mitsuba first (needs a Python with
    /// the `mitsuba` package: --python or PN_MITSUBA_PYTHON or the venv of
    /// scripts/mitsuba-venv.sh).
    #[arg(long)]
    pub mitsuba: bool,
    /// Samples per pixel of the Mitsuba reference (with --mitsuba; default 1024).
    #[arg(long, default_value_t = 1024, allow_negative_numbers = true)]
    pub mitsuba_spp: usize,
    /// Python interpreter for --mitsuba.
    #[arg(long)]
    pub python: Option<PathBuf>,
    /// Worker threads (default: all cores).
    #[arg(long, allow_negative_numbers = true)]
    pub threads: Option<usize>,
}

impl FigureArgs {
    /// The driver's request.
    pub fn request(&self, env: &Env) -> FigureRequest {
        FigureRequest {
            scene: self.scene.clone(),
            out: self.out.clone(),
            spp: self.spp,
            solve_res: self.solve_res,
            reference: self.reference.clone(),
            mitsuba: self.mitsuba,
            mitsuba_spp: self.mitsuba_spp,
            python: env.python(self.python.as_deref()),
            threads: self.threads,
            tuning: env.tuning.clone(),
        }
    }
}
