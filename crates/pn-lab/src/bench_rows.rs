//! The rows of `bench.csv` and the measurements that `pn bench`, its model section
//! (`bench_model`) and `pn tradeoff` share: peak memory, the point-source profile
//! error and the FLD point source.

use pn_runtime::fld::{FldGrid, FldProblem};
use pn_runtime::pipeline::Solution;
use pn_runtime::scenes::PointSourceParams;

/// One operator's model and measurement (`bench_roofline` fills it).
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct Roofline {
    /// `s-matfree`, `s-formed`, `a-csr` or `a-matfree`.
    pub(crate) operator: &'static str,
    /// Modelled bytes of one application.
    pub(crate) bytes_per_application: u64,
    /// Median seconds of one application.
    pub(crate) seconds_per_application: f64,
}

impl Roofline {
    /// Achieved bandwidth, GB/s.
    pub(crate) fn achieved_gbs(&self) -> f64 {
        pn_runtime::bandwidth::achieved_gbs(
            self.bytes_per_application as f64,
            self.seconds_per_application,
        )
    }

    /// Time of one application over the time of its bytes at `bandwidth_gbs`.
    pub(crate) fn ratio(&self, bandwidth_gbs: f64) -> f64 {
        pn_runtime::bandwidth::roofline_ratio(
            self.bytes_per_application as f64,
            self.seconds_per_application,
            bandwidth_gbs,
        )
    }
}

/// One row of bench.csv.
pub(crate) struct Row {
    pub(crate) problem: String,
    pub(crate) method: String,
    pub(crate) solver: String,
    pub(crate) order: usize,
    pub(crate) resolution: String,
    pub(crate) unknowns: usize,
    pub(crate) iterations: usize,
    pub(crate) seconds_assemble: f64,
    pub(crate) seconds_solve: f64,
    pub(crate) peak_memory_bytes: u64,
    pub(crate) error: Option<f64>,
    pub(crate) reference: &'static str,
    pub(crate) converged: bool,
    /// Products with `A` or their equivalent ([`pn_runtime::solver::SolveStats::operator_applications`]).
    pub(crate) operator_applications: usize,
    /// The operator this solver applies, modelled and timed (`bench_roofline`); `None`
    /// where there is no model.
    pub(crate) roofline: Option<Roofline>,
}

/// The columns of bench.csv. The roofline columns (from `bytes_per_application` on) were
/// appended on 2026-12-05, after the older ones, so that readers by position keep working.
pub(crate) const CSV_HEADER: &str = "problem,method,solver,order,resolution,unknowns,iterations,seconds_assemble,seconds_solve,peak_memory_bytes,error,reference,converged,operator_applications,bytes_per_application,bytes_per_unknown_iteration,seconds_per_application,achieved_gbs,bandwidth_gbs,roofline_ratio,roofline_operator";

impl Row {
    /// The CSV line without the measured bandwidth (and hence without the roofline ratio).
    pub(crate) fn csv(&self) -> String {
        self.csv_line(None)
    }

    /// Modelled operator bytes per unknown and iteration: one application's bytes times the
    /// applications, over unknowns × iterations (the Krylov vectors and the rest of the
    /// preconditioner not included).
    pub(crate) fn bytes_per_unknown_iteration(&self) -> Option<f64> {
        let r = self.roofline.as_ref()?;
        Some(
            r.bytes_per_application as f64 * self.operator_applications as f64
                / (self.unknowns.max(1) * self.iterations.max(1)) as f64,
        )
    }

    /// The CSV line, with the machine's `bandwidth_gbs` (measured once per run) and the
    /// roofline ratio against it where the row has a model.
    pub(crate) fn csv_line(&self, bandwidth_gbs: Option<f64>) -> String {
        self.cells(bandwidth_gbs).join(",")
    }

    /// The cells of [`Row::csv_line`], one per column of [`CSV_HEADER`].
    pub(crate) fn cells(&self, bandwidth_gbs: Option<f64>) -> Vec<String> {
        let r = self.roofline.as_ref();
        let opt = |v: Option<String>| v.unwrap_or_default();
        vec![
            self.problem.clone(),
            self.method.clone(),
            self.solver.clone(),
            self.order.to_string(),
            self.resolution.clone(),
            self.unknowns.to_string(),
            self.iterations.to_string(),
            format!("{:.6}", self.seconds_assemble),
            format!("{:.6}", self.seconds_solve),
            self.peak_memory_bytes.to_string(),
            self.error.map_or("".into(), |e| format!("{e:.3e}")),
            self.reference.to_string(),
            self.converged.to_string(),
            self.operator_applications.to_string(),
            opt(r.map(|r| r.bytes_per_application.to_string())),
            opt(self
                .bytes_per_unknown_iteration()
                .map(|b| format!("{b:.1}"))),
            opt(r.map(|r| format!("{:.6e}", r.seconds_per_application))),
            opt(r.map(|r| format!("{:.3}", r.achieved_gbs()))),
            opt(bandwidth_gbs.map(|b| format!("{b:.2}"))),
            opt(r
                .zip(bandwidth_gbs)
                .map(|(r, b)| format!("{:.3}", r.ratio(b)))),
            opt(r.map(|r| r.operator.to_string())),
        ]
    }
}

