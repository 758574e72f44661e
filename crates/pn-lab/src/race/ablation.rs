//! The ablation of `pn race --ablation` (issue 17): on every scene, each arm of a study
//! changes one suspected cause of pn's bias against Mitsuba (the vacuum treatment, the P_N
//! order, the solve resolution, the renderer's quadrature, the density filter, …) and is
//! rendered and judged against the scene's Mitsuba reference.
//!
//! A study is a TOML file of `[[arm]]` tables (`name`, `group`, `point`, optional `args`;
//! [`DEFAULT_STUDY`] is the built-in one, `race/default_study.toml` in the source, with the
//! format in its comments). Per scene it writes `ablation.csv` ([`COLUMNS`]); for all scenes
//! `bias_vs_order.png` (the bias of the `order` group's arms against the P_N order, odd and
//! even orders apart). The change columns are measured against the base: the first arm of
//! group `base`, else the first arm.

use super::metrics::{errors, Errors};
use super::plot::{draw_bias_vs_order, OrderSeries};
use super::pn_side::pn_settings;
use super::pn_side::{PnPoint, PnRunner};
use super::{Ctx, WORK};
use anyhow::{anyhow, bail, ensure, Context, Result};
use pn_formats::{num, Table};
use pn_render::compare::{read_gray, GrayImage};
use pn_render::{RenderScene, SceneOverride};
use serde::Deserialize;
use std::collections::{BTreeMap, HashMap, HashSet};
use std::io::Write;
use std::path::{Path, PathBuf};

/// The built-in study (`race/default_study.toml`): base P_3 @ 24³; the vacuum treatment
/// (box absorber, margin 8, σ_t thresholds 0.02 and 2, absorbing layers 4 and 8, Marshak
/// faces on a cropped grid at P_5); orders 1–5 and 7; solve resolutions 16–48 and P_5 @ 32³;
/// the fine quadrature; the nearest filter; the nearest lookup of the solution.
pub const DEFAULT_STUDY: &str = include_str!("default_study.toml");

/// Columns of `ablation.csv`.
pub const COLUMNS: &[&str] = &[
    "scene",
    "group",
    "arm",
    "point",
    "settings",
    "seconds",
    "rel_rmse",
    "rel_bias",
    "bias_change_vs_base",
    "image_change_vs_base",
    "converged",
    "error",
];

/// The name of the plot of the bias against the P_N order (in the race's output folder).
pub const ORDER_PLOT: &str = "bias_vs_order.png";

/// The group whose arms the order plot shows.
pub const ORDER_GROUP: &str = "order";

/// `pn render` flags an arm must not give: the point and the race set them.
const RESERVED: &[&str] = &[
    "--method",
    "--order",
    "--solve-res",
    "--out",
    "--turntable",
    "--threads",
];

/// One arm: a pn point and extra `pn render` arguments.
#[derive(Clone, Debug, PartialEq)]
pub struct Arm {
    /// Its name (unique within the group).
    pub name: String,
    /// What it probes (`base`, `vacuum`, `order`, …).
    pub group: String,
    /// Method, solve resolution and renderer settings.
    pub point: PnPoint,
    /// More `pn render` arguments (`--set solve.margin=8`, `--filter nearest`).
    pub args: Vec<String>,
}

impl Arm {
    /// The `--set` overrides among its arguments.
    fn overrides(&self) -> Result<Vec<SceneOverride>> {
        let mut v = vec![];
        let mut it = self.args.iter();
        while let Some(a) = it.next() {
            if let Some(val) = a.strip_prefix("--set=") {
                v.push(val.parse()?);
            } else if a == "--set" {
                let val = it.next().context("--set without a value")?;
                v.push(val.parse()?);
            }
        }
        Ok(v)
    }

    /// The render cache key: the same point and arguments are one render.
    fn key(&self) -> String {
        format!("{} {}", self.point.label(), self.args.join(" "))
    }
}

