//! `pn figure nebula`: the comparison figure (docs/rendering.md). Renders one scene with
//! single scattering only, CDA, FLD, POP (directional lights; docs/pop-design.md), P_1, P_3
//! and P_5 (the same renderer for all: by default
//! the deterministic one, so the panels differ by the method alone; with `--renderer
//! montecarlo` the same camera rays and seeds), and — when a Mitsuba reference is given (`--reference`), already present as
//! `<out>/mitsuba.exr`, or rendered on request (`--mitsuba`) — compares each against it.
//!
//! Writes `<out>/<method>/{image.exr,image.png,report.json}` (and `difference.png`, the
//! signed false-colour difference of `pn compare`, with a reference), `figure.png` (the
//! images side by side, one exposure for all, labelled with method and times; with a
//! reference a second row of absolute-error maps on one common scale) and `table.csv` /
//! `table.md` (method, solve seconds, render seconds, unknowns, RMSE and relative MSE
//! against the reference).

use anyhow::{ensure, Context, Result};
use plotters::prelude::*;
use pn_drivers::compare::write_difference_png;
use pn_drivers::render::{render_scene, write_run, RenderOptions, RenderRun};
use pn_formats::Table;
use pn_formats::{exposure, read_exr_gray, srgb8};
use pn_render::compare::{metrics, GrayImage, Metrics};
use pn_render::scene::{RenderMethod, RendererKind};
use pn_render::{DensityFilter, RenderScene, SceneOverride};
use pn_runtime::solver::SolverTuning;
use std::path::{Path, PathBuf};

/// The options of `pn figure`.
#[derive(Clone, Debug, PartialEq)]
pub struct FigureRequest {
    /// The scene: a built-in name or a `.toml` file.
    pub scene: String,
    /// Output directory (default `out/figure-<scene>`).
    pub out: Option<PathBuf>,
    /// Samples per pixel of the Monte Carlo renderer (default: the scene's).
    pub spp: Option<usize>,
    /// The renderer (default: the scene's, deterministic unless it says otherwise).
    pub renderer: Option<RendererKind>,
    /// Camera rays per pixel of the deterministic renderer, k² (default: the scene's).
    pub rays: Option<usize>,
    /// Step of the deterministic renderer in voxel sides (default: the scene's).
    pub step: Option<f64>,
    /// Density filter, overriding the scene's `[medium] filter`.
    pub filter: Option<DensityFilter>,
    /// Solve-grid cells per axis across the medium box (default: the scene's).
    pub solve_res: Option<usize>,
    /// Mitsuba reference EXR (default: `<out>/mitsuba.exr` when it exists).
    pub reference: Option<PathBuf>,
    /// Export the scene and render the reference with Mitsuba first.
    pub mitsuba: bool,
    /// Samples per pixel of the Mitsuba reference (with `mitsuba`).
    pub mitsuba_spp: usize,
    /// The Python interpreter with Mitsuba chosen by the caller (`pn`: `--python`, else
    /// `$PN_MITSUBA_PYTHON`); `None`: the venv of `scripts/mitsuba-venv.sh`.
    pub python: Option<PathBuf>,
    /// Worker threads (default: all cores).
    pub threads: Option<usize>,
    /// `--set SECTION.KEY=VALUE` overrides of the scene's TOML (as `pn render --set`).
    pub set: Vec<SceneOverride>,
    /// Expert solver settings (the `pn` binary reads them from the environment).
    pub tuning: SolverTuning,
}

impl Default for FigureRequest {
    /// The `nebula` figure with the scene's settings, no Mitsuba run, 1024 reference spp.
    fn default() -> Self {
        Self {
            scene: "nebula".into(),
            out: None,
            spp: None,
            renderer: None,
            rays: None,
            step: None,
            filter: None,
            solve_res: None,
            reference: None,
            mitsuba: false,
            mitsuba_spp: 1024,
            python: None,
            threads: None,
            set: Vec::new(),
            tuning: SolverTuning::default(),
        }
    }
}

/// One column of the figure.
struct Entry {
    label: &'static str,
    key: &'static str,
    run: RenderRun,
    metrics: Option<Metrics>,
}

/// The methods of the figure: (label, directory, method, P_N order or POP's bands). P_5
/// stays last: without a reference its image sets the common exposure.
const METHODS: [(&str, &str, RenderMethod, usize); 7] = [
    ("single scattering", "single", RenderMethod::None, 1),
    ("CDA", "cda", RenderMethod::Cda, 1),
    ("FLD", "fld", RenderMethod::Fld, 1),
    ("POP", "pop", RenderMethod::Pop, 3),
    ("P1", "p1", RenderMethod::Pn, 1),
    ("P3", "p3", RenderMethod::Pn, 3),
    ("P5", "p5", RenderMethod::Pn, 5),
];

