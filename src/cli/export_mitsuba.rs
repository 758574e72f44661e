//! `pn export-mitsuba`: its arguments.

use clap::Args;
use pn_drivers::export_mitsuba::ExportMitsubaRequest;
use pn_render::DensityFilter;
use std::path::PathBuf;

use super::Env;

/// Arguments of `pn export-mitsuba`.
#[derive(Args, Debug)]
pub struct ExportMitsubaArgs {
    /// Scene: a TOML file or a built-in name (cloud, nebula, sphere, lowalbedo).
    pub scene: String,
    /// Output folder.
    #[arg(long, default_value = "out/mitsuba")]
    pub out: PathBuf,
    /// Samples per pixel (default: the scene's [render] spp).
    #[arg(long, allow_negative_numbers = true)]
    pub spp: Option<usize>,
    /// Sampler seed (default: the scene's [render] seed).
    #[arg(long, allow_negative_numbers = true)]
    pub seed: Option<u64>,
    /// volpath max_depth: -1 = all orders of scattering, 2 = single scattering only.
    #[arg(long, default_value_t = -1, allow_negative_numbers = true)]
    pub max_depth: i64,
    /// How the gridvolumes read the voxels: trilinear (Mitsuba's default) or nearest;
    /// overrides the scene's [medium] filter.
    #[arg(long)]
    pub filter: Option<DensityFilter>,
    /// Also run the script (writes OUT/mitsuba.exr).
    #[arg(long)]
    pub run: bool,
    /// Python interpreter with Mitsuba (default: $PN_MITSUBA_PYTHON, then
    /// .venv-mitsuba/bin/python from scripts/mitsuba-venv.sh).
    #[arg(long)]
    pub python: Option<PathBuf>,
}

impl ExportMitsubaArgs {
    /// The driver's request.
    pub fn request(&self, env: &Env) -> ExportMitsubaRequest {
        ExportMitsubaRequest {
            scene: self.scene.clone(),
            out: self.out.clone(),
            spp: self.spp,
            seed: self.seed,
            max_depth: self.max_depth,
            filter: self.filter,
            run: self.run,
            python: env.python(self.python.as_deref()),
        }
    }
}
