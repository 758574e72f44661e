//! `pn export-mitsuba`: writes a render scene for Mitsuba 3 (`density.vol` and
//! `render_mitsuba.py`, see `pn_runtime::render::mitsuba`) and, with `--run`, renders it.

use anyhow::Context;
use clap::Args;
use pn_runtime::render::mitsuba::{self, ExportOptions, RunOptions};
use pn_runtime::render::RenderScene;
use std::path::PathBuf;

/// Arguments of `pn export-mitsuba`.
#[derive(Args, Debug)]
pub struct ExportMitsubaArgs {
    /// Scene: a TOML file or a built-in name (cloud, nebula, sphere, lowalbedo).
    pub scene: String,
    /// Output folder.
    #[arg(long, default_value = "out/mitsuba")]
    pub out: PathBuf,
    /// Samples per pixel (default: the scene's [render] spp).
    #[arg(long)]
    pub spp: Option<usize>,
    /// Sampler seed (default: the scene's [render] seed).
    #[arg(long)]
    pub seed: Option<u64>,
    /// volpath max_depth: -1 = all orders of scattering, 2 = single scattering only.
    #[arg(long, default_value_t = -1, allow_negative_numbers = true)]
    pub max_depth: i64,
    /// Also run the script (writes OUT/mitsuba.exr).
    #[arg(long)]
    pub run: bool,
    /// Python interpreter with Mitsuba (default: $PN_MITSUBA_PYTHON, then
    /// .venv-mitsuba/bin/python from scripts/mitsuba-venv.sh).
    #[arg(long)]
    pub python: Option<PathBuf>,
}

/// Runs `pn export-mitsuba`.
pub fn run(args: &ExportMitsubaArgs) -> anyhow::Result<()> {
    let scene = RenderScene::load(&args.scene)?;
    let mut opts = ExportOptions::from_scene(&scene);
    opts.spp = args.spp.unwrap_or(opts.spp);
    opts.seed = args.seed.unwrap_or(opts.seed);
    opts.max_depth = args.max_depth;
    let e = mitsuba::export(&scene, &args.out, &opts)
        .with_context(|| format!("exporting {} for Mitsuba", scene.name))?;
    println!("wrote {} and {}", e.density.display(), e.script.display());
    if args.run {
        let python = mitsuba::find_python(args.python.as_deref())?;
        let r = mitsuba::run_mitsuba_with(&e.dir, &python, &RunOptions::default())?;
        println!(
            "mitsuba: {} ({} spp, max_depth {}) in {:.2} s",
            r.image.display(),
            opts.spp,
            opts.max_depth,
            r.seconds
        );
    } else {
        println!(
            "render it with: {} {}",
            mitsuba::find_python(args.python.as_deref())
                .map_or_else(|_| "python3".to_string(), |p| p.display().to_string()),
            e.script.display()
        );
    }
    Ok(())
}
