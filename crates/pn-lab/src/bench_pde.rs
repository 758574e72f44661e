//! `pn bench` rows of the shipped text PDEs (`pdes/*.pde`, docs/pde-text.md) beside the
//! built-in methods: the checkerboard against StaRMAP's P_5 and the point source against
//! each variant's own exact solution where one exists.

use crate::bench_rows::{
    grid_label, max_rel_diff, pointsource_options, profile_error, reset_peak_memory, row_from, Row,
};
use pn_codegen::text::parse_pde;
use pn_runtime::pipeline::solve_problem;
use pn_runtime::reference::{cda_point_source, pn_point_source, PointSourceModes};
use pn_runtime::scenes::{builtin, BuiltinOptions};
use pn_runtime::solver::{SolverKind, SolverOptions, SolverTuning};
use std::path::Path;

/// A shipped PDE with parameter overrides: (row name, file text, parameters).
type Variant = (
    &'static str,
    &'static str,
    &'static [(&'static str, &'static str)],
);

const CDA: &str = include_str!("../../../pdes/cda.pde");
const SP1: &str = include_str!("../../../pdes/sp1.pde");
const SP3: &str = include_str!("../../../pdes/sp3.pde");
const FPN: &str = include_str!("../../../pdes/fpn.pde");
const DPN: &str = include_str!("../../../pdes/dpn.pde");

/// The largest point-source grid DP_3 is benchmarked on: its P_4-sized system (25 moments
/// per cell, 4.6 M non-zeros at 24³) grows past a few GB at the 80³ of the full bench.
const DPN_MAX_RES: usize = 32;

/// The exact point-source fluence a variant is judged by (normalised, τ from the source).
enum Exact {
    Cda,
    P3,
    Sp3,
}

/// Solves `scene` with each variant through the default solver (parity-cg, whose fallback
/// takes the systems without the parity structure) and appends a row each.
fn solve_variant(
    problem: &str,
    scene: &pn_runtime::scenes::Scene,
    (name, text, params): Variant,
    tol: f64,
    tuning: &SolverTuning,
) -> anyhow::Result<(pn_runtime::pipeline::Solution, String)> {
    let params: Vec<(String, String)> = params
        .iter()
        .map(|(k, v)| (k.to_string(), v.to_string()))
        .collect();
    let pde = parse_pde(text, &params).map_err(|e| anyhow::anyhow!("pdes/{name}: {e}"))?;
    let choice = pn_kernels::pde_kernel(&pde, scene.problem.grid.dim)?;
    pn_drivers::progress::print_notes(choice.note.as_slice());
    let opts = SolverOptions {
        tol,
        tuning: tuning.clone(),
        ..Default::default()
    };
    reset_peak_memory();
    let sol = solve_problem(
        &scene.problem,
        choice.kernel.as_ref(),
        SolverKind::ParityCg,
        &opts,
    )
    .map_err(|e| e.context(format!("{problem} with pdes/{name}")))?;
    pn_drivers::progress::print_notes(&sol.stats.notes);
    Ok((sol, grid_label(&scene.problem.grid)))
}

/// Appends (and prints) the row of variant `name` on `problem`.
fn push_row(
    rows: &mut Vec<Row>,
    problem: &str,
    name: &str,
    res: String,
    sol: &pn_runtime::pipeline::Solution,
    err: Option<f64>,
    reference: &'static str,
) {
    let row = row_from(problem, &format!("pde:{name}"), 0, res, sol, err, reference);
    eprintln!("bench: {}", row.csv());
    rows.push(row);
}