fn gray(run: &RenderRun) -> GrayImage {
    GrayImage {
        width: run.image.width,
        height: run.image.height,
        data: run.image.data.iter().map(|v| *v as f64).collect(),
    }
}

/// Runs `pn figure`: renders every method, writes the images, `figure.png` and the tables,
/// and prints the table to `stdout`.
pub fn run(a: &FigureRequest, stdout: &mut dyn std::io::Write) -> Result<()> {
    let mut scene = RenderScene::load_with_overrides(&a.scene, &a.set)?;
    if let Some(s) = a.spp {
        scene.render.spp = s;
    }
    if let Some(r) = a.renderer {
        scene.render.renderer = r;
    }
    if let Some(r) = a.rays {
        scene.render.rays = r;
    }
    if let Some(s) = a.step {
        scene.render.step = s;
    }
    if let Some(f) = a.filter {
        scene.medium.filter = f;
    }
    if let Some(r) = a.solve_res {
        scene.solve.resolution = [r; 3];
    }
    scene.render.validate()?;
    scene.solve.validate()?;
    let out = a
        .out
        .clone()
        .unwrap_or_else(|| PathBuf::from("out").join(format!("figure-{}", scene.name)));
    // What can fail cheaply fails before the folder exists: the reference named on the
    // command line, and the Python that would render one.
    pn_formats::files::check_output_dir(&out)?;
    let given_reference = match &a.reference {
        Some(p) => Some(read_reference(p, &scene)?),
        None => None,
    };
    let python = if a.mitsuba {
        let python = pn_drivers::mitsuba::find_python(a.python.as_deref())?;
        pn_drivers::mitsuba::check_python(&python)?;
        Some(python)
    } else {
        None
    };
    let created = !out.exists();
    std::fs::create_dir_all(&out).with_context(|| format!("cannot create {}", out.display()))?;
    let result = render_all(a, &scene, &out, given_reference, python.as_deref(), stdout);
    if result.is_err() && created {
        // A failed figure leaves no half-written folder behind (issue 53).
        let _ = std::fs::remove_dir_all(&out);
    }
    result
}

/// Reads a reference image and checks it has the scene's size.
fn read_reference(p: &Path, scene: &RenderScene) -> Result<GrayImage> {
    let (w, h, data) = read_exr_gray(p)?;
    ensure!(
        (w, h) == (scene.camera.width, scene.camera.height),
        "the reference {} is {w}×{h}, the scene renders {}×{}",
        p.display(),
        scene.camera.width,
        scene.camera.height
    );
    Ok(GrayImage {
        width: w,
        height: h,
        data: data.into_iter().map(f64::from).collect(),
    })
}

/// Renders every method into `out` (which exists), with the figure and the tables.
fn render_all(
    a: &FigureRequest,
    scene: &RenderScene,
    out: &Path,
    given_reference: Option<GrayImage>,
    python: Option<&Path>,
    stdout: &mut dyn std::io::Write,
) -> Result<()> {
    if let Some(python) = python {
        render_reference(scene, out, a, python)?;
    }
    let ref_path = a
        .reference
        .clone()
        .or_else(|| Some(out.join("mitsuba.exr")).filter(|p| p.is_file()));
    let reference = match (given_reference, &ref_path) {
        (Some(r), _) => Some(r),
        (None, Some(p)) => Some(read_reference(p, scene)?),
        (None, None) => None,
    };

    let mut entries = Vec::new();
    for (label, key, method, order) in METHODS {
        let mut s = scene.clone();
        s.solve.method = method;
        s.solve.order = order;
        eprintln!("rendering {label} ...");
        let options = RenderOptions {
            threads: a.threads,
            max_memory: None,
            progress: true,
            tuning: a.tuning.clone(),
            ..Default::default()
        };
        let run = render_scene(&s, &options)?;
        let dir = out.join(key);
        write_run(&dir, &run)?;
        let m = match &reference {
            Some(r) => {
                let g = gray(&run);
                write_difference_png(
                    &dir.join("difference.png"),
                    &g,
                    r,
                    &format!("{label} − Mitsuba"),
                )?;
                Some(metrics(&g, r)?)
            }
            None => None,
        };
        entries.push(Entry {
            label,
            key,
            run,
            metrics: m,
        });
    }
    write_tables(out, &entries, ref_path.as_deref())?;
    write_figure(&out.join("figure.png"), &entries, reference.as_ref())?;
    write!(stdout, "{}", std::fs::read_to_string(out.join("table.md"))?)?;
    writeln!(stdout, "-> {}", out.display())?;
    Ok(())
}

