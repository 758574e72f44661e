//! `report.json`: what was solved, how, and what it cost.

use pn_runtime::energy::EnergyBalance;
use pn_runtime::pipeline::Solution;
use pn_runtime::problem::Problem;
use pn_runtime::solver::SolveStatus;
use pn_stencil::Dim;

/// Descriptive facts the runtime cannot know by itself (chosen by the caller).
#[derive(Clone, Debug, PartialEq)]
pub struct RunInfo {
    /// Scene name.
    pub scene: String,
    /// `pn` or `cda`.
    pub method: String,
    /// P_N order (0 for CDA).
    pub order: usize,
    /// `staggered` or `collocated`.
    pub layout: String,
    /// Whether the stencil was compiled at build time (false: interpreted IR).
    pub stencil_compiled: bool,
    /// Worker threads.
    pub threads: usize,
}

/// The contents of `report.json`.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct Report {
    /// Scene name.
    pub scene: String,
    /// `pn` or `cda`.
    pub method: String,
    /// P_N order.
    pub order: usize,
    /// 2 or 3.
    pub dim: u8,
    /// Cells per axis.
    pub resolution: [usize; 3],
    /// Domain lower corner.
    pub domain_min: [f64; 3],
    /// Domain upper corner.
    pub domain_max: [f64; 3],
    /// `neumann` or `dirichlet`.
    pub boundary: String,
    /// `staggered` or `collocated`.
    pub layout: String,
    /// Stencil name.
    pub stencil: String,
    /// Compiled (true) or interpreted (false) stencil.
    pub stencil_compiled: bool,
    /// `exact` (analytic fields at staggered positions) or `voxel-averaged`.
    pub field_evaluation: String,
    /// The σ_t threshold, if any.
    pub sigma_t_min: Option<f64>,
    /// Number of unknowns.
    pub unknowns: usize,
    /// Stored non-zeros of A.
    pub nonzeros: usize,
    /// Solver name.
    pub solver: String,
    /// Why the solver stopped.
    pub status: SolveStatus,
    /// Whether the tolerance was reached.
    pub converged: bool,
    /// Iterations.
    pub iterations: usize,
    /// Work in products with `A` ([`pn_runtime::solver::SolveStats::operator_applications`]).
    pub operator_applications: usize,
    /// Final relative residual ‖b − Au‖₂/‖b‖₂ (recomputed from the solution).
    pub final_residual: f64,
    /// Which norm `final_residual` and `tolerance` refer to.
    pub residual_norm: String,
    /// Final absolute residual ‖b − Au‖₂.
    pub absolute_residual: f64,
    /// ‖b‖₂.
    pub rhs_norm: f64,
    /// Tolerance on the relative residual.
    pub tolerance: f64,
    /// Seconds spent assembling.
    pub seconds_assembly: f64,
    /// Seconds spent solving.
    pub seconds_solve: f64,
    /// Peak resident memory (VmHWM) in bytes.
    pub peak_memory_bytes: Option<u64>,
    /// Worker threads.
    pub threads: usize,
    /// Source power vs absorbed power + boundary outflow.
    pub energy_balance: Option<EnergyBalance>,
    /// (iteration, relative residual), subsampled to at most ~500 entries.
    pub residual_history: Vec<(usize, f64)>,
}

impl Report {
    /// Collects the report of a solve.
    pub fn new(info: &RunInfo, problem: &Problem, kernel_name: &str, sol: &Solution) -> Self {
        let st = &sol.stats;
        let stride = st.history.len().div_ceil(500).max(1);
        let mut history: Vec<(usize, f64)> = st
            .history
            .iter()
            .enumerate()
            .step_by(stride)
            .map(|(i, r)| (i + 1, *r))
            .collect();
        if let Some(last) = st.history.last() {
            if history.last().map(|h| h.0) != Some(st.history.len()) {
                history.push((st.history.len(), *last));
            }
        }
        Report {
            scene: info.scene.clone(),
            method: info.method.clone(),
            order: info.order,
            dim: if problem.grid.dim == Dim::Two { 2 } else { 3 },
            resolution: problem.grid.res,
            domain_min: problem.grid.min,
            domain_max: problem.grid.max,
            boundary: problem.boundary.name(),
            layout: info.layout.clone(),
            stencil: kernel_name.into(),
            stencil_compiled: info.stencil_compiled,
            field_evaluation: if problem.uses_voxels() {
                "voxel-averaged"
            } else {
                "exact"
            }
            .into(),
            sigma_t_min: problem.sigma_t_min,
            unknowns: sol.unknowns,
            nonzeros: sol.nonzeros,
            solver: st.solver.clone(),
            status: st.status,
            converged: st.converged(),
            iterations: st.iterations,
            operator_applications: st.operator_applications,
            final_residual: st.relative_residual,
            residual_norm: "relative l2: ||b - A u||_2 / ||b||_2 over all unknowns".into(),
            absolute_residual: st.absolute_residual,
            rhs_norm: st.rhs_norm,
            tolerance: st.tolerance,
            seconds_assembly: sol.seconds_assembly,
            seconds_solve: sol.seconds_solve,
            peak_memory_bytes: pn_runtime::memory::peak_memory_bytes(),
            threads: info.threads,
            energy_balance: sol.energy.clone(),
            residual_history: history,
        }
    }
}