/// Resets the kernel's peak-RSS counter so that each problem's peak is its own
/// (`/proc/self/clear_refs`, Linux ≥ 4.0); returns false where that is not possible.
pub(crate) fn reset_peak_memory() -> bool {
    std::fs::write("/proc/self/clear_refs", "5").is_ok()
}

/// The peak resident memory of the process (0 where unknown).
pub(crate) fn peak_memory() -> u64 {
    pn_runtime::peak_memory_bytes().unwrap_or(0)
}

/// Largest relative deviation of `values(k)` (normalised fluence at k cells along +x from
/// the source) from `exact(τ_k)` at the cells nearest τ = 1, 2, 4.
pub(crate) fn profile_error(
    tau_per_cell: f64,
    max_k: usize,
    values: impl Fn(usize) -> f64,
    exact: impl Fn(f64) -> f64,
) -> Option<f64> {
    let mut worst: Option<f64> = None;
    for tau in [1.0, 2.0, 4.0] {
        let k = (tau / tau_per_cell).round() as usize;
        if k == 0 || k > max_k {
            continue;
        }
        let t = k as f64 * tau_per_cell;
        let e = (values(k) / exact(t) - 1.0).abs();
        worst = Some(worst.map_or(e, |w: f64| w.max(e)));
    }
    worst
}

pub(crate) fn row_from(
    problem: &str,
    method: &str,
    order: usize,
    res: String,
    sol: &Solution,
    error: Option<f64>,
    reference: &'static str,
) -> Row {
    Row {
        problem: problem.into(),
        method: method.into(),
        solver: sol.stats.solver.clone(),
        order,
        resolution: res,
        unknowns: sol.unknowns,
        iterations: sol.stats.iterations,
        seconds_assemble: sol.seconds_assembly,
        seconds_solve: sol.seconds_solve,
        peak_memory_bytes: peak_memory(),
        error,
        reference,
        converged: sol.stats.converged(),
        operator_applications: sol.stats.operator_applications,
        roofline: None,
    }
}

/// The point source of `params` on `n³` cells for FLD: a unit-power source in cell
/// (n/2, n/2, n/2), like the `pointsource` scene.
pub(crate) fn fld_point_source(n: usize, params: &PointSourceParams) -> anyhow::Result<FldProblem> {
    let grid = FldGrid::cube(n, 2.0 * params.half_width)?;
    let h = 2.0 * params.half_width / n as f64;
    let cells = grid.len();
    let c = n / 2;
    let mut source = vec![0.0; cells];
    source[grid.index(c, c, c)] = 1.0 / (h * h * h);
    Ok(FldProblem {
        grid,
        sigma_t: vec![params.sigma_t; cells],
        sigma_a: vec![params.sigma_t * (1.0 - params.albedo); cells],
        source,
    })
}

/// max |a − b| / max |b| (None when the lengths differ or `b` is empty).
pub(crate) fn max_rel_diff(a: &[f64], b: &[f64]) -> Option<f64> {
    if a.len() != b.len() || b.is_empty() {
        return None;
    }
    let scale = b.iter().fold(0.0f64, |m, x| m.max(x.abs()));
    let diff = a
        .iter()
        .zip(b)
        .fold(0.0f64, |m, (x, y)| m.max((x - y).abs()));
    Some(diff / scale)
}

/// The resolution column: the grid's cells per axis joined by `x` (`71x71`, `40x40x40`).
pub(crate) fn grid_label(g: &pn_runtime::problem::Grid) -> String {
    g.res[..g.dim.axes()]
        .iter()
        .map(|n| n.to_string())
        .collect::<Vec<_>>()
        .join("x")
}

/// The bench's point source on `n³` cells: the default parameters and the scene options.
pub(crate) fn pointsource_options(
    n: usize,
) -> (
    pn_runtime::scenes::PointSourceParams,
    pn_runtime::scenes::BuiltinOptions,
) {
    let params = pn_runtime::scenes::PointSourceParams::default();
    let opts = pn_runtime::scenes::BuiltinOptions {
        dim: Some(pn_kernels::Dim::Three),
        res: Some(vec![n]),
        pointsource: params,
        ..Default::default()
    };
    (params, opts)
}
