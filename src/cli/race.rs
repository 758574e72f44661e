//! `pn race`: its arguments.

use anyhow::Context;
use clap::Args;
use pn_lab::race::{parse_points, RaceRequest};
use std::path::PathBuf;

use super::Env;

/// Arguments of `pn race`.
#[derive(Args, Debug, Clone)]
pub struct RaceArgs {
    /// Scene files (.toml) or built-in scenes (cloud, nebula, …); each gets its own folder.
    #[arg(required_unless_present = "markdown_only")]
    pub scenes: Vec<String>,
    /// Output folder: per scene points.csv, error_time.png, crossings.txt, single_scatter.csv,
    /// turntable.csv (and ablation.csv); for all summary.csv and results.md (and
    /// bias_vs_order.png).
    #[arg(long, default_value = "out/race")]
    pub out: PathBuf,
    /// Reference cache folder (default out/race-cache).
    #[arg(long)]
    pub cache: Option<PathBuf>,
    /// Python interpreter with mitsuba and pyoidn (default $PN_MITSUBA_PYTHON, else
    /// .venv-mitsuba/bin/python; create it with scripts/mitsuba-venv.sh).
    #[arg(long)]
    pub python: Option<PathBuf>,
    /// Reference spp in all, as two halves with different seeds (default 4096; 64 with --quick).
    #[arg(long, allow_negative_numbers = true)]
    pub reference_spp: Option<usize>,
    /// Mitsuba spp ladder, comma separated (default 1,4,16,64,256; 1,4 with --quick).
    #[arg(long, value_delimiter = ',', allow_negative_numbers = true)]
    pub mitsuba_spp: Option<Vec<usize>>,
    /// The Mitsuba spp whose error the crossing points refer to (default 64).
    #[arg(long, allow_negative_numbers = true)]
    pub target_spp: Option<usize>,
    /// Skip the denoised Mitsuba curve.
    #[arg(long)]
    pub no_denoise: bool,
    /// pn points METHOD@RES[:rays=K][:step=S], comma separated: cda@24, p5@32:rays=1, …
    /// (pop@20: POP with a 20-cell grid, 20 iterations and a 20-cell solve grid; a text PDE
    /// as FILE.pde@RES[:NAME=VALUE…], e.g. pdes/sp3.pde@16, pdes/fpn.pde@16:N=5)
    /// (default cda, P_1, P_3 at
    /// 16,24,32,48, P_5 at 16,24,32 and P_7 at 16,24; p1@16 with --quick).
    #[arg(long)]
    pub pn_points: Option<String>,
    /// Extra `pn render` arguments for every pn render, in one string (e.g. "--spp 16").
    #[arg(long, allow_hyphen_values = true, default_value = "")]
    pub render_args: String,
    /// Turntable views (0: no turntable; default 16, 2 with --quick).
    #[arg(long, allow_negative_numbers = true)]
    pub turntable: Option<usize>,
    /// The pn point of the turntable (default: the fastest reaching the target error).
    #[arg(long)]
    pub turntable_point: Option<String>,
    /// Skip the single-scattering comparison.
    #[arg(long)]
    pub no_single_scatter: bool,
    /// Run an ablation study on every scene after its race: each arm changes one suspected
    /// cause of pn's bias (vacuum treatment, P_N order, solve resolution, quadrature, density
    /// filter, solution lookup) and is judged against the scene's Mitsuba reference; per scene ablation.csv
    /// (bias, relative RMSE, and their change against the base arm), for all
    /// bias_vs_order.png, an Ablation section in results.md. Without --ablation-study, the
    /// built-in study (crates/pn-lab/src/race/default_study.toml: 22 arms, 20 renders
    /// per scene). Replaces the former four-step ablation: --ablation-base, --ablation-res,
    /// --ablation-order and --ablation-fine-args are gone (write the arms in a study file).
    /// Example: pn race cloud scenes/puff.toml --ablation --out out/ablation.
    #[arg(long)]
    pub ablation: bool,
    /// The ablation study: a TOML file of [[arm]] tables with name, group, point (a pn point,
    /// e.g. p3@24 or p5@32:rays=16) and optional args (more `pn render` arguments, e.g.
    /// ["--set", "solve.margin=8"]); the first arm of group "base" is the base. Implies
    /// --ablation.
    #[arg(long, value_name = "FILE")]
    pub ablation_study: Option<PathBuf>,
    /// A small smoke run: 64-spp reference, Mitsuba at 1 and 4 spp, one pn point, 2 views.
    #[arg(long)]
    pub quick: bool,
    /// Worker threads of the pn renders (default: all cores).
    #[arg(long, allow_negative_numbers = true, value_parser = super::parse_threads)]
    pub threads: Option<usize>,
    /// Time every Mitsuba and pn point K times and keep the run with the median wall time
    /// (the images are the same each time): steadier numbers on a shared machine.
    #[arg(long, default_value_t = 1, value_name = "K")]
    pub repeat: usize,
    /// Only rewrite results.md from the CSV files in --out.
    #[arg(long)]
    pub markdown_only: bool,
    /// Keep <out>/<scene>/work/ (the export, every image and render) after each scene.
    #[arg(long)]
    pub keep_work: bool,
}

fn words(s: &str) -> Vec<String> {
    s.split_whitespace().map(str::to_string).collect()
}

impl RaceArgs {
    /// The driver's request (the pn points run this very binary).
    pub fn request(&self, env: &Env) -> anyhow::Result<RaceRequest> {
        let one = |s: &Option<String>, flag: &str| -> anyhow::Result<_> {
            s.as_deref()
                .map(|t| {
                    let mut v = parse_points(t).with_context(|| format!("--{flag}"))?;
                    anyhow::ensure!(v.len() == 1, "--{flag} takes one point, got {t:?}");
                    Ok(v.remove(0))
                })
                .transpose()
        };
        Ok(RaceRequest {
            scenes: self.scenes.clone(),
            out: self.out.clone(),
            cache: self.cache.clone(),
            python: env.python(self.python.as_deref()),
            pn_binary: std::env::current_exe()
                .context("cannot find the running pn binary for the pn renders")?,
            reference_spp: self.reference_spp,
            mitsuba_spp: self.mitsuba_spp.clone(),
            target_spp: self.target_spp,
            denoise: !self.no_denoise,
            pn_points: self
                .pn_points
                .as_deref()
                .map(parse_points)
                .transpose()
                .context("--pn-points")?,
            render_args: words(&self.render_args),
            turntable: self.turntable,
            turntable_point: one(&self.turntable_point, "turntable-point")?,
            single_scatter: !self.no_single_scatter,
            ablation: self.ablation || self.ablation_study.is_some(),
            ablation_study: self.ablation_study.clone(),
            quick: self.quick,
            threads: self.threads,
            repeat: self.repeat,
            markdown_only: self.markdown_only,
            keep_work: self.keep_work,
            temp_dir: std::env::temp_dir(),
        })
    }
}
