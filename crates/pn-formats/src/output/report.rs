//! `report.json`: what was solved, how, and what it cost.
//!
//! [`SolveReport`] is the whole file of one `pn solve`: the common [`Report`] plus the
//! sections a run adds (the sampling mode, the error estimate, the `slab`/`milne`
//! measurements, the FLD entries). A command builds it in memory and [`super::write_outputs`]
//! writes it once, atomically ([`crate::json::write_atomic`]).

use pn_runtime::pipeline::Solution;
use pn_runtime::problem::Problem;
use pn_runtime::solver::SolveStatus;
use pn_runtime::EnergyBalance;
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

/// The fields every `report.json` of a solve has (the first keys of [`SolveReport`]).
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
            peak_memory_bytes: pn_runtime::peak_memory_bytes(),
            threads: info.threads,
            energy_balance: sol.energy.clone(),
            residual_history: history,
        }
    }
}

/// The contents of `report.json` of `pn solve`: [`Report`] plus the optional sections, each
/// written only when present, in this order after the common keys.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct SolveReport {
    /// The common fields.
    #[serde(flatten)]
    pub base: Report,
    /// The field sampling mode (`exact`, `average:<k>`), recorded when it is not the default
    /// or with an error estimate.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub sampling: Option<String>,
    /// `--error-estimate`: the Richardson estimate from the coarser solves.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub error_estimate: Option<ErrorEstimate>,
    /// The `slab` and `milne` scenes: the Marshak vacuum boundary's measurements.
    #[serde(flatten)]
    pub vacuum: VacuumMeasurements,
    /// `--method fld`: the FLD entries.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub fld: Option<FldSection>,
    /// `--distributed`: the split, the PETSc solver and every process's measurements.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub distributed: Option<DistributedSection>,
}

/// The entries under `"distributed"` (`pn solve --distributed`, docs/distributed.md).
#[derive(Clone, Debug, Default, PartialEq, serde::Serialize)]
pub struct DistributedSection {
    /// MPI processes.
    pub processes: usize,
    /// Boxes per axis.
    pub procs: [usize; 3],
    /// PETSc's Krylov method (`cg`, `gmres`).
    pub ksp: String,
    /// PETSc's preconditioner (`gamg`, `hypre`, `jacobi`, `none`).
    pub pc: String,
    /// Whether the assembled reduced operator was symmetric (null: not assembled).
    pub symmetric: Option<bool>,
    /// PETSc's converged reason and its words.
    pub converged_reason: i32,
    /// PETSc's converged reason in words.
    pub converged_reason_text: String,
    /// ‖f − S u_e‖ / ‖f‖ of the reduced system at the end.
    pub reduced_relative_residual: f64,
    /// Stored entries of the assembled reduced operator (0: not assembled).
    pub nonzeros_reduced: usize,
    /// One entry per process, in rank order.
    pub ranks: Vec<RankSection>,
}

/// One process's measurements.
#[derive(Clone, Debug, Default, PartialEq, serde::Serialize)]
pub struct RankSection {
    /// Seconds assembling its rows.
    pub assembly_seconds: f64,
    /// Seconds forming the reduced operator and setting up the preconditioner.
    pub setup_seconds: f64,
    /// Seconds in the Krylov solve.
    pub solve_seconds: f64,
    /// Seconds of the solve in the operator's ghost exchanges.
    pub communication_seconds: f64,
    /// Applications of the reduced operator.
    pub operator_applications: usize,
    /// Bytes received per application (both ghost exchanges).
    pub halo_bytes_per_application: usize,
    /// Unknowns owned.
    pub owned_unknowns: usize,
    /// Ghost unknowns.
    pub ghost_unknowns: usize,
    /// Peak resident memory of the process in bytes.
    pub peak_memory_bytes: f64,
    /// Global reductions (MPI_Allreduce) during the Krylov solve.
    pub reductions: usize,
}

impl SolveReport {
    /// The report with no optional section.
    pub fn new(base: Report) -> Self {
        SolveReport {
            base,
            sampling: None,
            error_estimate: None,
            vacuum: VacuumMeasurements::default(),
            fld: None,
            distributed: None,
        }
    }
}

/// The estimate under `"error_estimate"` (`pn solve --error-estimate`, docs/convergence.md).
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct ErrorEstimate {
    /// What is estimated.
    pub quantity: String,
    /// Resolution of the extra (coarse) solve, where the per-cell estimate lives.
    pub coarse_resolution: [usize; 3],
    /// Richardson estimate (order, relative L2, max, ...).
    #[serde(flatten)]
    pub estimate: pn_runtime::convergence::RichardsonEstimate,
    /// The observed order from three levels, if a quarter-resolution solve was possible.
    pub observed_order: Option<f64>,
    /// Relative L2 differences ‖u_half − u_fine‖/‖u_fine‖ (on the half grid) and
    /// ‖u_quarter − u_half‖/‖u_half‖ (on the quarter grid, when solved).
    pub level_differences: Vec<f64>,
    /// Seconds of the extra solves (assembly + solve).
    pub extra_seconds: f64,
    /// Extra seconds relative to the fine solve.
    pub extra_cost_fraction: f64,
}

/// What `pn solve slab` and `pn solve milne` add at the top level of the report; each key
/// is written only when measured.
#[derive(Clone, Debug, Default, PartialEq, serde::Serialize)]
pub struct VacuumMeasurements {
    /// `slab`: collided outgoing flux through x = 0 per unit incident flux.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub reflection: Option<f64>,
    /// `slab`: the same through x = τ.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub transmission: Option<f64>,
    /// `slab`: the 1D P_N–Marshak reflection.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub reference_reflection: Option<f64>,
    /// `slab`: the 1D P_N–Marshak transmission.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub reference_transmission: Option<f64>,
    /// `milne`: the measured extrapolation length.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub extrapolation_length: Option<f64>,
    /// `milne`: the P_N–Marshak extrapolation length.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub reference_extrapolation_length: Option<f64>,
}

/// FLD-specific entries of `report.json` (the key `fld`).
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct FldSection {
    /// `gs` (red–black Gauss–Seidel/SOR) or `picard` (linear solves through the stencil).
    pub route: String,
    /// Limiter name (`lp`, `sum`, `max`, `kershaw`, `larsen2`, `cda`).
    pub limiter: String,
    /// SOR factor ω (Gauss–Seidel route; null for Picard).
    pub omega: Option<f64>,
    /// Extinction threshold σ_ε (1/length).
    pub sigma_eps: f64,
    /// ε of the lower bounds and the boundary value.
    pub eps: f64,
    /// RMS source j̄ (fluence units, `q = √(4π) Q_0^0`).
    pub rms_source: f64,
    /// Dirichlet value φ = ε j̄ h on the outermost cell layer (fluence units).
    pub phi_boundary: f64,
    /// Gauss–Seidel iterations or Picard steps.
    pub iterations: usize,
    /// Final relative residual (RMS over the interior / j̄).
    pub residual: f64,
    /// Tolerance on it.
    pub tolerance: f64,
    /// Whether it converged.
    pub converged: bool,
    /// Linear solver of the Picard steps.
    pub linear_solver: Option<String>,
    /// Linear iterations of each Picard step.
    pub linear_iterations: Vec<usize>,
    /// What the output arrays hold.
    pub output_normalisation: String,
}