/// The text-PDE rows: the checkerboard (71², tolerance 1e-10) against StaRMAP's P_5 from
/// `reference` (`checkerboard/starmap_p5_n71.csv`), and the point source on `n³` cells
/// (tolerance 1e-6) against the variant's exact solution (CDA and SP_1: the CDA solution;
/// SP_3: its two-mode solution; filtered P_3: the P_3 solution, so the error is the
/// filter's). `quick` leaves out filtered P_5 and DP_3 (P_3 with a diffusive correction,
/// whose steady state is P_4 with band 4 eliminated: judged against the P_4 solution, on at
/// most [`DPN_MAX_RES`]³ cells; its checkerboard solve takes ~13 s).
pub(crate) fn pde_rows(
    quick: bool,
    reference: &Path,
    n: usize,
    tuning: &SolverTuning,
    rows: &mut Vec<Row>,
) -> anyhow::Result<()> {
    let mut checkerboard: Vec<Variant> = vec![
        ("cda.pde", CDA, &[]),
        ("sp1.pde", SP1, &[]),
        ("sp3.pde", SP3, &[]),
        ("fpn.pde N=3", FPN, &[]),
    ];
    if !quick {
        checkerboard.push(("fpn.pde N=5", FPN, &[("N", "5")]));
        checkerboard.push(("dpn.pde N=3", DPN, &[]));
    }
    let starmap = Some(pn_runtime::reference::starmap::read_csv(
        &reference.join("checkerboard/starmap_p5_n71.csv"),
    )?);
    let scene = builtin("checkerboard", &BuiltinOptions::default())?;
    for v in checkerboard {
        let (sol, res) = solve_variant("checkerboard", &scene, v, 1e-10, tuning)?;
        let err = starmap.as_ref().and_then(|r| max_rel_diff(&sol.l00(), r));
        let reference = if err.is_some() { "starmap_p5" } else { "none" };
        push_row(rows, "checkerboard", v.0, res, &sol, err, reference);
    }

    let (params, opts) = pointsource_options(n);
    let scene = builtin("pointsource", &opts)?;
    let tau_per_cell = params.sigma_t * 2.0 * params.half_width / n as f64;
    let c = n / 2;
    let norm = 4.0 * std::f64::consts::PI / (params.sigma_t * params.sigma_t);
    let pointsource: [(Variant, Exact, &'static str); 4] = [
        (("cda.pde", CDA, &[]), Exact::Cda, "cda_exact"),
        (("sp1.pde", SP1, &[]), Exact::Cda, "cda_exact"),
        (("sp3.pde", SP3, &[]), Exact::Sp3, "sp3_exact"),
        (("fpn.pde N=3", FPN, &[]), Exact::P3, "pn_exact"),
    ];
    let (sp3, p3, p4) = (
        PointSourceModes::sp3(params.albedo, params.g)?,
        pn_point_source(3, params.albedo, params.g)?,
        pn_point_source(4, params.albedo, params.g)?,
    );
    for (v, exact, reference) in pointsource {
        let (sol, res) = solve_variant("pointsource", &scene, v, 1e-6, tuning)?;
        let l00 = sol.l00();
        let err = profile_error(
            tau_per_cell,
            n - 1 - c,
            |k| l00[((c + k) * n + c) * n + c] * norm,
            |t| match exact {
                Exact::Cda => cda_point_source(t, params.albedo, params.g),
                Exact::Sp3 => sp3.fluence(t),
                Exact::P3 => p3.fluence(t),
            },
        );
        push_row(rows, "pointsource", v.0, res, &sol, err, reference);
    }
    if !quick {
        let m = n.min(DPN_MAX_RES);
        let (params, opts) = pointsource_options(m);
        let scene = builtin("pointsource", &opts)?;
        let tau_per_cell = params.sigma_t * 2.0 * params.half_width / m as f64;
        let c = m / 2;
        let (sol, res) = solve_variant(
            "pointsource",
            &scene,
            ("dpn.pde N=3", DPN, &[]),
            1e-6,
            tuning,
        )?;
        let l00 = sol.l00();
        let err = profile_error(
            tau_per_cell,
            m - 1 - c,
            |k| l00[((c + k) * m + c) * m + c] * norm,
            |t| p4.fluence(t),
        );
        push_row(
            rows,
            "pointsource",
            "dpn.pde N=3",
            res,
            &sol,
            err,
            "p4_exact",
        );
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The quick rows on a 12³ point source: every variant converges and has an error; CDA
    /// from text and SP_1 solve the same system; on the checkerboard SP_3 and filtered P_3 lie
    /// closer to StaRMAP's P_5 than the diffusion variants do.
    #[test]
    fn text_pde_rows_run_and_order_by_accuracy() {
        let data = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../tests/data");
        let mut rows = Vec::new();
        pde_rows(true, &data, 12, &SolverTuning::default(), &mut rows).unwrap();
        let names: Vec<(&str, &str)> = rows
            .iter()
            .map(|r| (r.problem.as_str(), r.method.as_str()))
            .collect();
        assert_eq!(names.len(), 8, "{names:?}");
        for r in &rows {
            let e = r.error.unwrap_or(f64::NAN);
            assert!(r.converged && e.is_finite() && e > 0.0, "{}", r.csv());
        }
        let err = |p: &str, m: &str| {
            rows.iter()
                .find(|r| r.problem == p && r.method == m)
                .and_then(|r| r.error)
                .unwrap()
        };
        for p in ["checkerboard", "pointsource"] {
            assert_eq!(err(p, "pde:cda.pde"), err(p, "pde:sp1.pde"), "{p}");
        }
        let cda = err("checkerboard", "pde:cda.pde");
        assert!(err("checkerboard", "pde:sp3.pde") < 0.5 * cda);
        assert!(err("checkerboard", "pde:fpn.pde N=3") < 0.5 * cda);
    }
}
