//! `results.md` of `pn race`, generated from the CSV files of the output folder alone
//! (`summary.csv`, and per scene `points.csv`, `single_scatter.csv`, `turntable.csv`,
//! `ablation.csv`), so that `pn race --markdown-only` rewrites it without rendering.

use super::ablation;
use super::analysis::{crossings, family_name, points};
use anyhow::{Context, Result};
use pn_formats::Table;
use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

/// Columns of `summary.csv` (one row per scene).
pub const SUMMARY_COLUMNS: &[&str] = &[
    "scene",
    "reference_spp",
    "reference_noise",
    "target_spp",
    "mitsuba_target_rel_rmse",
    "mitsuba_target_seconds",
    "pn_first_reaching",
    "pn_first_seconds",
    "speedup_at_target",
    "best_pn",
    "best_pn_rel_rmse",
    "best_pn_rel_bias",
    "best_pn_seconds",
    "ss_rel_bias",
    "ss_rel_rmse",
    "ss_reference_noise",
    "ss_rmse_over_noise",
    "ss_bias_sigmas",
    "turntable_views",
    "turntable_pn",
    "turntable_pn_seconds",
    "turntable_mitsuba_spp",
    "turntable_mitsuba_seconds",
    "turntable_speedup",
];

/// Columns of `single_scatter.csv`.
pub const SINGLE_COLUMNS: &[&str] = &[
    "scene",
    "reference_spp",
    "reference_noise_rel_rmse",
    "reference_noise_rel_mean",
    "pn_settings",
    "pn_seconds",
    "rel_rmse",
    "rel_bias",
    "rmse_over_noise",
    "bias_sigmas",
];

/// Columns of `turntable.csv`.
pub const TURNTABLE_COLUMNS: &[&str] = &[
    "scene",
    "tool",
    "settings",
    "views",
    "seconds",
    "seconds_per_view",
    "view0_rel_rmse",
    "view0_vs_single_render",
    "mean_view_difference",
    "max_view_difference",
];

fn pct(r: &BTreeMap<String, String>, k: &str) -> String {
    r.get(k)
        .and_then(|v| v.parse::<f64>().ok())
        .map(|v| format!("{:+.2} %", 100.0 * v))
        .unwrap_or_default()
}

fn get<'a>(r: &'a BTreeMap<String, String>, k: &str) -> &'a str {
    r.get(k).map(String::as_str).unwrap_or("")
}

/// The side-by-side table of every scene of `summary.csv`.
fn summary_table(recs: &[BTreeMap<String, String>]) -> Result<String> {
    let mut t = Table::new(&[
        "scene",
        "reference noise",
        "Mitsuba at target spp: error, s",
        "first pn point reaching it",
        "pn s",
        "× sooner",
        "best pn (error, bias, s)",
        "single scattering: bias, RMSE / noise",
        "turntable: pn s, Mitsuba s (spp)",
        "× sooner",
    ]);
    for r in recs {
        let turntable = if get(r, "turntable_views").is_empty() {
            "—".to_string()
        } else {
            format!(
                "{} K={}: {}, {} ({} spp)",
                get(r, "turntable_pn"),
                get(r, "turntable_views"),
                get(r, "turntable_pn_seconds"),
                get(r, "turntable_mitsuba_seconds"),
                get(r, "turntable_mitsuba_spp")
            )
        };
        t.push_row([
            get(r, "scene").to_string(),
            get(r, "reference_noise").to_string(),
            format!(
                "{} spp: {}, {} s",
                get(r, "target_spp"),
                get(r, "mitsuba_target_rel_rmse"),
                get(r, "mitsuba_target_seconds")
            ),
            if get(r, "pn_first_reaching").is_empty() {
                "none"
            } else {
                get(r, "pn_first_reaching")
            }
            .to_string(),
            get(r, "pn_first_seconds").to_string(),
            get(r, "speedup_at_target").to_string(),
            format!(
                "{}: {}, {}, {} s",
                get(r, "best_pn"),
                get(r, "best_pn_rel_rmse"),
                pct(r, "best_pn_rel_bias"),
                get(r, "best_pn_seconds")
            ),
            format!(
                "{}, {}",
                pct(r, "ss_rel_bias"),
                get(r, "ss_rmse_over_noise")
            ),
            turntable,
            get(r, "turntable_speedup").to_string(),
        ])?;
    }
    Ok(t.to_markdown())
}

