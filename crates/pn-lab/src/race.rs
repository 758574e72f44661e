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

pub mod ablation;
mod analysis;
mod markdown;
mod metrics;
mod mitsuba_side;
mod plot;
mod pn_side;
mod proc;

pub use pn_side::{Family, PnPoint};

use analysis::{MITSUBA, MITSUBA_OIDN, POINT_COLUMNS};
use anyhow::{ensure, Context, Result};
use metrics::{errors, excess, spp_for_error};
use mitsuba_side::{Mitsuba, MitsubaJob};
use pn_formats::table::{self, num, Table};
use pn_runtime::render::compare::{read_gray, GrayImage};
use pn_runtime::render::RenderScene;
use pn_side::{PnResult, PnRunner};
use std::io::Write;
use std::path::{Path, PathBuf};

/// The pn points of a full race.
pub const DEFAULT_PN_POINTS: &str = "cda@16,cda@24,cda@32,cda@48,p1@16,p1@24,p1@32,p1@48,\
                                     p3@16,p3@24,p3@32,p3@48,p5@16,p5@24,p5@32,p7@16,p7@24";
/// The per-scene folder of the images, exports and renders (removed at the end of a scene
/// unless `keep_work`).
pub const WORK: &str = "work";

/// Most timed runs per point (`--repeat`).
pub const MAX_REPEAT: usize = 15;

/// Runs `run` `k` times (at least once) and returns the run with the median of `wall`
/// (the lower middle one for even `k`). The race's points are deterministic (a fixed seed,
/// a deterministic solver), so every run gives the same image; only the time varies with
/// what else the machine is doing.
fn median_run<T>(
    k: usize,
    wall: impl Fn(&T) -> f64,
    mut run: impl FnMut() -> Result<T>,
) -> Result<T> {
    let mut runs = (0..k.max(1)).map(|_| run()).collect::<Result<Vec<T>>>()?;
    runs.sort_by(|a, b| wall(a).total_cmp(&wall(b)));
    Ok(runs.swap_remove((runs.len() - 1) / 2))
}

/// Mitsuba's spp ladder of a full race.
pub const DEFAULT_MITSUBA_SPP: &[usize] = &[1, 4, 16, 64, 256];

/// The options of `pn race`.
#[derive(Clone, Debug, PartialEq)]
pub struct RaceRequest {
    /// Scene files or built-in names.
    pub scenes: Vec<String>,
    /// Output folder (everything: CSV, PNG, Markdown).
    pub out: PathBuf,
    /// Reference cache (default `out/race-cache`).
    pub cache: Option<PathBuf>,
    /// The Python interpreter with Mitsuba and pyoidn (default: see
    /// `pn_runtime::render::mitsuba::find_python`).
    pub python: Option<PathBuf>,
    /// The `pn` binary for the pn points (the command line passes itself).
    pub pn_binary: PathBuf,
    /// Reference spp in all (two halves; default 4096, 64 with `quick`).
    pub reference_spp: Option<usize>,
    /// Mitsuba's spp ladder (default 1, 4, 16, 64, 256; 1, 4 with `quick`).
    pub mitsuba_spp: Option<Vec<usize>>,
    /// The Mitsuba spp whose error the crossing points are measured against (default 64;
    /// the largest of the ladder with `quick`).
    pub target_spp: Option<usize>,
    /// Also run denoised Mitsuba.
    pub denoise: bool,
    /// pn points (default [`DEFAULT_PN_POINTS`]; `p1@16` with `quick`).
    pub pn_points: Option<Vec<PnPoint>>,
    /// Extra `pn render` arguments for every pn render (renderer settings).
    pub render_args: Vec<String>,
    /// Turntable views (0 = no turntable; default 16, 2 with `quick`).
    pub turntable: Option<usize>,
    /// The pn point of the turntable (default: the fastest that reaches the target error,
    /// else the most accurate).
    pub turntable_point: Option<PnPoint>,
    /// Run the single-scattering comparison.
    pub single_scatter: bool,
    /// Run the ablation study on every scene.
    pub ablation: bool,
    /// The ablation study file (default: the built-in [`ablation::DEFAULT_STUDY`]).
    pub ablation_study: Option<PathBuf>,
    /// A small smoke run.
    pub quick: bool,
    /// `--threads` for the pn renders.
    pub threads: Option<usize>,
    /// Timed runs per Mitsuba and pn point; the run with the median wall time is kept.
    pub repeat: usize,
    /// Only regenerate `results.md` from the CSV files in `out`.
    pub markdown_only: bool,
    /// Keep `<out>/<scene>/work/` (exports, images, renders) after the scene.
    pub keep_work: bool,
    /// Where the race writes its scratch files (the probe of the Python interpreter, in a
    /// folder of its own that is removed afterwards); the command line passes the system's
    /// temporary folder.
    pub temp_dir: PathBuf,
}

