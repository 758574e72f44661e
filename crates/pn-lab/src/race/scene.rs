//! The race on one scene: Mitsuba's points (plain and denoised at each spp), pn's points,
//! `points.csv`, `crossings.txt`, the error-against-time plot, then the single-scattering
//! comparison, the turntable and the ablation; returns the scene's summary row.

use super::analysis::{self, MITSUBA, MITSUBA_OIDN, POINT_COLUMNS};
use super::metrics::{self, errors, excess};
use super::mitsuba_side::{self, MitsubaJob};
use super::pn_side::{pn_settings, Family, PnPoint, PnResult, PnRunner};
use super::{ablation, error_time, single_scatter, turntable, Ctx, WORK};
use anyhow::{Context, Result};
use pn_formats::{num, Table};
use pn_render::compare::{read_gray, GrayImage};
use pn_render::RenderScene;
use std::io::Write;
use std::path::Path;

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
pub(super) fn race_scene(
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
    table.write_csv(&dir.join("points.csv"))?;
    let pts = analysis::points(&table);
    error_time::draw(&dir, &name, plan.reference_spp, &table, noise)?;
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
        row.extend(single_scatter::single_scatter(
            ctx, &name, &dir, &runner, log,
        )?);
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
            row.extend(turntable::turntable(
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

#[cfg(test)]
mod tests {
    use super::*;

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
}
