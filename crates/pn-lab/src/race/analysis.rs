//! Derived columns and crossing points of a race table, computed from the table's records
//! alone (the same code serves the run and the Markdown writer).

use super::metrics::{excess, spp_for_error, time_to_reach};
use pn_formats::{num, Table};
use std::collections::BTreeMap;

/// Family name of plain Mitsuba in the CSV.
pub const MITSUBA: &str = "mitsuba";
/// Family name of denoised Mitsuba in the CSV.
pub const MITSUBA_OIDN: &str = "mitsuba+oidn";

/// The columns of `points.csv` (docs/race.md explains each).
pub const POINT_COLUMNS: &[&str] = &[
    "scene",
    "tool",
    "family",
    "settings",
    "spp",
    "order",
    "solve_res",
    "seconds",
    "seconds_render",
    "seconds_solve",
    "seconds_setup",
    "seconds_denoise",
    "iterations",
    "rel_rmse",
    "rel_rmse_excess",
    "rel_bias",
    "mean",
    "mitsuba_equal_error_seconds",
    "mitsuba_extrapolated",
    "speedup_vs_mitsuba",
    "oidn_equal_error_seconds",
    "speedup_vs_oidn",
    "runs",
];

/// One point as read from a record.
#[derive(Clone, Debug)]
pub struct Pt {
    /// Family column.
    pub family: String,
    /// Settings column.
    pub settings: String,
    /// spp (Mitsuba).
    pub spp: Option<usize>,
    /// Wall seconds.
    pub seconds: f64,
    /// Seconds in the renderer alone.
    pub seconds_render: f64,
    /// Relative RMSE.
    pub rel_rmse: f64,
    /// Relative bias.
    pub rel_bias: f64,
}

fn f(r: &BTreeMap<String, String>, k: &str) -> f64 {
    r.get(k).and_then(|v| v.parse().ok()).unwrap_or(f64::NAN)
}

/// The points of a table.
pub fn points(t: &Table) -> Vec<Pt> {
    t.records()
        .iter()
        .map(|r| Pt {
            family: r.get("family").cloned().unwrap_or_default(),
            settings: r.get("settings").cloned().unwrap_or_default(),
            spp: r.get("spp").and_then(|v| v.parse().ok()),
            seconds: f(r, "seconds"),
            seconds_render: f(r, "seconds_render"),
            rel_rmse: f(r, "rel_rmse"),
            rel_bias: f(r, "rel_bias"),
        })
        .collect()
}

/// The (seconds, error) curve of a family, in table order (increasing spp for Mitsuba, the
/// ladder's order for pn).
pub fn curve(pts: &[Pt], family: &str) -> Vec<(f64, f64)> {
    pts.iter()
        .filter(|p| p.family == family)
        .map(|p| (p.seconds, p.rel_rmse))
        .collect()
}

/// Plain Mitsuba's time to reach `target`: interpolated between the measured points, or,
/// below the most accurate one, extrapolated with the spp^(-1/2) law on the error in excess
/// of the reference noise (the render part scaled by the spp, the rest of the command kept).
/// Returns (seconds, extrapolated).
pub fn mitsuba_time_for(pts: &[Pt], target: f64, ref_noise: f64) -> Option<(f64, bool)> {
    let c = curve(pts, MITSUBA);
    if let Some(t) = time_to_reach(&c, target) {
        return Some((t, false));
    }
    let mi: Vec<&Pt> = pts.iter().filter(|p| p.family == MITSUBA).collect();
    let last = mi.iter().max_by_key(|p| p.spp.unwrap_or(0))?;
    let spp_last = last.spp? as f64;
    let goal = excess(target, ref_noise);
    let fit: Vec<(usize, f64)> = mi
        .iter()
        .filter_map(|p| Some((p.spp?, excess(p.rel_rmse, ref_noise))))
        .collect();
    let spp = spp_for_error(&fit, goal)?;
    let render = if last.seconds_render.is_finite() {
        last.seconds_render
    } else {
        last.seconds
    };
    Some((last.seconds - render + render * spp / spp_last, true))
}

