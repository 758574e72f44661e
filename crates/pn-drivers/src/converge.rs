//! `pn converge <scene> --order N --res R1,R2,R3,...`: a self-convergence study (docs/convergence.md).
//!
//! Solves the scene at every resolution (all other flags as in `pn solve`: method, order,
//! sampling, boundary, solver, tolerance, point-source parameters), compares every level
//! with the finest on the coarsest grid (fluence restricted by cell averaging) and, for the
//! checkerboard scenes, by the averages over the 1×1(×1) blocks, and writes
//! `convergence.csv`, `convergence.json` and `convergence.png` (see
//! `pn_runtime::convergence`).

use crate::error_estimate::solve_at;
use crate::scene_setup::{Method, SolveRequest};
use anyhow::{ensure, Context, Result};
use pn_formats::plot::write_convergence_png;
use pn_runtime::convergence::{analyse, check_nesting, Level};
use std::io::Write;
use std::path::PathBuf;

/// `convergence.json` (keys in the order of earlier versions of the file).
#[derive(serde::Serialize)]
struct ConvergeReport<'a> {
    /// The boundary closure's name.
    boundary: String,
    /// `pn` or `cda`.
    method: &'static str,
    /// `--order` as given (null: the scene's default).
    order: Option<usize>,
    /// The resolved sampling mode.
    sampling: String,
    /// The scene's name.
    scene: String,
    /// The study.
    table: &'a pn_runtime::convergence::StudyTable,
}

/// Blocks per axis of the scenes that define blocks.
fn scene_blocks(scene: &str, axes: usize) -> Option<[usize; 3]> {
    match scene {
        "checkerboard" | "checkerboard3d" => Some(if axes == 3 { [7, 7, 7] } else { [7, 7, 1] }),
        _ => None,
    }
}

/// Runs `pn converge`: `req` as for `pn solve`, except that `req.res` lists the
/// resolutions (coarsest first, each one value for all axes and an integer multiple of the
/// first) and `req.out` is the study's directory (default `out/converge-<scene>`). Prints
/// the table to `stdout`.
pub fn run(req: &SolveRequest, stdout: &mut dyn Write) -> Result<()> {
    anyhow::ensure!(
        req.distributed.is_none(),
        "pn converge does not run distributed (its solves are small); use `pn solve \
         --distributed` for one resolution"
    );
    let a = req;
    ensure!(
        !a.error_estimate,
        "--error-estimate applies to pn solve; pn converge reports Richardson estimates per level"
    );
    ensure!(
        a.tol.is_finite() && a.tol > 0.0,
        "--tol must be positive, got {}",
        a.tol
    );
    let res = a.res.clone().unwrap_or_default();
    ensure!(
        res.len() >= 2,
        "pn converge needs at least two resolutions, e.g. --res 71,142,284"
    );
    ensure!(
        res.iter().all(|&r| r > 0),
        "resolutions must be positive, got {res:?}"
    );
    let as3 = |r: usize| [r, r, r];
    check_nesting(&res.iter().map(|&r| as3(r)).collect::<Vec<_>>())
        .context("pn converge needs nested resolutions (e.g. 71,142,284)")?;
    let mut levels = Vec::new();
    let mut domain = None;
    let mut name = req.scene.clone();
    let mut notes = Vec::new();
    let mut boundary = String::new();
    for &r in &res {
        let lv = solve_at(req, vec![r])?;
        eprintln!(
            "solved {r}: {} unknowns, {} iterations, {:.2} s",
            lv.sol.unknowns, lv.sol.stats.iterations, lv.seconds
        );
        for n in &lv.scene.notes {
            if !notes.contains(n) {
                eprintln!("note: {n}");
                notes.push(n.clone());
            }
        }
        name = lv.scene.name.clone();
        boundary = lv.problem.boundary.name().to_string();
        domain = Some(lv.problem.grid.clone());
        levels.push(Level {
            res: lv.problem.grid.res,
            unknowns: lv.sol.unknowns,
            seconds: lv.seconds,
            fluence: lv.sol.l00(),
        });
    }
    let domain = domain.context("internal: no level was solved")?;
    let axes = domain.dim.axes();
    let table = analyse(&levels, &domain, scene_blocks(&name, axes))?;
    write!(stdout, "{}", table.to_text())?;
    let out = a
        .out
        .clone()
        .unwrap_or_else(|| PathBuf::from("out").join(format!("converge-{name}")));
    std::fs::create_dir_all(&out)
        .with_context(|| format!("cannot create output directory {}", out.display()))?;
    std::fs::write(out.join("convergence.csv"), table.to_csv())
        .with_context(|| format!("writing {}", out.join("convergence.csv").display()))?;
    let what = if a.method == Method::Cda {
        "CDA".to_string()
    } else {
        format!("P_{}", a.order.map_or("default".into(), |o| o.to_string()))
    };
    let sampling = a.sampling.resolved(axes).name();
    let report = ConvergeReport {
        boundary,
        method: a.method.name(),
        order: a.order,
        sampling: sampling.clone(),
        scene: name.clone(),
        table: &table,
    };
    pn_formats::write_atomic(&out.join("convergence.json"), &report)?;
    let title = format!("{name} {what}, sampling {sampling}: self-convergence");
    write_convergence_png(
        &out.join("convergence.png"),
        &table,
        domain.max[0] - domain.min[0],
        &title,
    )?;
    writeln!(stdout, "-> {}", out.display())?;
    Ok(())
}
