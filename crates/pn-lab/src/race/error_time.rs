//! The error-against-time plots: `<scene>/error_time.png` from a scene's points table, and
//! their redrawing from the CSV files (`--markdown-only`).

use super::{analysis, plot};
use anyhow::Result;
use pn_formats::Table;
use std::io::Write;
use std::path::Path;

/// `<dir>/error_time.png` from a scene's points table (`points.csv`): one curve per family.
pub(super) fn draw(
    dir: &Path,
    name: &str,
    reference_spp: usize,
    table: &Table,
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
pub(super) fn redraw_all(out: &Path, stdout: &mut dyn Write) -> Result<()> {
    let summary = out.join("summary.csv");
    if !summary.exists() {
        return Ok(());
    }
    for r in Table::read_csv(&summary)?.records() {
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
            draw(&dir, scene, spp, &Table::read_csv(&points)?, noise)?;
            writeln!(stdout, "wrote {}", dir.join("error_time.png").display())?;
        }
    }
    Ok(())
}