/// Fills the equal-error columns of every pn row of `t` (and of the denoised rows, against
/// plain Mitsuba).
pub fn derive(t: &mut Table, ref_noise: f64) {
    let pts = points(t);
    let oidn = curve(&pts, MITSUBA_OIDN);
    let col = |name: &str| t.header.iter().position(|h| h == name);
    let (Some(ci), Some(cx), Some(cs), Some(co), Some(cso)) = (
        col("mitsuba_equal_error_seconds"),
        col("mitsuba_extrapolated"),
        col("speedup_vs_mitsuba"),
        col("oidn_equal_error_seconds"),
        col("speedup_vs_oidn"),
    ) else {
        return;
    };
    for (row, p) in t.rows.iter_mut().zip(&pts) {
        if p.family == MITSUBA || !p.rel_rmse.is_finite() {
            continue;
        }
        if let Some((s, extrapolated)) = mitsuba_time_for(&pts, p.rel_rmse, ref_noise) {
            row[ci] = num(Some(s));
            row[cx] = if extrapolated { "yes" } else { "no" }.into();
            row[cs] = num(Some(s / p.seconds));
        }
        if p.family != MITSUBA_OIDN {
            if let Some(s) = time_to_reach(&oidn, p.rel_rmse) {
                // Only where the denoised curve really gets there (not its first point's
                // time for an error it already beats).
                if oidn.first().is_some_and(|f| f.1 > p.rel_rmse) {
                    row[co] = num(Some(s));
                    row[cso] = num(Some(s / p.seconds));
                }
            }
        }
    }
}

/// A readable family name.
pub fn family_name(fam: &str) -> String {
    match fam {
        MITSUBA => "Mitsuba".into(),
        MITSUBA_OIDN => "Mitsuba + OIDN".into(),
        "cda" => "pn CDA".into(),
        "none" => "pn single scattering".into(),
        "fld" => "pn FLD".into(),
        "pop" => "pn POP".into(),
        f if f.starts_with("pde:") => format!("pn PDE {}", &f[4..]),
        f if f.starts_with("sn") => format!("pn DSA S_N L={}", &f[2..]),
        f => match f.strip_prefix('p') {
            Some(n) => format!("pn P_{n}"),
            None => f.into(),
        },
    }
}

/// The families of a table in order: Mitsuba, Mitsuba + OIDN, then pn's as they appear.
pub fn families(pts: &[Pt]) -> Vec<String> {
    let mut v: Vec<String> = vec![];
    for p in pts {
        if !v.contains(&p.family) {
            v.push(p.family.clone());
        }
    }
    v.sort_by_key(|f| match f.as_str() {
        MITSUBA => 0,
        MITSUBA_OIDN => 1,
        _ => 2,
    });
    v
}

