//! The turntable: one `pn render --turntable K` against K Mitsuba renders of the same
//! cameras (one process, the scene loaded once) at the spp that reaches pn's error
//! (`turntable.csv`).

use super::analysis::{self, MITSUBA};
use super::markdown;
use super::metrics::{self, errors, excess, spp_for_error};
use super::mitsuba_side::{self, MitsubaJob};
use super::pn_side::{pn_settings, PnPoint, PnRunner};
use super::proc;
use super::{Ctx, WORK};
use anyhow::{ensure, Result};
use pn_formats::{num, Table};
use pn_render::compare::read_gray;
use pn_render::RenderScene;
use std::io::Write;
use std::path::{Path, PathBuf};

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
pub(super) fn turntable(
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
    t.write_csv(&dir.join("turntable.csv"))?;
    Ok(vec![
        ("turntable_views", k.to_string()),
        ("turntable_pn", point.label()),
        ("turntable_pn_seconds", num(Some(r.wall))),
        ("turntable_mitsuba_spp", spp.to_string()),
        ("turntable_mitsuba_seconds", num(Some(m.wall))),
        ("turntable_speedup", num(Some(speedup))),
    ])
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
}
