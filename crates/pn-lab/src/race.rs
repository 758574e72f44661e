//! `pn race <scene>...`: pn against Mitsuba 3 at equal error, in wall time (docs/race.md).
//!
//! Per scene, into `<out>/<scene>/` (exports, images and renders into `<out>/<scene>/work/`,
//! removed after the scene unless `keep_work`):
//! * a high-spp Mitsuba reference (`volpath`, all bounces; two independent halves with
//!   different seeds, whose difference gives the reference's own noise), rendered once and
//!   cached under the cache folder, keyed by a hash of the exported scene files and the spp;
//! * Mitsuba at increasing spp, plain and denoised with Open Image Denoise (pyoidn, colour
//!   only), each a whole Python process timed around it, plus its render-only seconds;
//! * pn at increasing accuracy (method × solve resolution), each a whole `pn render`
//!   subprocess timed around it, with its `report.json` time split;
//! * `points.csv` (one row per point), `error_time.png` (log–log, one curve per family),
//!   `crossings.txt` (the crossing points against plain Mitsuba at the target spp);
//! * single scattering: Mitsuba `max_depth = 2` (its own two-halves reference) against
//!   `pn render --method none` (`single_scatter.csv`);
//! * the turntable: one `pn render --turntable K` against K Mitsuba renders of the same
//!   cameras (one process, the scene loaded once) at the spp that reaches pn's error
//!   (`turntable.csv`);
//!
//! and, for all scenes, `summary.csv` and `results.md` (generated from the CSV files alone;
//! `markdown_only` regenerates it). With `ablation`, every scene also runs an ablation study
//! ([`ablation`]: each arm changes one suspected cause of the bias; `ablation.csv` per scene,
//! `bias_vs_order.png` for all).
//!
//! Errors: relative RMSE = ‖image − reference‖₂ / ‖reference‖₂ over all pixels; relative
//! bias = (mean image − mean reference) / mean reference.

//!
//! One concept per module: `request` (the options and the plan they give), `scene` (the
//! race on one scene: Mitsuba's and pn's points, the summary row), `single_scatter`,
//! `turntable`, [`ablation`], `error_time` (the error-against-time plots), `markdown`
//! (`results.md` from the CSV files), and below them `analysis`, `metrics`, `plot`,
//! `mitsuba_side`, `pn_side` and `proc`.

pub mod ablation;
mod analysis;
mod error_time;
mod markdown;
mod metrics;
mod mitsuba_side;
mod plot;
mod pn_side;
mod proc;
mod request;
mod scene;
mod single_scatter;
mod turntable;

pub use pn_side::{Family, PnPoint};
pub use request::{parse_points, RaceRequest, DEFAULT_MITSUBA_SPP, DEFAULT_PN_POINTS, MAX_REPEAT};
pub use turntable::turntable_cameras;

use anyhow::{ensure, Context, Result};
use mitsuba_side::Mitsuba;
use pn_formats::Table;
use request::Plan;
use std::io::Write;
use std::path::PathBuf;

/// The per-scene folder of the images, exports and renders (removed at the end of a scene
/// unless `keep_work`).
pub const WORK: &str = "work";

/// Everything one scene's race needs.
pub(crate) struct Ctx<'a> {
    pub(crate) req: &'a RaceRequest,
    pub(crate) plan: &'a Plan,
    pub(crate) mitsuba: &'a Mitsuba,
    pub(crate) cache: PathBuf,
}

/// Runs `pn race`.
pub fn run(req: &RaceRequest, stdout: &mut dyn Write) -> Result<()> {
    if req.markdown_only {
        error_time::redraw_all(&req.out, stdout)?;
        if let Some(p) = ablation::draw_order_plot(&req.out)? {
            writeln!(stdout, "wrote {}", p.display())?;
        }
        let p = markdown::write(&req.out)?;
        writeln!(stdout, "wrote {}", p.display())?;
        return Ok(());
    }
    ensure!(!req.scenes.is_empty(), "no scene given");
    let plan = Plan::new(req)?;
    if let Some(study) = &plan.study {
        // Before anything renders: a bad --set or a repeated flag fails now, not hours later.
        study.check(&req.scenes, &req.render_args)?;
    }
    check_inputs(req, &plan)?;
    let created = create_out(&req.out)?;
    let scratch = req.temp_dir.join(format!("pn-race-{}", std::process::id()));
    let mitsuba = Mitsuba::find(req.python.as_deref(), &scratch);
    let _ = std::fs::remove_dir_all(&scratch);
    let mitsuba = match mitsuba {
        Ok(m) => m,
        Err(e) => {
            // A refusal leaves no output folder behind (only the empty ones made here go).
            for d in created.iter().rev() {
                let _ = std::fs::remove_dir(d);
            }
            return Err(e);
        }
    };
    writeln!(
        stdout,
        "pn race: Mitsuba {} ({}), reference {} spp, Mitsuba spp {:?}, {} pn points, \
         turntable {} views{}",
        mitsuba.version,
        mitsuba.python.display(),
        plan.reference_spp,
        plan.mitsuba_spp,
        plan.pn_points.len(),
        plan.turntable,
        if req.repeat > 1 {
            format!(
                ", each point timed {} times (the median run kept)",
                req.repeat
            )
        } else {
            String::new()
        }
    )?;
    let ctx = Ctx {
        req,
        plan: &plan,
        mitsuba: &mitsuba,
        cache: req
            .cache
            .clone()
            .unwrap_or_else(|| PathBuf::from("out/race-cache")),
    };
    let mut summary = Table::new(markdown::SUMMARY_COLUMNS);
    for s in &req.scenes {
        let row = scene::race_scene(&ctx, s, stdout).with_context(|| format!("race on {s}"))?;
        summary.push(&row)?;
        summary.write_csv(&req.out.join("summary.csv"))?;
        if plan.study.is_some() {
            if let Some(p) = ablation::draw_order_plot(&req.out)? {
                writeln!(stdout, "  wrote {}", p.display())?;
            }
        }
    }
    let md = markdown::write(&req.out)?;
    writeln!(
        stdout,
        "wrote {} and {}",
        req.out.join("summary.csv").display(),
        md.display()
    )?;
    Ok(())
}

/// Everything the race reads, checked before Mitsuba is looked for (with Mitsuba, the
/// references come first and take minutes): every scene loads, and every text-PDE point's
/// file parses with its parameters and discretizes.
fn check_inputs(req: &RaceRequest, plan: &Plan) -> Result<()> {
    for s in &req.scenes {
        pn_render::RenderScene::load(s).with_context(|| format!("race on {s}"))?;
    }
    for p in plan.pn_points.iter().chain(req.turntable_point.as_ref()) {
        if let Some(pde) = &p.pde {
            pn_render::pde_kernel::PdeKernel::load(&pde.path, &pde.params)
                .with_context(|| format!("pn point {:?}", p.label()))?;
        }
    }
    Ok(())
}

/// Creates the output folder; returns the folders it made, outermost first, so that a
/// refusal can take them away again.
fn create_out(out: &std::path::Path) -> Result<Vec<PathBuf>> {
    let mut missing: Vec<PathBuf> = out
        .ancestors()
        .take_while(|a| !a.as_os_str().is_empty() && !a.exists())
        .map(std::path::Path::to_path_buf)
        .collect();
    missing.reverse();
    if let Err(e) = std::fs::create_dir_all(out) {
        for d in missing.iter().rev() {
            let _ = std::fs::remove_dir(d);
        }
        return Err(e).with_context(|| format!("cannot create {}", out.display()));
    }
    ensure!(out.is_dir(), "--out {} is not a folder", out.display());
    Ok(missing)
}