/// The crossing points against plain Mitsuba at `target_spp`: for every other family, the
/// fastest point at or below that error, one sentence each. Also returns the
/// fastest pn point that reaches it: (settings, seconds, speedup).
pub fn crossings(pts: &[Pt], target_spp: usize) -> (Vec<String>, Option<(String, f64, f64)>) {
    let mut lines = vec![];
    let Some(target) = pts
        .iter()
        .find(|p| p.family == MITSUBA && p.spp == Some(target_spp))
    else {
        return (
            vec![format!("no plain Mitsuba point at {target_spp} spp")],
            None,
        );
    };
    let (e, t) = (target.rel_rmse, target.seconds);
    let mut best: Option<(String, f64, f64)> = None;
    for fam in families(pts) {
        if fam == MITSUBA {
            continue;
        }
        let mine: Vec<&Pt> = pts.iter().filter(|p| p.family == fam).collect();
        let name = family_name(&fam);
        // The fastest point of the family at or below the target error.
        match mine
            .iter()
            .filter(|p| p.rel_rmse <= e)
            .min_by(|a, b| a.seconds.total_cmp(&b.seconds))
        {
            Some(p) => {
                let ratio = t / p.seconds;
                let verdict = if ratio >= 1.0 {
                    format!("{ratio:.1}× sooner than")
                } else {
                    format!("{:.1}× slower than", 1.0 / ratio)
                };
                lines.push(format!(
                    "{name} {} reaches Mitsuba-{target_spp}spp's error {e:.3} in {:.2} s \
                     (error {:.3}, bias {:+.1} %): {verdict} Mitsuba's {t:.2} s",
                    p.settings,
                    p.seconds,
                    p.rel_rmse,
                    100.0 * p.rel_bias,
                ));
                if fam != MITSUBA_OIDN && best.as_ref().is_none_or(|b| p.seconds < b.1) {
                    best = Some((format!("{name} {}", p.settings), p.seconds, t / p.seconds));
                }
            }
            None => {
                if let Some(b) = mine.iter().min_by(|a, b| a.rel_rmse.total_cmp(&b.rel_rmse)) {
                    lines.push(format!(
                        "{name} does not reach Mitsuba-{target_spp}spp's error {e:.3}: best \
                         {:.3} ({}, {:.2} s, bias {:+.1} %)",
                        b.rel_rmse,
                        b.settings,
                        b.seconds,
                        100.0 * b.rel_bias
                    ));
                }
            }
        }
    }
    (lines, best)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn table() -> Table {
        let mut t = Table::new(POINT_COLUMNS);
        for (fam, settings, spp, s, r, e) in [
            (MITSUBA, "spp=1", "1", 0.5, 0.1, 0.8),
            (MITSUBA, "spp=4", "4", 0.8, 0.4, 0.4),
            (MITSUBA, "spp=16", "16", 2.0, 1.6, 0.2),
            (MITSUBA_OIDN, "spp=1", "1", 0.6, 0.1, 0.3),
            (MITSUBA_OIDN, "spp=4", "4", 0.9, 0.4, 0.15),
            ("p3", "res=16", "", 0.3, 0.1, 0.5),
            ("p3", "res=32", "", 1.0, 0.1, 0.19),
            ("p5", "res=32", "", 3.0, 0.1, 0.05),
        ] {
            t.push(&[
                ("family", fam.into()),
                ("settings", settings.into()),
                ("spp", spp.into()),
                ("seconds", s.to_string()),
                ("seconds_render", r.to_string()),
                ("rel_rmse", e.to_string()),
                ("rel_bias", "0".into()),
            ])
            .unwrap();
        }
        t
    }

    #[test]
    fn crossing_and_equal_error_columns() {
        let mut t = table();
        derive(&mut t, 0.0);
        let rec = t.records();
        // p3@16 (0.5) lies between Mitsuba 1 spp (0.8 at 0.5 s) and 4 spp (0.4 at 0.8 s).
        let s: f64 = rec[5]["mitsuba_equal_error_seconds"].parse().unwrap();
        assert!(s > 0.5 && s < 0.8 && rec[5]["mitsuba_extrapolated"] == "no");
        // p5 (0.05) is below every Mitsuba point: 16 spp · (0.2/0.05)² = 256 spp,
        // 0.4 s + 1.6 s · 16.
        let s: f64 = rec[7]["mitsuba_equal_error_seconds"].parse().unwrap();
        assert!((s - (0.4 + 1.6 * 16.0)).abs() < 1e-3 && rec[7]["mitsuba_extrapolated"] == "yes");
        // The denoised curve reaches 0.19 only between its points? It starts at 0.3 > 0.19
        // and reaches 0.15 at 0.9 s: interpolated.
        let s: f64 = rec[6]["oidn_equal_error_seconds"].parse().unwrap();
        assert!(s > 0.6 && s < 0.9);
        let (lines, best) = crossings(&points(&t), 16);
        assert_eq!(lines.len(), 3, "{lines:?}");
        let (name, secs, speedup) = best.unwrap();
        assert_eq!(name, "pn P_3 res=32");
        assert!((secs - 1.0).abs() < 1e-12 && (speedup - 2.0).abs() < 1e-12);
    }

    #[test]
    fn family_names_are_readable() {
        let names: Vec<String> = ["p5", "cda", "fld", "pop", "none", "pde:fpn N=5", "sn5"]
            .into_iter()
            .map(family_name)
            .collect();
        assert_eq!(
            names,
            [
                "pn P_5",
                "pn CDA",
                "pn FLD",
                "pn POP",
                "pn single scattering",
                "pn PDE fpn N=5",
                "pn DSA S_N L=5"
            ]
        );
    }
}