/// A study: its arms in order, and where it came from (for messages).
#[derive(Clone, Debug, PartialEq)]
pub struct Study {
    /// The file, or "built-in".
    pub source: String,
    /// The arms.
    pub arms: Vec<Arm>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct ArmToml {
    name: String,
    group: String,
    point: String,
    #[serde(default)]
    args: Vec<String>,
}

/// Refuses a name that would break the CSV or be invisible.
fn check_label(what: &str, v: &str) -> Result<()> {
    ensure!(!v.trim().is_empty(), "{what} is empty");
    ensure!(
        !v.contains([',', '"', '\n', '|']),
        "{what} {v:?} must not contain a comma, a double quote, '|' or a newline"
    );
    Ok(())
}

impl Study {
    /// The built-in study ([`DEFAULT_STUDY`]).
    pub fn builtin() -> Result<Self> {
        Self::parse(DEFAULT_STUDY, "built-in (race/default_study.toml)")
    }

    /// Reads a study file.
    pub fn from_file(path: &Path) -> Result<Self> {
        let text = pn_formats::read_text(path)
            .with_context(|| format!("cannot read ablation study {}", path.display()))?;
        Self::parse(&text, &path.display().to_string())
    }

    /// Parses a study; errors name `source` and the arm (its number and name).
    pub fn parse(text: &str, source: &str) -> Result<Self> {
        let ctx = || format!("ablation study {source}");
        let table: toml::Table = toml::from_str(text)
            .map_err(|e| anyhow!("{e}"))
            .with_context(ctx)?;
        if let Some(k) = table.keys().find(|k| *k != "arm") {
            bail!(
                "{}: unknown key {k:?} (a study is a list of [[arm]] tables)",
                ctx()
            );
        }
        let list = table
            .get("arm")
            .with_context(|| format!("{}: no [[arm]] tables", ctx()))?
            .as_array()
            .with_context(|| format!("{}: arm must be a list of [[arm]] tables", ctx()))?;
        ensure!(!list.is_empty(), "{}: no [[arm]] tables", ctx());
        let mut arms: Vec<Arm> = vec![];
        for (i, v) in list.iter().enumerate() {
            let label = match v.get("name").and_then(|n| n.as_str()) {
                Some(n) => format!("arm {} ({n:?})", i + 1),
                None => format!("arm {}", i + 1),
            };
            let arm = Self::arm(v)
                .with_context(|| label.clone())
                .with_context(ctx)?;
            if let Some(j) = arms
                .iter()
                .position(|a| a.group == arm.group && a.name == arm.name)
            {
                bail!(
                    "{}: {label}: group {:?} has an arm {:?} already (arm {})",
                    ctx(),
                    arm.group,
                    arm.name,
                    j + 1
                );
            }
            arms.push(arm);
        }
        Ok(Self {
            source: source.to_string(),
            arms,
        })
    }

    fn arm(v: &toml::Value) -> Result<Arm> {
        let a: ArmToml = v
            .clone()
            .try_into()
            .map_err(|e: toml::de::Error| anyhow!("{}", e.message().trim_end()))?;
        check_label("name", &a.name)?;
        check_label("group", &a.group)?;
        let point = PnPoint::parse(&a.point).context("point")?;
        for x in &a.args {
            let flag = x.split('=').next().unwrap_or(x);
            ensure!(
                !RESERVED.contains(&flag),
                "args: {flag} is set by the point ({:?}) or the race; give the method, order and \
                 resolution in `point`",
                a.point
            );
            ensure!(
                !(point.rays.is_some() && flag == "--rays"
                    || point.step.is_some() && flag == "--step"),
                "args: {flag} repeats the point's :{} option",
                flag.trim_start_matches('-')
            );
        }
        let arm = Arm {
            name: a.name,
            group: a.group,
            point,
            args: a.args,
        };
        arm.overrides().context("args")?;
        Ok(arm)
    }