/// Exports the scene and renders `<out>/mitsuba.exr` with Mitsuba (full transport).
fn render_reference(
    scene: &RenderScene,
    out: &Path,
    a: &FigureRequest,
    python: &Path,
) -> Result<()> {
    use pn_drivers::mitsuba;
    use pn_render::mitsuba::ExportOptions;
    let dir = out.join("mitsuba");
    let opts = ExportOptions {
        spp: a.mitsuba_spp,
        ..ExportOptions::from_scene(scene)
    };
    mitsuba::export(scene, &dir, &opts)?;
    eprintln!(
        "rendering the Mitsuba reference ({} spp) ...",
        a.mitsuba_spp
    );
    let run = mitsuba::run_mitsuba_with(
        &dir,
        python,
        &mitsuba::RunOptions {
            out: Some(out.join("mitsuba.exr")),
            ..Default::default()
        },
    )?;
    eprintln!("Mitsuba: {:.1} s", run.seconds);
    Ok(())
}

fn fmt_opt(v: Option<f64>) -> String {
    v.map_or_else(|| "n/a".to_string(), |x| format!("{x:.4e}"))
}

/// One method's line of `table.csv` and `table.md`.
struct TableRow<'a> {
    label: &'a str,
    key: &'a str,
    /// Light depth, sources, solve and sweeps, s.
    solve: f64,
    render: f64,
    total: f64,
    unknowns: u128,
    iterations: usize,
    metrics: Option<&'a Metrics>,
}

impl<'a> TableRow<'a> {
    fn new(e: &'a Entry) -> Self {
        let r = &e.run.report;
        Self {
            label: e.label,
            key: e.key,
            solve: r.seconds.light_depth + r.seconds.sources + r.seconds.solve + r.seconds.sweeps,
            render: r.seconds.render,
            total: r.seconds.total,
            unknowns: r.unknowns.as_ref().map_or(0, |u| u.solved),
            iterations: r.solver.as_ref().map_or(0, |s| s.iterations),
            metrics: e.metrics.as_ref(),
        }
    }
}

/// The text of `table.csv` and of `table.md`.
fn tables(rows: &[TableRow], reference: Option<&Path>) -> Result<(String, String)> {
    let mut csv = Table::new(&[
        "method",
        "solve_seconds",
        "render_seconds",
        "total_seconds",
        "unknowns",
        "iterations",
        "rmse",
        "rel_mse",
        "mean_rel_error",
        "rel_bias",
    ]);
    let mut md = Table::new(&[
        "method",
        "solve s",
        "render s",
        "unknowns",
        "iterations",
        "RMSE",
        "rel. MSE",
        "mean rel. error",
    ]);
    for r in rows {
        let m = r.metrics;
        csv.push_row([
            r.key.to_string(),
            format!("{:.4}", r.solve),
            format!("{:.4}", r.render),
            format!("{:.4}", r.total),
            r.unknowns.to_string(),
            r.iterations.to_string(),
            fmt_opt(m.map(|m| m.rmse)),
            fmt_opt(m.map(|m| m.rel_mse)),
            fmt_opt(m.map(|m| m.mean_rel_error)),
            fmt_opt(m.map(|m| m.rel_bias)),
        ])?;
        md.push_row([
            r.label.to_string(),
            format!("{:.2}", r.solve),
            format!("{:.2}", r.render),
            r.unknowns.to_string(),
            r.iterations.to_string(),
            fmt_opt(m.map(|m| m.rmse)),
            fmt_opt(m.map(|m| m.rel_mse)),
            fmt_opt(m.map(|m| m.mean_rel_error)),
        ])?;
    }
    let md = format!(
        "Reference: {}\n\n{}",
        reference.map_or("none (no Mitsuba image)".to_string(), |p| p
            .display()
            .to_string()),
        md.to_markdown()
    );
    Ok((csv.to_csv(), md))
}

fn write_tables(out: &Path, entries: &[Entry], reference: Option<&Path>) -> Result<()> {
    let rows: Vec<TableRow> = entries.iter().map(TableRow::new).collect();
    let (csv, md) = tables(&rows, reference)?;
    std::fs::write(out.join("table.csv"), csv).context("writing table.csv")?;
    std::fs::write(out.join("table.md"), md).context("writing table.md")?;
    Ok(())
}