/// Scenes of an interrupted run: a folder with `points.csv` but no summary row yet.
fn partial_scenes(out: &Path, recs: &[BTreeMap<String, String>]) -> Result<Vec<String>> {
    let mut dirs: Vec<PathBuf> = std::fs::read_dir(out)
        .with_context(|| format!("cannot list {}", out.display()))?
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.join("points.csv").is_file())
        .collect();
    dirs.sort();
    Ok(dirs
        .iter()
        .map(|d| {
            d.file_name()
                .map(|n| n.to_string_lossy().into_owned())
                .unwrap_or_default()
        })
        .filter(|name| !recs.iter().any(|r| get(r, "scene") == name))
        .collect())
}

/// The columns of a scene's points table in `results.md` (header text, column).
const POINTS_MD: &[(&str, &str)] = &[
    ("method", "family"),
    ("settings", "settings"),
    ("seconds", "seconds"),
    ("render s", "seconds_render"),
    ("solve s", "seconds_solve"),
    ("other s", "seconds_setup"),
    ("denoise s", "seconds_denoise"),
    ("rel. RMSE", "rel_rmse"),
    ("excess", "rel_rmse_excess"),
    ("rel. bias", "rel_bias"),
    ("Mitsuba s at this error", "mitsuba_equal_error_seconds"),
    ("extrap.", "mitsuba_extrapolated"),
    ("× vs Mitsuba", "speedup_vs_mitsuba"),
    ("OIDN s at this error", "oidn_equal_error_seconds"),
    ("× vs OIDN", "speedup_vs_oidn"),
];

/// The columns of a scene's single-scattering table in `results.md`.
const SINGLE_MD: &[(&str, &str)] = &[
    ("reference spp", "reference_spp"),
    ("reference noise (RMSE)", "reference_noise_rel_rmse"),
    ("reference noise (mean)", "reference_noise_rel_mean"),
    ("pn settings", "pn_settings"),
    ("pn s", "pn_seconds"),
    ("rel. RMSE", "rel_rmse"),
    ("rel. bias", "rel_bias"),
    ("RMSE / noise", "rmse_over_noise"),
    ("bias / σ(mean)", "bias_sigmas"),
];

/// The columns of a scene's turntable table in `results.md`.
const TURNTABLE_MD: &[(&str, &str)] = &[
    ("tool", "tool"),
    ("settings", "settings"),
    ("views", "views"),
    ("seconds", "seconds"),
    ("s / view", "seconds_per_view"),
    ("view 0 rel. RMSE", "view0_rel_rmse"),
    ("view 0 vs single render", "view0_vs_single_render"),
    ("pn vs Mitsuba per view (mean)", "mean_view_difference"),
    ("(max)", "max_view_difference"),
];

/// One scene's section: the plot, the crossing points and the points table, then the
/// single-scattering, turntable and ablation tables of the files that exist.
fn scene_section(out: &Path, r: &BTreeMap<String, String>) -> Result<String> {
    let mut s = String::new();
    let scene = get(r, "scene");
    let dir = out.join(scene);
    let _ = write!(s, "\n## {scene}\n\n![{scene}]({scene}/error_time.png)\n\n");
    let pts_path = dir.join("points.csv");
    if pts_path.is_file() {
        let t = Table::read_csv(&pts_path)?;
        let pts = points(&t);
        let target: usize = get(r, "target_spp").parse().unwrap_or(64);
        // (64 for a scene without a summary row: the default target.)
        let (lines, _) = crossings(&pts, target);
        s += "Crossing points:\n\n";
        for l in lines {
            let _ = writeln!(s, "* {l}");
        }
        s += "\n";
        let mut t2 = t.clone();
        let fi = t2.header.iter().position(|h| h == "family");
        if let Some(fi) = fi {
            for row in &mut t2.rows {
                row[fi] = family_name(&row[fi]);
            }
        }
        s += &t2.select(POINTS_MD).to_markdown();
    }
    let ss = dir.join("single_scatter.csv");
    if ss.is_file() {
        s += "\nSingle scattering (Mitsuba `max_depth = 2` against `pn render --method none`):\n\n";
        s += &Table::read_csv(&ss)?.select(SINGLE_MD).to_markdown();
    }
    let tt = dir.join("turntable.csv");
    if tt.is_file() {
        s += "\nTurntable (one `pn render --turntable K` against K Mitsuba renders in one process):\n\n";
        s += &Table::read_csv(&tt)?.select(TURNTABLE_MD).to_markdown();
    }
    let ab = dir.join("ablation.csv");
    if ab.is_file() {
        s += &ablation::markdown(&Table::read_csv(&ab)?)?;
    }
    Ok(s)
}