    /// The base arm's index: the first of group `base`, else 0.
    pub fn base_index(&self) -> usize {
        self.arms
            .iter()
            .position(|a| a.group == "base")
            .unwrap_or(0)
    }

    /// Checks, before anything renders, that every arm's `--set` overrides apply to every
    /// scene and that no flag is given twice (by the race's `render_args`, the point and the
    /// arm).
    pub fn check(&self, scenes: &[String], render_args: &[String]) -> Result<()> {
        let mut seen: HashSet<String> = HashSet::new();
        for (i, arm) in self.arms.iter().enumerate() {
            let ctx = || {
                format!(
                    "ablation study {}: arm {} ({:?})",
                    self.source,
                    i + 1,
                    arm.name
                )
            };
            let mut flags: Vec<&str> = render_args
                .iter()
                .chain(&arm.args)
                .map(String::as_str)
                .filter(|a| a.starts_with("--") && !a.starts_with("--set"))
                .map(|a| a.split('=').next().unwrap_or(a))
                .collect();
            if arm.point.rays.is_some() {
                flags.push("--rays");
            }
            if arm.point.step.is_some() {
                flags.push("--step");
            }
            for (k, f) in flags.iter().enumerate() {
                ensure!(
                    !flags[..k].contains(f),
                    "{}: {f} is given twice (by --render-args, the point or the arm's args)",
                    ctx()
                );
            }
            let sets = arm.overrides().with_context(ctx)?;
            if sets.is_empty() {
                continue;
            }
            for s in scenes {
                let key = format!("{s}\u{0}{}", arm.args.join("\u{0}"));
                if !seen.insert(key) {
                    continue;
                }
                RenderScene::load_with_overrides(s, &sets)
                    .with_context(|| format!("scene {s}"))
                    .with_context(ctx)?;
            }
        }
        Ok(())
    }
}

/// A finished (or failed) render of an arm.
#[derive(Clone)]
struct Outcome {
    seconds: f64,
    converged: bool,
    image: GrayImage,
    errors: Errors,
}

/// Runs the study on one scene against its `reference`: one line per arm on `log`,
/// `<dir>/ablation.csv` rewritten after every arm. A render that fails is a row with its
/// error (the study goes on).
pub(super) fn run(
    ctx: &Ctx,
    study: &Study,
    name: &str,
    dir: &Path,
    runner: &PnRunner,
    reference: &GrayImage,
    log: &mut dyn Write,
) -> Result<()> {
    let adir = dir.join(WORK).join("ablation");
    let ref_norm = reference.data.iter().map(|v| v * v).sum::<f64>().sqrt();
    let base = study.base_index();
    let n = study.arms.len();
    let order: Vec<usize> = std::iter::once(base)
        .chain((0..n).filter(|&i| i != base))
        .collect();
    let mut done: HashMap<String, (usize, std::result::Result<Outcome, String>)> = HashMap::new();
    let mut rows: Vec<Option<Vec<(&'static str, String)>>> = vec![None; n];
    let mut base_out: Option<Outcome> = None;
    let path = dir.join("ablation.csv");
    for (k, &i) in order.iter().enumerate() {
        let arm = &study.arms[i];
        let key = arm.key();
        let (reused, outcome) = match done.get(&key) {
            Some((j, o)) => (Some(*j), o.clone()),
            None => {
                let out = adir.join(format!("{i:02}_{}", arm.point.folder()));
                let o = render_arm(runner, arm, &out, reference);
                done.insert(key, (i, o.clone()));
                (None, o)
            }
        };
        if i == base {
            base_out = outcome.as_ref().ok().cloned();
        }
        let mut all_args = ctx.req.render_args.clone();
        all_args.extend(arm.args.iter().cloned());
        let mut row = vec![
            ("scene", name.to_string()),
            ("group", arm.group.clone()),
            ("arm", arm.name.clone()),
            ("point", arm.point.label()),
            ("settings", pn_settings(&arm.point, &all_args)),
        ];
        let what = format!("{}/{}", arm.group, arm.name);
        let same = reused
            .map(|j| format!(" (the render of {:?})", study.arms[j].name))
            .unwrap_or_default();
        match &outcome {
            Ok(o) => {
                let (dbias, dimg) = match &base_out {
                    Some(b) => (
                        Some(100.0 * (o.errors.rel_bias - b.errors.rel_bias)),
                        Some(l2_difference(&o.image, &b.image)? / ref_norm),
                    ),
                    None => (None, None),
                };
                writeln!(
                    log,
                    "  ablation {:>2}/{n} {what:<28} {:<12} {:>7.2} s: bias {:+.2} %, rel. RMSE \
                     {:.4}{}{}{same}",
                    k + 1,
                    arm.point.label(),
                    o.seconds,
                    100.0 * o.errors.rel_bias,
                    o.errors.rel_rmse,
                    match (dbias, dimg) {
                        (Some(b), Some(d)) if i != base =>
                            format!("; vs base {b:+.2} pp, image change {d:.4}"),
                        _ => String::new(),
                    },
                    if o.converged {
                        ""
                    } else {
                        " (solver NOT converged)"
                    },
                )?;
                row.extend([
                    ("seconds", num(Some(o.seconds))),
                    ("rel_rmse", num(Some(o.errors.rel_rmse))),
                    ("rel_bias", num(Some(o.errors.rel_bias))),
                    ("bias_change_vs_base", num(dbias)),
                    ("image_change_vs_base", num(dimg)),
                    ("converged", o.converged.to_string()),
                ]);
            }
            Err(e) => {
                writeln!(
                    log,
                    "  ablation {:>2}/{n} {what:<28} {:<12} FAILED{same}: {e}",
                    k + 1,
                    arm.point.label()
                )?;
                row.push(("error", csv_safe(e, 300)));
            }
        }
        rows[i] = Some(row);
        let mut t = Table::new(COLUMNS);
        for r in rows.iter().flatten() {
            t.push(r)?;
        }
        t.write_csv(&path)?;
    }
    Ok(())
}

/// Renders one arm and judges it; an error as text.
fn render_arm(
    runner: &PnRunner,
    arm: &Arm,
    out: &Path,
    reference: &GrayImage,
) -> std::result::Result<Outcome, String> {
    let go = || -> Result<Outcome> {
        let r = runner.render(&arm.point, out, &arm.args)?;
        let image = read_gray(&r.images[0])?;
        let errors = errors(&image, reference)?;
        Ok(Outcome {
            seconds: r.wall,
            converged: r.converged,
            image,
            errors,
        })
    };
    go().map_err(|e| format!("{e:#}"))
}

/// ‖a − b‖₂ over all pixels.
fn l2_difference(a: &GrayImage, b: &GrayImage) -> Result<f64> {
    ensure!(
        a.data.len() == b.data.len(),
        "internal: ablation images of different sizes"
    );
    Ok(a.data
        .iter()
        .zip(&b.data)
        .map(|(x, y)| (x - y) * (x - y))
        .sum::<f64>()
        .sqrt())
}

/// `s` as one CSV cell: no comma, quote or newline, at most `max` characters.
fn csv_safe(s: &str, max: usize) -> String {
    let one: String = s
        .chars()
        .map(|c| match c {
            ',' => ';',
            '"' => '\'',
            '\n' | '\r' => ' ',
            c => c,
        })
        .collect();
    let mut t: String = one.chars().take(max).collect();
    if one.chars().count() > max {
        t.push('…');
    }
    t
}

/// The `order` group's (order, bias in %) per scene, from `<out>/<scene>/ablation.csv`.
fn order_series(out: &Path) -> Result<Vec<OrderSeries>> {
    if !out.is_dir() {
        return Ok(vec![]);
    }
    let mut dirs: Vec<PathBuf> = std::fs::read_dir(out)
        .with_context(|| format!("cannot list {}", out.display()))?
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.join("ablation.csv").is_file())
        .collect();
    dirs.sort();
    let mut all = vec![];
    for d in dirs {
        let t = Table::read_csv(&d.join("ablation.csv"))?;
        let mut points = vec![];
        for r in t.records() {
            if r.get("group").map(String::as_str) != Some(ORDER_GROUP) {
                continue;
            }
            let order = r
                .get("point")
                .and_then(|p| PnPoint::parse(p).ok())
                .and_then(|p| p.family.order());
            let bias = r.get("rel_bias").and_then(|b| b.parse::<f64>().ok());
            if let (Some(o), Some(b)) = (order, bias) {
                points.push((o, 100.0 * b));
            }
        }
        if !points.is_empty() {
            points.sort_by_key(|p| p.0);
            points.dedup_by_key(|p| p.0);
            let scene = d
                .file_name()
                .map(|n| n.to_string_lossy().into_owned())
                .unwrap_or_default();
            all.push(OrderSeries { scene, points });
        }
    }
    Ok(all)
}

/// Draws `<out>/bias_vs_order.png` from every scene's `ablation.csv`; `None` when no scene
/// has arms of the `order` group.
pub fn draw_order_plot(out: &Path) -> Result<Option<PathBuf>> {
    let series = order_series(out)?;
    if series.is_empty() {
        return Ok(None);
    }
    let path = out.join(ORDER_PLOT);
    draw_bias_vs_order(&path, &series)?;
    Ok(Some(path))
}

fn get<'a>(r: &'a BTreeMap<String, String>, k: &str) -> &'a str {
    r.get(k).map(String::as_str).unwrap_or("")
}

