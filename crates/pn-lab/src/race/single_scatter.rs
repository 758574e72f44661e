//! Single scattering: Mitsuba `max_depth = 2` (its own two-halves reference) against
//! `pn render --method none` (`single_scatter.csv`).

use super::markdown;
use super::metrics::errors;
use super::mitsuba_side;
use super::pn_side::{pn_settings, PnPoint, PnRunner};
use super::{Ctx, WORK};
use anyhow::Result;
use pn_formats::{num, Table};
use pn_render::compare::read_gray;
use std::io::Write;
use std::path::Path;

/// Single scattering: Mitsuba `max_depth = 2` reference (two halves) against
/// `pn render --method none`.
pub(super) fn single_scatter(
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
    t.write_csv(&dir.join("single_scatter.csv"))?;
    Ok(vec![
        ("ss_rel_bias", num(Some(e.rel_bias))),
        ("ss_rel_rmse", num(Some(e.rel_rmse))),
        ("ss_reference_noise", num(Some(info.noise_rel_rmse))),
        ("ss_rmse_over_noise", num(Some(ratio))),
        ("ss_bias_sigmas", num(Some(sigmas))),
    ])
}