impl Default for RaceRequest {
    /// The full race on the nebula into `out/race`.
    fn default() -> Self {
        Self {
            scenes: vec!["nebula".into()],
            out: PathBuf::from("out/race"),
            cache: None,
            python: None,
            pn_binary: PathBuf::from("pn"),
            reference_spp: None,
            mitsuba_spp: None,
            target_spp: None,
            denoise: true,
            pn_points: None,
            render_args: vec![],
            turntable: None,
            turntable_point: None,
            single_scatter: true,
            ablation: false,
            ablation_study: None,
            quick: false,
            threads: None,
            repeat: 1,
            markdown_only: false,
            keep_work: false,
            temp_dir: PathBuf::from("out/race-tmp"),
        }
    }
}

/// The request with every default filled in.
struct Plan {
    reference_spp: usize,
    mitsuba_spp: Vec<usize>,
    target_spp: usize,
    pn_points: Vec<PnPoint>,
    turntable: usize,
    study: Option<ablation::Study>,
}

impl Plan {
    fn new(r: &RaceRequest) -> Result<Self> {
        let reference_spp = r.reference_spp.unwrap_or(if r.quick { 64 } else { 4096 });
        ensure!(
            reference_spp >= 2,
            "--reference-spp must be at least 2 (two halves), got {reference_spp}"
        );
        let mut mitsuba_spp = r.mitsuba_spp.clone().unwrap_or_else(|| {
            if r.quick {
                vec![1, 4]
            } else {
                DEFAULT_MITSUBA_SPP.to_vec()
            }
        });
        mitsuba_spp.sort_unstable();
        mitsuba_spp.dedup();
        ensure!(
            !mitsuba_spp.is_empty() && mitsuba_spp[0] >= 1,
            "--mitsuba-spp needs positive values"
        );
        let last = mitsuba_spp[mitsuba_spp.len() - 1];
        let target_spp = r
            .target_spp
            .unwrap_or(if r.quick || !mitsuba_spp.contains(&64) {
                last
            } else {
                64
            });
        ensure!(
            mitsuba_spp.contains(&target_spp),
            "--target-spp {target_spp} is not in --mitsuba-spp {mitsuba_spp:?}"
        );
        let pn_points = match &r.pn_points {
            Some(p) => p.clone(),
            None if r.quick => vec![PnPoint::parse("p1@16")?],
            None => parse_points(DEFAULT_PN_POINTS)?,
        };
        ensure!(!pn_points.is_empty(), "--pn-points is empty");
        ensure!(
            (1..=MAX_REPEAT).contains(&r.repeat),
            "--repeat must lie in 1..={MAX_REPEAT}, got {}",
            r.repeat
        );
        ensure!(
            pn_points.iter().all(|p| p.family != Family::None),
            "--pn-points: single scattering (none) is its own comparison, not a race point"
        );
        let study = match (&r.ablation_study, r.ablation) {
            (_, false) => None,
            (Some(p), true) => Some(ablation::Study::from_file(p)?),
            (None, true) => Some(ablation::Study::builtin()?),
        };
        Ok(Self {
            reference_spp,
            mitsuba_spp,
            target_spp,
            pn_points,
            turntable: r.turntable.unwrap_or(if r.quick { 2 } else { 16 }),
            study,
        })
    }
}

/// Parses a comma-separated list of pn points (`cda@16,p5@24`).
pub fn parse_points(s: &str) -> Result<Vec<PnPoint>> {
    s.split(',')
        .filter(|t| !t.trim().is_empty())
        .map(PnPoint::parse)
        .collect()
}