fn pct(v: &str, scale: f64, unit: &str) -> String {
    v.parse::<f64>()
        .map(|x| format!("{:+.2}{unit}", scale * x))
        .unwrap_or_default()
}

/// The Markdown of one scene's `ablation.csv`: one table, rows grouped by group (in the
/// order of their first arm). A file of the former four-step ablation (a `step` column)
/// is shown as it is.
pub fn markdown(t: &Table) -> Result<String> {
    let mut s = String::new();
    let recs = t.records();
    if !t.header.iter().any(|h| h == "group") {
        s += "\nAblation (former four-step form: each step refines one thing; `change` = \
              ‖image − previous image‖₂ / ‖reference‖₂, the error that step removes):\n\n";
        s += &t
            .select(&[
                ("step", "step"),
                ("point", "point"),
                ("settings", "settings"),
                ("seconds", "seconds"),
                ("rel. RMSE", "rel_rmse"),
                ("rel. bias", "rel_bias"),
                ("change", "change_from_previous"),
            ])
            .to_markdown();
        return Ok(s);
    }
    s += "\n### Ablation\n\nEach arm changes one thing against the base (pn render \
          arguments in `settings`); bias = (mean image − mean reference) / mean reference; \
          Δ bias = bias − the base's bias in percentage points; image change = ‖image − base \
          image‖₂ / ‖reference‖₂.\n\n";
    let mut md = Table::new(&[
        "group",
        "arm",
        "point",
        "settings",
        "seconds",
        "rel. RMSE",
        "bias",
        "Δ bias vs base",
        "image change vs base",
        "converged",
    ]);
    let mut groups: Vec<&str> = vec![];
    for r in &recs {
        let g = get(r, "group");
        if !groups.contains(&g) {
            groups.push(g);
        }
    }
    for g in groups {
        let mut first = true;
        for r in recs.iter().filter(|r| get(r, "group") == g) {
            let failed = get(r, "error");
            md.push_row([
                if first { g } else { "" }.to_string(),
                get(r, "arm").to_string(),
                get(r, "point").to_string(),
                get(r, "settings").to_string(),
                get(r, "seconds").to_string(),
                if failed.is_empty() {
                    get(r, "rel_rmse").to_string()
                } else {
                    format!("failed: {failed}")
                },
                pct(get(r, "rel_bias"), 100.0, " %"),
                pct(get(r, "bias_change_vs_base"), 1.0, " pp"),
                get(r, "image_change_vs_base").to_string(),
                get(r, "converged").to_string(),
            ])?;
            first = false;
        }
    }
    s += &md.to_markdown();
    Ok(s)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::race::Family;

    #[test]
    fn the_default_study_parses_with_its_arms() {
        let s = Study::builtin().unwrap();
        let names: Vec<String> = s
            .arms
            .iter()
            .map(|a| format!("{}/{}", a.group, a.name))
            .collect();
        for want in [
            "base/base",
            "vacuum/absorber box",
            "vacuum/margin 8",
            "vacuum/sigma_t_min 0.02",
            "vacuum/sigma_t_min 2",
            "vacuum/absorbing layer 4",
            "vacuum/absorbing layer 8",
            "vacuum/marshak cropped (P_5)",
            "lookup/lookup nearest",
            "order/p2",
            "order/p7",
            "resolution/res 48",
            "quadrature/fine",
            "filter/nearest",
        ] {
            assert!(names.iter().any(|n| n == want), "{want} missing: {names:?}");
        }
        assert_eq!(s.base_index(), 0);
        assert_eq!(s.arms[0].point.label(), "p3@24");
        let orders: Vec<usize> = s
            .arms
            .iter()
            .filter(|a| a.group == ORDER_GROUP)
            .filter_map(|a| a.point.family.order())
            .collect();
        assert_eq!(orders, [1, 2, 3, 4, 5, 7]);
        let margin = s.arms.iter().find(|a| a.name == "margin 8").unwrap();
        assert_eq!(margin.args, ["--set", "solve.margin=8"]);
        assert_eq!(margin.overrides().unwrap()[0].key(), "solve.margin");
        // The base and the order group's p3 are one render.
        let p3 = s.arms.iter().find(|a| a.name == "p3").unwrap();
        assert_eq!(p3.key(), s.arms[0].key());
        let renders: HashSet<String> = s.arms.iter().map(Arm::key).collect();
        assert_eq!((s.arms.len(), renders.len()), (22, 20));
        // Every --set applies to every built-in render scene; no flag twice.
        let scenes: Vec<String> = ["sphere", "cloud"].map(String::from).to_vec();
        s.check(&scenes, &[]).unwrap();
        let e = format!(
            "{:#}",
            s.check(&scenes, &["--rays".into(), "1".into()])
                .unwrap_err()
        );
        assert!(
            e.contains("arm 18 (\"fine\")") && e.contains("--rays"),
            "{e}"
        );
    }

    fn err(text: &str) -> String {
        format!("{:#}", Study::parse(text, "s.toml").unwrap_err())
    }

    #[test]
    fn malformed_studies_name_the_file_and_the_arm() {
        let ok = "[[arm]]\nname = \"a\"\ngroup = \"base\"\npoint = \"p1@8\"\n";
        let s = Study::parse(ok, "s.toml").unwrap();
        assert_eq!(s.arms[0].point.family, Family::Pn(1));
        assert!(s.arms[0].args.is_empty());
        let second = |extra: &str| format!("{ok}[[arm]]\nname = \"b\"\n{extra}");
        for (text, want) in [
            (
                second("group = \"g\"\n"),
                "arm 2 (\"b\"): missing field `point`",
            ),
            (
                second("group = \"g\"\npoint = \"p3\"\n"),
                "arm 2 (\"b\"): point: pn point \"p3\"",
            ),
            (
                second("group = \"g\"\npoint = \"p3@8\"\ncolour = 1\n"),
                "unknown field `colour`",
            ),
            (
                second("group = \"g\"\npoint = \"p3@8\"\nargs = [\"--order\", \"5\"]\n"),
                "--order is set by the point",
            ),
            (
                second("group = \"g\"\npoint = \"p3@8:rays=4\"\nargs = [\"--rays\", \"16\"]\n"),
                "repeats the point's :rays",
            ),
            (
                second("group = \"g\"\npoint = \"p3@8\"\nargs = [\"--set\", \"solve\"]\n"),
                "SECTION.KEY=VALUE",
            ),
            (
                second("group = \"g\"\npoint = \"p3@8\"\nargs = [\"--set\"]\n"),
                "--set without a value",
            ),
            (
                second("group = \"base\"\npoint = \"p3@8\"\n").replace("\"b\"", "\"a\""),
                "group \"base\" has an arm \"a\" already (arm 1)",
            ),
            (
                second("group = \"g,h\"\npoint = \"p3@8\"\n"),
                "must not contain a comma",
            ),
            (second("group = 3\npoint = \"p3@8\"\n"), "arm 2 (\"b\")"),
            (format!("{ok}[other]\nx = 1\n"), "unknown key \"other\""),
            (String::new(), "no [[arm]]"),
            ("arm = 3\n".into(), "list of [[arm]]"),
            ("[[arm]\n".into(), "line 1"),
        ] {
            let e = err(&text);
            assert!(e.contains("ablation study s.toml"), "{e}");
            assert!(e.contains(want), "want {want:?}: {e}");
        }
        // An arm without a name is named by its number.
        let e = err("[[arm]]\ngroup = \"g\"\npoint = \"p1@8\"\n");
        assert!(e.contains("arm 1: missing field `name`"), "{e}");
        // A --set key the scene does not have: named before anything renders.
        let bad =
            second("group = \"g\"\npoint = \"p1@8\"\nargs = [\"--set\", \"solve.nonsense=1\"]\n");
        let e = format!(
            "{:#}",
            Study::parse(&bad, "s.toml")
                .unwrap()
                .check(&["sphere".to_string()], &[])
                .unwrap_err()
        );
        assert!(
            e.contains("arm 2 (\"b\")") && e.contains("scene sphere") && e.contains("nonsense"),
            "{e}"
        );
        // Without a base group the first arm is the base.
        let s = Study::parse(
            &second("group = \"g\"\npoint = \"p3@8\"\n").replace("base", "x"),
            "s",
        )
        .unwrap();
        assert_eq!(s.base_index(), 0);
    }

    #[test]
    fn markdown_groups_rows_and_reads_the_former_form() {
        let mut t = Table::new(COLUMNS);
        for (g, a, b) in [
            ("base", "base", "-0.2"),
            ("order", "p1", "-0.3"),
            ("vacuum", "margin 8", "-0.19"),
            ("order", "p5", "-0.1"),
        ] {
            t.push(&[
                ("group", g.into()),
                ("arm", a.into()),
                ("rel_bias", b.into()),
                ("bias_change_vs_base", "1.5".into()),
            ])
            .unwrap();
        }
        let md = markdown(&t).unwrap();
        let order = md.find("| order | p1").unwrap();
        assert!(md.find("|  | p5").unwrap() > order, "{md}");
        assert!(
            md.find("| vacuum").unwrap() > md.find("|  | p5").unwrap(),
            "{md}"
        );
        assert!(md.contains("-30.00 %") && md.contains("+1.50 pp"), "{md}");
        let old = Table::new(&["scene", "step", "point", "change_from_previous"]);
        assert!(markdown(&old).unwrap().contains("former four-step form"));
    }

    #[test]
    fn csv_cells_are_made_safe() {
        assert_eq!(csv_safe("a,b\n\"c\"", 100), "a;b 'c'");
        assert_eq!(csv_safe("abcdef", 3), "abc…");
    }
}
