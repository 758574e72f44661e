//! `pn export-mitsuba`: writes a render scene for Mitsuba 3 (`density.vol` and
//! `render_mitsuba.py`, computed by `pn_render::mitsuba`, written by [`crate::mitsuba`]) and, with `--run`, renders it.

use crate::mitsuba::{self, RunOptions};
use anyhow::Context;
use pn_render::mitsuba::ExportOptions;
use pn_render::{DensityFilter, RenderScene};
use std::io::Write;
use std::path::PathBuf;

/// What `pn export-mitsuba` writes (and runs).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct ExportMitsubaRequest {
    /// Scene: a TOML file or a built-in name (cloud, nebula, sphere, lowalbedo).
    pub scene: String,
    /// Output folder.
    pub out: PathBuf,
    /// Samples per pixel (default: the scene's `[render] spp`).
    pub spp: Option<usize>,
    /// Sampler seed (default: the scene's `[render] seed`).
    pub seed: Option<u64>,
    /// volpath `max_depth`: −1 = all orders of scattering, 2 = single scattering only.
    pub max_depth: i64,
    /// Density filter of the exported `gridvolume`s, overriding the scene's `[medium]
    /// filter` (`None`: the scene's).
    pub filter: Option<DensityFilter>,
    /// Also run the script (writes `OUT/mitsuba.exr`).
    pub run: bool,
    /// The Python interpreter with Mitsuba chosen by the caller (`pn`: `--python`, else
    /// `$PN_MITSUBA_PYTHON`); `None`: `.venv-mitsuba/bin/python` from
    /// `scripts/mitsuba-venv.sh` ([`mitsuba::find_python`]).
    pub python: Option<PathBuf>,
}

impl Default for ExportMitsubaRequest {
    /// The `nebula` scene into `out/mitsuba`, the scene's samples, seed and filter, all
    /// orders of scattering, not run.
    fn default() -> Self {
        Self {
            scene: "nebula".into(),
            out: PathBuf::from("out/mitsuba"),
            spp: None,
            seed: None,
            max_depth: -1,
            filter: None,
            run: false,
            python: None,
        }
    }
}

/// Runs `pn export-mitsuba`, naming the written files (and the render) on `stdout`.
pub fn run(args: &ExportMitsubaRequest, stdout: &mut dyn Write) -> anyhow::Result<()> {
    let mut scene = RenderScene::load(&args.scene)?;
    if let Some(f) = args.filter {
        scene.medium.filter = f;
    }
    let mut opts = ExportOptions::from_scene(&scene);
    opts.spp = args.spp.unwrap_or(opts.spp);
    opts.seed = args.seed.unwrap_or(opts.seed);
    opts.max_depth = args.max_depth;
    let e = mitsuba::export(&scene, &args.out, &opts)
        .with_context(|| format!("exporting {} for Mitsuba", scene.name))?;
    writeln!(
        stdout,
        "wrote {} and {} (density filter {})",
        e.density.display(),
        e.script.display(),
        e.filter
    )?;
    if args.run {
        let python = mitsuba::find_python(args.python.as_deref())?;
        let r = mitsuba::run_mitsuba_with(&e.dir, &python, &RunOptions::default())?;
        writeln!(
            stdout,
            "mitsuba: {} ({} spp, max_depth {}) in {:.2} s",
            r.image.display(),
            opts.spp,
            opts.max_depth,
            r.seconds
        )?;
    } else {
        writeln!(
            stdout,
            "render it with: {} {}",
            mitsuba::find_python(args.python.as_deref())
                .map_or_else(|_| "python3".to_string(), |p| p.display().to_string()),
            e.script.display()
        )?;
    }
    Ok(())
}