/// The settings text of a pn row: `res=24` plus the render arguments (`spp=16`; a `--set`
/// as its `SECTION.KEY=VALUE`), with no comma or double quote (a CSV cell).
fn pn_settings(p: &PnPoint, args: &[String]) -> String {
    let mut s = if p.family == Family::None {
        String::from("-")
    } else {
        format!("res={}", p.solve_res)
    };
    let all: Vec<String> = args.iter().cloned().chain(p.render_args()).collect();
    let mut it = all.iter().peekable();
    while let Some(a) = it.next() {
        let key = a.trim_start_matches('-');
        if let Some(v) = key.strip_prefix("set=") {
            s += &format!(" {v}");
            continue;
        }
        match it.peek() {
            Some(v) if key == "set" => {
                s += &format!(" {v}");
                it.next();
            }
            Some(v) if !v.starts_with("--") => {
                s += &format!(" {key}={v}");
                it.next();
            }
            _ => s += &format!(" {key}"),
        }
    }
    s.replace(',', ";").replace('"', "'")
}

/// Everything one scene's race needs.
struct Ctx<'a> {
    req: &'a RaceRequest,
    plan: &'a Plan,
    mitsuba: &'a Mitsuba,
    cache: PathBuf,
}

/// Runs `pn race`.
pub fn run(req: &RaceRequest, stdout: &mut dyn Write) -> Result<()> {
    if req.markdown_only {
        redraw_error_time_plots(&req.out, stdout)?;
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
    std::fs::create_dir_all(&req.out)
        .with_context(|| format!("cannot create {}", req.out.display()))?;
    let scratch = req.temp_dir.join(format!("pn-race-{}", std::process::id()));
    let mitsuba = Mitsuba::find(req.python.as_deref(), &scratch);
    let _ = std::fs::remove_dir_all(&scratch);
    let mitsuba = mitsuba?;
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
        let row = race_scene(&ctx, s, stdout).with_context(|| format!("race on {s}"))?;
        summary.push(&row)?;
        summary.write(&req.out.join("summary.csv"))?;
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

/// Mitsuba rows: plain and (optionally) denoised at each spp.
fn mitsuba_points(
    ctx: &Ctx,
    name: &str,
    dir: &Path,
    reference: &GrayImage,
    noise: f64,
    table: &mut Table,
    log: &mut dyn Write,
) -> Result<()> {
    let export = dir.join(WORK).join("export");
    let images = dir.join(WORK).join("mitsuba");
    std::fs::create_dir_all(&images)?;
    for (k, &spp) in ctx.plan.mitsuba_spp.iter().enumerate() {
        for denoise in [false, true] {
            if denoise && !ctx.req.denoise {
                continue;
            }
            let fam = if denoise { MITSUBA_OIDN } else { MITSUBA };
            let out = images.join(format!(
                "{}_{spp:05}.exr",
                if denoise { "oidn" } else { "plain" }
            ));
            let r = median_run(
                ctx.req.repeat,
                |r: &mitsuba_side::MitsubaResult| r.wall,
                || {
                    mitsuba_side::render(
                        ctx.mitsuba,
                        &MitsubaJob {
                            export: &export,
                            spp,
                            seed: 1 + k as u64,
                            max_depth: -1,
                            denoise,
                            out: &out,
                            views: None,
                        },
                    )
                },
            )?;
            let e = errors(&read_gray(&out)?, reference)?;
            writeln!(
                log,
                "  {:<16} spp {spp:>5}: {:>7.2} s (render {:.2} s), rel. RMSE {:.4}, bias {:+.2} %",
                analysis::family_name(fam),
                r.wall,
                r.render,
                e.rel_rmse,
                100.0 * e.rel_bias
            )?;
            table.push(&[
                ("scene", name.into()),
                ("tool", "mitsuba".into()),
                ("family", fam.into()),
                ("settings", format!("spp={spp}")),
                ("spp", spp.to_string()),
                ("seconds", num(Some(r.wall))),
                ("seconds_render", num(Some(r.render))),
                ("seconds_denoise", num(denoise.then_some(r.denoise))),
                ("rel_rmse", num(Some(e.rel_rmse))),
                ("rel_rmse_excess", num(Some(excess(e.rel_rmse, noise)))),
                ("rel_bias", num(Some(e.rel_bias))),
                ("mean", num(Some(e.mean))),
                ("runs", ctx.req.repeat.max(1).to_string()),
            ])?;
        }
    }
    Ok(())
}

/// The time split of a pn render: (solve, render, everything else in the report).
fn pn_split(r: &PnResult) -> (Option<f64>, Option<f64>, Option<f64>) {
    let solve = r.phase("solve");
    let render = r.phase("render");
    let other: f64 = r
        .phases
        .iter()
        .filter(|(k, _)| !matches!(k.as_str(), "solve" | "render" | "total"))
        .map(|(_, v)| v)
        .sum();
    (solve, render, Some(other))
}

/// One pn row.
#[allow(clippy::too_many_arguments)]
fn pn_row(
    name: &str,
    p: &PnPoint,
    args: &[String],
    r: &PnResult,
    e: &metrics::Errors,
    noise: f64,
) -> Vec<(&'static str, String)> {
    let (solve, render, other) = pn_split(r);
    vec![
        ("scene", name.into()),
        ("tool", "pn".into()),
        ("family", p.family_key()),
        ("settings", pn_settings(p, args)),
        (
            "order",
            p.family.order().map(|n| n.to_string()).unwrap_or_default(),
        ),
        (
            "solve_res",
            if p.family == Family::None {
                String::new()
            } else {
                p.solve_res.to_string()
            },
        ),
        ("seconds", num(Some(r.wall))),
        ("seconds_render", num(render)),
        ("seconds_solve", num(solve)),
        ("seconds_setup", num(other)),
        (
            "iterations",
            r.iterations.map(|n| n.to_string()).unwrap_or_default(),
        ),
        ("rel_rmse", num(Some(e.rel_rmse))),
        ("rel_rmse_excess", num(Some(excess(e.rel_rmse, noise)))),
        ("rel_bias", num(Some(e.rel_bias))),
        ("mean", num(Some(e.mean))),
    ]
}

/// The race on one scene; returns its summary row.
fn race_scene(
    ctx: &Ctx,
    scene_arg: &str,
    log: &mut dyn Write,
) -> Result<Vec<(&'static str, String)>> {
    let scene = RenderScene::load(scene_arg)?;
    let name = scene.name.clone();
    let dir = ctx.req.out.join(&name);
    let export = dir.join(WORK).join("export");
    mitsuba_side::export_scene(&scene, &export)?;
    writeln!(
        log,
        "{name}: {}×{} px, density {:?}",
        scene.camera.width,
        scene.camera.height,
        scene.density_grid()?.res
    )?;
    let plan = ctx.plan;
    let reference = mitsuba_side::reference(
        ctx.mitsuba,
        &name,
        &export,
        &ctx.cache,
        plan.reference_spp,
        -1,
        log,
    )?;
    let noise = reference.info.noise_rel_rmse;
    let mut table = Table::new(POINT_COLUMNS);
    mitsuba_points(ctx, &name, &dir, &reference.image, noise, &mut table, log)?;

    let runner = PnRunner {
        binary: ctx.req.pn_binary.clone(),
        scene: scene_arg.to_string(),
        render_args: ctx.req.render_args.clone(),
        threads: ctx.req.threads,
    };
    let mut pn_errors = vec![];
    for p in &plan.pn_points {
        let out = dir.join(WORK).join("pn").join(p.folder());
        let r = median_run(
            ctx.req.repeat,
            |r: &PnResult| r.wall,
            || runner.render(p, &out, &[]),
        )?;
        let e = errors(&read_gray(&r.images[0])?, &reference.image)?;
        let (solve, render, _) = pn_split(&r);
        writeln!(
            log,
            "  pn {:<14}: {:>7.2} s (solve {:.2} s, render {:.2} s), rel. RMSE {:.4}, bias {:+.2} %{}",
            p.pretty(),
            r.wall,
            solve.unwrap_or(f64::NAN),
            render.unwrap_or(f64::NAN),
            e.rel_rmse,
            100.0 * e.rel_bias,
            if r.converged { "" } else { " (solver NOT converged)" }
        )?;
        let mut row = pn_row(&name, p, &ctx.req.render_args, &r, &e, noise);
        row.push(("runs", ctx.req.repeat.max(1).to_string()));
        table.push(&row)?;
        pn_errors.push((p.clone(), r, e));
    }
    analysis::derive(&mut table, noise);
    table.write(&dir.join("points.csv"))?;
    let pts = analysis::points(&table);
    draw_error_time(&dir, &name, plan.reference_spp, &table, noise)?;
    let (lines, best) = analysis::crossings(&pts, plan.target_spp);
    std::fs::write(dir.join("crossings.txt"), lines.join("\n") + "\n")?;
    for l in &lines {
        writeln!(log, "  {l}")?;
    }

    let target = pts
        .iter()
        .find(|p| p.family == MITSUBA && p.spp == Some(plan.target_spp))
        .map(|p| (p.rel_rmse, p.seconds));
    let best_pn = pn_errors
        .iter()
        .min_by(|a, b| a.2.rel_rmse.total_cmp(&b.2.rel_rmse));
    let mut row: Vec<(&'static str, String)> = vec![
        ("scene", name.clone()),
        ("reference_spp", plan.reference_spp.to_string()),
        ("reference_noise", num(Some(noise))),
        ("target_spp", plan.target_spp.to_string()),
        ("mitsuba_target_rel_rmse", num(target.map(|t| t.0))),
        ("mitsuba_target_seconds", num(target.map(|t| t.1))),
    ];
    if let Some((label, secs, speedup)) = &best {
        row.push(("pn_first_reaching", label.clone()));
        row.push(("pn_first_seconds", num(Some(*secs))));
        row.push(("speedup_at_target", num(Some(*speedup))));
    }
    if let Some((p, r, e)) = best_pn {
        row.push(("best_pn", p.pretty().replace('³', "^3")));
        row.push(("best_pn_rel_rmse", num(Some(e.rel_rmse))));
        row.push(("best_pn_rel_bias", num(Some(e.rel_bias))));
        row.push(("best_pn_seconds", num(Some(r.wall))));
    }

    if ctx.req.single_scatter {
        row.extend(single_scatter(ctx, &name, &dir, &runner, log)?);
    }
    if plan.turntable > 0 {
        let point = ctx.req.turntable_point.clone().or_else(|| {
            // The fastest point that reaches the target error, else the most accurate.
            let reach = target.map(|t| t.0).unwrap_or(0.0);
            pn_errors
                .iter()
                .filter(|(_, _, e)| e.rel_rmse <= reach)
                .min_by(|a, b| a.1.wall.total_cmp(&b.1.wall))
                .or(best_pn)
                .map(|x| x.0.clone())
        });
        if let Some(point) = point {
            let single = pn_errors
                .iter()
                .find(|x| x.0 == point)
                .map(|x| (x.1.images[0].clone(), x.2));
            row.extend(turntable(
                ctx, &scene, &name, &dir, &runner, &point, single, &pts, &reference, log,
            )?);
        }
    }
    if let Some(study) = &plan.study {
        writeln!(
            log,
            "  ablation: {} arms of the study {}",
            study.arms.len(),
            study.source
        )?;
        ablation::run(ctx, study, &name, &dir, &runner, &reference.image, log)?;
    }
    if !ctx.req.keep_work {
        let w = dir.join(WORK);
        std::fs::remove_dir_all(&w).with_context(|| format!("cannot remove {}", w.display()))?;
    }
    Ok(row)
}

/// Single scattering: Mitsuba `max_depth = 2` reference (two halves) against
/// `pn render --method none`.
fn single_scatter(
    ctx: &Ctx,
    name: &str,
    dir: &Path,
    runner: &PnRunner,
    log: &mut dyn Write,
) -> Result<Vec<(&'static str, String)>> {
    let export = dir.join(WORK).join("export");
    let reference = mitsuba_side::reference(
        ctx.mitsuba,
        name,
        &export,
        &ctx.cache,
        ctx.plan.reference_spp,
        2,
        log,
    )?;
    let p = PnPoint::parse("none")?;
    let r = runner.render(&p, &dir.join(WORK).join("pn").join("single_scatter"), &[])?;
    let e = errors(&read_gray(&r.images[0])?, &reference.image)?;
    let info = &reference.info;
    let ratio = e.rel_rmse / info.noise_rel_rmse;
    let sigmas = e.rel_bias / info.noise_rel_mean;
    writeln!(
        log,
        "  single scattering: pn {:.2} s, rel. bias {:+.3} % ({sigmas:+.1} σ of the reference \
         mean), rel. RMSE {:.4} = {ratio:.2} × the reference's own noise {:.4}",
        r.wall,
        100.0 * e.rel_bias,
        e.rel_rmse,
        info.noise_rel_rmse
    )?;
    let mut t = Table::new(markdown::SINGLE_COLUMNS);
    let cells = vec![
        ("scene", name.to_string()),
        ("reference_spp", ctx.plan.reference_spp.to_string()),
        ("reference_noise_rel_rmse", num(Some(info.noise_rel_rmse))),
        ("reference_noise_rel_mean", num(Some(info.noise_rel_mean))),
        ("pn_settings", pn_settings(&p, &ctx.req.render_args)),
        ("pn_seconds", num(Some(r.wall))),
        ("rel_rmse", num(Some(e.rel_rmse))),
        ("rel_bias", num(Some(e.rel_bias))),
        ("rmse_over_noise", num(Some(ratio))),
        ("bias_sigmas", num(Some(sigmas))),
    ];
    t.push(&cells)?;
    t.write(&dir.join("single_scatter.csv"))?;
    Ok(vec![
        ("ss_rel_bias", num(Some(e.rel_bias))),
        ("ss_rel_rmse", num(Some(e.rel_rmse))),
        ("ss_reference_noise", num(Some(info.noise_rel_rmse))),
        ("ss_rmse_over_noise", num(Some(ratio))),
        ("ss_bias_sigmas", num(Some(sigmas))),
    ])
}

/// The turntable cameras: the scene camera rotated about the axis through `target`
/// parallel to `up` by 2πk/K (right-handed; view 0 = the scene camera).
pub fn turntable_cameras(scene: &RenderScene, k: usize) -> Vec<[[f64; 3]; 3]> {
    let c = &scene.camera;
    let n = c.up.iter().map(|v| v * v).sum::<f64>().sqrt();
    let a = c.up.map(|v| v / n);
    let v = [0, 1, 2].map(|d| c.position[d] - c.target[d]);
    (0..k)
        .map(|i| {
            let th = std::f64::consts::TAU * i as f64 / k as f64;
            let (s, co) = th.sin_cos();
            let cross = [
                a[1] * v[2] - a[2] * v[1],
                a[2] * v[0] - a[0] * v[2],
                a[0] * v[1] - a[1] * v[0],
            ];
            let dot = a[0] * v[0] + a[1] * v[1] + a[2] * v[2];
            let r = [0, 1, 2].map(|d| v[d] * co + cross[d] * s + a[d] * dot * (1.0 - co));
            [[0, 1, 2].map(|d| c.target[d] + r[d]), c.target, c.up]
        })
        .collect()
}

/// The turntable: `pn render --turntable K` against K Mitsuba renders at the spp that
/// reaches pn's view-0 error.
#[allow(clippy::too_many_arguments)]
fn turntable(
    ctx: &Ctx,
    scene: &RenderScene,
    name: &str,
    dir: &Path,
    runner: &PnRunner,
    point: &PnPoint,
    single: Option<(PathBuf, metrics::Errors)>,
    pts: &[analysis::Pt],
    reference: &mitsuba_side::Reference,
    log: &mut dyn Write,
) -> Result<Vec<(&'static str, String)>> {
    let k = ctx.plan.turntable;
    let out = dir.join(WORK).join("turntable");
    let pn_out = out.join("pn");
    let _ = std::fs::remove_dir_all(&pn_out);
    let r = match runner.render(point, &pn_out, &["--turntable".into(), k.to_string()]) {
        Ok(r) => r,
        Err(e) if format!("{e:#}").contains("unexpected argument '--turntable'") => {
            writeln!(
                log,
                "  turntable: skipped, this `pn render` has no --turntable ({})",
                proc::tail(&format!("{e:#}"), 1)
            )?;
            return Ok(vec![]);
        }
        Err(e) => return Err(e),
    };
    ensure!(
        r.images.len() == k,
        "pn render --turntable {k} wrote {} images into {}",
        r.images.len(),
        pn_out.display()
    );
    let view0 = read_gray(&r.images[0])?;
    let e0 = errors(&view0, &reference.image)?;
    let noise = reference.info.noise_rel_rmse;
    // View 0 is the scene camera: it must be the single render's image.
    let same = match &single {
        Some((img, _)) => Some(errors(&view0, &read_gray(img)?)?.rel_rmse),
        None => None,
    };
    // The Mitsuba spp that reaches pn's view-0 error (spp^(-1/2) on the excess error).
    let fit: Vec<(usize, f64)> = pts
        .iter()
        .filter(|p| p.family == MITSUBA)
        .filter_map(|p| Some((p.spp?, excess(p.rel_rmse, noise))))
        .collect();
    let goal = excess(e0.rel_rmse, noise);
    let spp = spp_for_error(&fit, goal)
        .map(|s| s.ceil().max(1.0) as usize)
        .unwrap_or(ctx.plan.reference_spp / 2)
        .min(ctx.plan.reference_spp / 2)
        .max(1);
    let views = turntable_cameras(scene, k);
    let vjson: Vec<serde_json::Value> = views
        .iter()
        .map(|v| serde_json::json!({"origin": v[0], "target": v[1], "up": v[2]}))
        .collect();
    std::fs::create_dir_all(&out)?;
    let views_path = out.join("views.json");
    std::fs::write(&views_path, serde_json::to_string_pretty(&vjson)?)?;
    let mi_out = out.join("mitsuba.exr");
    let m = mitsuba_side::render(
        ctx.mitsuba,
        &MitsubaJob {
            export: &dir.join(WORK).join("export"),
            spp,
            seed: 77,
            max_depth: -1,
            denoise: false,
            out: &mi_out,
            views: Some(&views_path),
        },
    )?;
    ensure!(
        m.images.len() == k,
        "Mitsuba wrote {} of {k} turntable views",
        m.images.len()
    );
    let mi0 = errors(&read_gray(&m.images[0])?, &reference.image)?;
    // pn against Mitsuba per view (both errors in it): a check that the cameras agree.
    let mut diffs = vec![];
    for (a, b) in r.images.iter().zip(&m.images) {
        diffs.push(errors(&read_gray(a)?, &read_gray(b)?)?.rel_rmse);
    }
    let mean_diff = diffs.iter().sum::<f64>() / k as f64;
    let max_diff = diffs.iter().copied().fold(0.0, f64::max);
    let speedup = m.wall / r.wall;
    writeln!(
        log,
        "  turntable {k} views, pn {}: {:.2} s (view 0 rel. RMSE {:.4}); Mitsuba {spp} spp: \
         {:.2} s (view 0 rel. RMSE {:.4}): {speedup:.1}× sooner; pn vs Mitsuba per view: mean \
         {mean_diff:.4}, max {max_diff:.4}",
        point.pretty(),
        r.wall,
        e0.rel_rmse,
        m.wall,
        mi0.rel_rmse
    )?;
    let mut t = Table::new(markdown::TURNTABLE_COLUMNS);
    t.push(&[
        ("scene", name.into()),
        ("tool", "pn".into()),
        (
            "settings",
            format!(
                "{} {}",
                point.family,
                pn_settings(point, &ctx.req.render_args)
            ),
        ),
        ("views", k.to_string()),
        ("seconds", num(Some(r.wall))),
        ("seconds_per_view", num(Some(r.wall / k as f64))),
        ("view0_rel_rmse", num(Some(e0.rel_rmse))),
        ("view0_vs_single_render", num(same)),
        ("mean_view_difference", num(Some(mean_diff))),
        ("max_view_difference", num(Some(max_diff))),
    ])?;
    t.push(&[
        ("scene", name.into()),
        ("tool", "mitsuba".into()),
        ("settings", format!("spp={spp}")),
        ("views", k.to_string()),
        ("seconds", num(Some(m.wall))),
        ("seconds_per_view", num(Some(m.wall / k as f64))),
        ("view0_rel_rmse", num(Some(mi0.rel_rmse))),
    ])?;
    t.write(&dir.join("turntable.csv"))?;
    Ok(vec![
        ("turntable_views", k.to_string()),
        ("turntable_pn", point.label()),
        ("turntable_pn_seconds", num(Some(r.wall))),
        ("turntable_mitsuba_spp", spp.to_string()),
        ("turntable_mitsuba_seconds", num(Some(m.wall))),
        ("turntable_speedup", num(Some(speedup))),
    ])
}

/// `<dir>/error_time.png` from a scene's points table (`points.csv`): one curve per family.
fn draw_error_time(
    dir: &Path,
    name: &str,
    reference_spp: usize,
    table: &table::Table,
    noise: f64,
) -> Result<()> {
    let pts = analysis::points(table);
    let curves: Vec<plot::Curve> = analysis::families(&pts)
        .into_iter()
        .map(|fam| {
            let v: Vec<(f64, f64, String)> = pts
                .iter()
                .filter(|p| p.family == fam)
                .map(|p| {
                    let label = match p.spp {
                        Some(s) => s.to_string(),
                        None => p
                            .settings
                            .split_whitespace()
                            .next()
                            .unwrap_or("")
                            .trim_start_matches("res=")
                            .to_string(),
                    };
                    (p.seconds, p.rel_rmse, label)
                })
                .collect();
            plot::Curve {
                mitsuba: fam.starts_with("mitsuba"),
                name: analysis::family_name(&fam),
                points: v,
            }
        })
        .collect();
    plot::draw(
        &dir.join("error_time.png"),
        &format!("{name}: error against wall time (reference {reference_spp} spp)"),
        &curves,
        noise,
    )?;
    Ok(())
}

/// Redraws every scene's `error_time.png` under `out` from its `points.csv`, with the
/// reference's spp and noise from `summary.csv` (for `--markdown-only`).
fn redraw_error_time_plots(out: &Path, stdout: &mut dyn Write) -> Result<()> {
    let summary = out.join("summary.csv");
    if !summary.exists() {
        return Ok(());
    }
    for r in table::Table::read(&summary)?.records() {
        let (Some(scene), Some(spp), Some(noise)) = (
            r.get("scene"),
            r.get("reference_spp").and_then(|v| v.parse::<usize>().ok()),
            r.get("reference_noise").and_then(|v| v.parse::<f64>().ok()),
        ) else {
            continue;
        };
        let dir = out.join(scene);
        let points = dir.join("points.csv");
        if points.exists() {
            draw_error_time(&dir, scene, spp, &table::Table::read(&points)?, noise)?;
            writeln!(stdout, "wrote {}", dir.join("error_time.png").display())?;
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn turntable_view_zero_is_the_camera_and_rotation_is_right_handed() {
        let scene = RenderScene::builtin("nebula").unwrap();
        let v = turntable_cameras(&scene, 4);
        assert_eq!(v[0][0], scene.camera.position);
        // Camera at +z, up +y: a quarter turn right-handed about +y takes +z to +x.
        let p = v[1][0];
        assert!((p[0] - 4.0).abs() < 1e-12 && p[1].abs() < 1e-12 && p[2].abs() < 1e-12);
        assert!((v[2][0][2] + 4.0).abs() < 1e-12);
    }

    /// `median_run` keeps the run with the median time: the middle one for odd k, the lower
    /// middle for even k, the only one for k = 1 (also for k = 0), and stops at an error.
    #[test]
    fn median_run_keeps_the_median_time() {
        let times = [0.9, 0.3, 0.5, 2.0, 0.4];
        let pick = |k: usize| {
            let mut i = 0;
            median_run(
                k,
                |t: &f64| *t,
                || {
                    i += 1;
                    Ok(times[i - 1])
                },
            )
            .unwrap()
        };
        assert_eq!(pick(5), 0.5);
        assert_eq!(pick(4), 0.5);
        assert_eq!(pick(2), 0.3);
        assert_eq!(pick(1), 0.9);
        assert_eq!(pick(0), 0.9);
        let mut calls = 0;
        let failed = median_run(
            3,
            |t: &f64| *t,
            || {
                calls += 1;
                anyhow::ensure!(calls < 2, "run {calls} failed");
                Ok(1.0)
            },
        );
        assert!(failed.is_err() && calls == 2);
    }

    #[test]
    fn plan_defaults_and_refusals() {
        let r = RaceRequest::default();
        let p = Plan::new(&r).unwrap();
        assert_eq!((p.reference_spp, p.target_spp, p.turntable), (4096, 64, 16));
        assert_eq!(p.pn_points.len(), 17);
        let q = Plan::new(&RaceRequest {
            quick: true,
            ..r.clone()
        })
        .unwrap();
        assert_eq!((q.mitsuba_spp.clone(), q.target_spp), (vec![1, 4], 4));
        for bad in [
            RaceRequest {
                reference_spp: Some(1),
                ..r.clone()
            },
            RaceRequest {
                target_spp: Some(8),
                ..r.clone()
            },
            RaceRequest {
                mitsuba_spp: Some(vec![0, 4]),
                ..r.clone()
            },
            RaceRequest {
                pn_points: Some(vec![PnPoint::parse("none").unwrap()]),
                ..r.clone()
            },
            RaceRequest {
                repeat: 0,
                ..r.clone()
            },
            RaceRequest {
                repeat: MAX_REPEAT + 1,
                ..r.clone()
            },
        ] {
            assert!(Plan::new(&bad).is_err());
        }
        assert_eq!(
            pn_settings(
                &PnPoint::parse("p5@24").unwrap(),
                &["--spp".into(), "16".into()]
            ),
            "res=24 spp=16"
        );
        assert_eq!(
            pn_settings(
                &PnPoint::parse("p3@24").unwrap(),
                &[
                    "--set".into(),
                    "camera.position=[0,0,3]".into(),
                    "--set=solve.absorber=\"box\"".into(),
                    "--exact-transmittance".into()
                ]
            ),
            "res=24 camera.position=[0;0;3] solve.absorber='box' exact-transmittance"
        );
    }
}