/// Draws the side-by-side figure: one row of tone-mapped images (one exposure, from the
/// reference if present, else from the last method), the reference at the end; with a
/// reference a second row of |image − reference| on one white→red scale (0 to the 99th
/// percentile of the largest error image).
fn write_figure(path: &Path, entries: &[Entry], reference: Option<&GrayImage>) -> Result<()> {
    let labels = crate::plot::fonts().is_ok();
    let err = |e: &dyn std::fmt::Display| pn_formats::plot::draw_error(path, e);
    let first = &entries[0].run.image;
    let (w, h) = (first.width, first.height);
    let scale = (240 / w.max(1)).clamp(1, 4);
    let (pw, ph) = ((w * scale) as i32, (h * scale) as i32);
    let label_h = 44;
    let cols = entries.len() + usize::from(reference.is_some());
    let rows = 1 + usize::from(reference.is_some());
    let size = (
        (cols as i32 * (pw + 8) + 8) as u32,
        (rows as i32 * (ph + label_h + 8) + 8) as u32,
    );
    let root = pn_formats::plot::white_canvas(path, size)?;
    let expo = match reference {
        Some(r) => exposure(&r.data.iter().map(|v| *v as f32).collect::<Vec<_>>()),
        None => exposure(&entries[entries.len() - 1].run.image.data),
    };
    let draw_panel = |col: usize,
                      row: usize,
                      px: &dyn Fn(usize) -> RGBColor,
                      title: &str,
                      sub: &str|
     -> Result<()> {
        let x0 = 8 + col as i32 * (pw + 8);
        let y0 = 8 + row as i32 * (ph + label_h + 8);
        if labels {
            root.draw_text(title, &("sans-serif", 15).into_text_style(&root), (x0, y0))
                .map_err(|e| err(&e))?;
            root.draw_text(
                sub,
                &("sans-serif", 12).into_text_style(&root),
                (x0, y0 + 19),
            )
            .map_err(|e| err(&e))?;
        }
        let y0 = y0 + label_h;
        for y in 0..h {
            for x in 0..w {
                let c = px(y * w + x);
                let (a, b) = (x0 + (x * scale) as i32, y0 + (y * scale) as i32);
                root.draw(&Rectangle::new(
                    [(a, b), (a + scale as i32, b + scale as i32)],
                    c.filled(),
                ))
                .map_err(|e| err(&e))?;
            }
        }
        Ok(())
    };
    let tone = |v: f64| {
        let g = srgb8(v as f32 * expo);
        RGBColor(g, g, g)
    };
    for (c, e) in entries.iter().enumerate() {
        let r = &e.run.report;
        let solve = r.seconds.light_depth + r.seconds.sources + r.seconds.solve + r.seconds.sweeps;
        let sub = format!("solve {solve:.1} s, render {:.1} s", r.seconds.render);
        let data = &e.run.image.data;
        draw_panel(c, 0, &|i| tone(data[i] as f64), e.label, &sub)?;
    }
    if let Some(refimg) = reference {
        draw_panel(
            entries.len(),
            0,
            &|i| tone(refimg.data[i]),
            "Mitsuba (reference)",
            "volpath",
        )?;
        // Common error scale: the largest 99th percentile of |a − ref| over the methods.
        let mut range = 0.0f64;
        for e in entries {
            let mut d: Vec<f64> = e
                .run
                .image
                .data
                .iter()
                .zip(&refimg.data)
                .map(|(a, b)| (*a as f64 - b).abs())
                .collect();
            d.sort_by(|a, b| a.total_cmp(b));
            range = range.max(d[((d.len() - 1) as f64 * 0.99) as usize]);
        }
        let range = if range > 0.0 { range } else { 1.0 };
        for (c, e) in entries.iter().enumerate() {
            let data = &e.run.image.data;
            let sub = format!(
                "|error|, 0–{range:.2e}; RMSE {}",
                fmt_opt(e.metrics.as_ref().map(|m| m.rmse))
            );
            draw_panel(
                c,
                1,
                &|i| {
                    let t = ((data[i] as f64 - refimg.data[i]).abs() / range).clamp(0.0, 1.0);
                    let v = (255.0 * (1.0 - t)) as u8;
                    RGBColor(255, v, v)
                },
                e.label,
                &sub,
            )?;
        }
    }
    root.present().map_err(|e| err(&e))?;
    Ok(())
}