/// The link to `docs/race.md` from `out`: relative where `out` lies under a `docs` folder
/// (`docs/race/` → `../race.md`, `docs/lab/race/<date>/` → `../../../race.md`), else the
/// repository path as text.
fn race_doc_link(out: &Path) -> String {
    let names: Vec<&std::ffi::OsStr> = out
        .components()
        .filter_map(|c| match c {
            std::path::Component::Normal(n) => Some(n),
            _ => None,
        })
        .collect();
    match names.iter().rposition(|n| *n == "docs") {
        Some(i) => format!(
            "[docs/race.md]({}race.md)",
            "../".repeat(names.len() - i - 1)
        ),
        None => "docs/race.md in the pnsolver repository".to_string(),
    }
}

/// Writes `<out>/results.md`; returns its path.
pub fn write(out: &Path) -> Result<PathBuf> {
    let summary = Table::read_csv(&out.join("summary.csv")).context(
        "no summary.csv in the output folder (run `pn race` first, then --markdown-only)",
    )?;
    let mut s = format!(
        "# pn race: results\n\nGenerated by `pn race` from the CSV files in this folder \
         (`pn race --markdown-only --out <this folder>` rewrites it). Columns and method: {}.\n\n",
        race_doc_link(out)
    );
    s += "## All scenes side by side\n\n";
    s += "Relative RMSE = ‖image − reference‖₂ / ‖reference‖₂; seconds are wall seconds of \
          whole commands.\n\n";
    let recs = summary.records();
    s += &summary_table(&recs)?;
    let partial: Vec<BTreeMap<String, String>> = partial_scenes(out, &recs)?
        .into_iter()
        .map(|name| BTreeMap::from([("scene".to_string(), name)]))
        .collect();
    if !partial.is_empty() {
        let names: Vec<&str> = partial.iter().map(|r| get(r, "scene")).collect();
        let _ = write!(
            s,
            "\nNot in the table above (the run ended before these scenes were complete; \
             what they finished is below): {}.\n",
            names.join(", ")
        );
    }
    if out.join(ablation::ORDER_PLOT).is_file() {
        let _ = write!(
            s,
            "\n## Ablation: bias against the P_N order\n\nThe `{}` arms of every scene's \
             ablation (odd orders: circles on solid lines, even orders: triangles on dashed \
             lines); the tables are in each scene's Ablation section.\n\n![bias against the \
             P_N order]({})\n",
            ablation::ORDER_GROUP,
            ablation::ORDER_PLOT
        );
    }
    for r in recs.iter().chain(&partial) {
        s += &scene_section(out, r)?;
    }
    let p = out.join("results.md");
    std::fs::write(&p, s).with_context(|| format!("cannot write {}", p.display()))?;
    Ok(p)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::race::analysis::POINT_COLUMNS;

    #[test]
    fn markdown_lists_complete_and_interrupted_scenes() {
        let out = std::env::temp_dir().join(format!("pn-race-md-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&out);
        let mut summary = Table::new(SUMMARY_COLUMNS);
        summary
            .push(&[("scene", "a".into()), ("target_spp", "4".into())])
            .unwrap();
        std::fs::create_dir_all(out.join("a")).unwrap();
        std::fs::create_dir_all(out.join("b")).unwrap();
        summary.write_csv(&out.join("summary.csv")).unwrap();
        let mut pts = Table::new(POINT_COLUMNS);
        pts.push(&[
            ("family", "mitsuba".into()),
            ("settings", "spp=4".into()),
            ("spp", "4".into()),
            ("seconds", "1".into()),
            ("rel_rmse", "0.5".into()),
        ])
        .unwrap();
        pts.write_csv(&out.join("a/points.csv")).unwrap();
        pts.write_csv(&out.join("b/points.csv")).unwrap();
        let md = std::fs::read_to_string(write(&out).unwrap()).unwrap();
        assert!(md.contains("## a") && md.contains("## b"));
        assert!(md.contains("were complete; what they finished is below): b."));
        std::fs::remove_dir_all(&out).ok();
    }

    #[test]
    fn the_race_doc_link_is_relative_to_the_output_folder() {
        use super::race_doc_link;
        assert_eq!(
            race_doc_link(Path::new("docs/race")),
            "[docs/race.md](../race.md)"
        );
        assert_eq!(
            race_doc_link(Path::new("/x/docs/lab/race/2026-12-07-sky")),
            "[docs/race.md](../../../race.md)"
        );
        assert_eq!(
            race_doc_link(Path::new("out/race")),
            "docs/race.md in the pnsolver repository"
        );
    }
}
