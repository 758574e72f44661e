//! `pn figure`: its arguments.

use clap::Args;
use pn_lab::figure::FigureRequest;
use pn_render::scene::RendererKind;
use pn_render::{DensityFilter, SceneOverride};
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
    /// The renderer: deterministic (default; noise-free ray marching) or montecarlo.
    #[arg(long)]
    pub renderer: Option<RendererKind>,
    /// Deterministic renderer: camera rays per pixel, a square number k² (default 4).
    #[arg(long, allow_negative_numbers = true)]
    pub rays: Option<usize>,
    /// Deterministic renderer: step in units of the smallest voxel side (default 0.5).
    #[arg(long, allow_negative_numbers = true)]
    pub step: Option<f64>,
    /// Samples per pixel of the Monte Carlo renderer (default: the scene's).
    #[arg(long, allow_negative_numbers = true)]
    pub spp: Option<usize>,
    /// How density voxels are read: trilinear (Mitsuba's default) or nearest; overrides the
    /// scene's [medium] filter.
    #[arg(long)]
    pub filter: Option<DensityFilter>,
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
    #[arg(long, allow_negative_numbers = true, value_parser = super::parse_threads)]
    pub threads: Option<usize>,
    /// Override a key of the scene's TOML before it is checked, as `pn render --set`
    /// (repeatable): `--set solve.margin=8`.
    #[arg(
        long = "set",
        value_name = "SECTION.KEY=VALUE",
        allow_hyphen_values = true
    )]
    pub set: Vec<SceneOverride>,
}

impl FigureArgs {
    /// The driver's request.
    pub fn request(&self, env: &Env) -> FigureRequest {
        FigureRequest {
            scene: self.scene.clone(),
            out: self.out.clone(),
            spp: self.spp,
            renderer: self.renderer,
            rays: self.rays,
            step: self.step,
            filter: self.filter,
            solve_res: self.solve_res,
            reference: self.reference.clone(),
            mitsuba: self.mitsuba,
            mitsuba_spp: self.mitsuba_spp,
            python: env.python(self.python.as_deref()),
            threads: self.threads,
            set: self.set.clone(),
            tuning: env.tuning.clone(),
        }
    }
}
