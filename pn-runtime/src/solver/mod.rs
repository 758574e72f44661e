//! Linear solvers for `A u = b`, behind a small trait so faster ones can be added.
//!
//! **Tolerance.** Every solver stops on the *relative* residual of the original system,
//! `‖b − A u‖₂ / ‖b‖₂ ≤ tol` (Euclidean norms over all unknowns). The absolute value
//! `‖b − A u‖₂` is reported too. The final residual in [`SolveStats`] is recomputed from
//! the returned solution, not taken from a recurrence.

pub mod cgnr;
pub mod parity;

use sprs::CsMat;

/// Which solver to use (`--solver`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum SolverKind {
    /// Conjugate gradients on the normal equations AᵀA u = Aᵀb (CGLS form, AᵀA never formed).
    Cgnr,
    /// Eliminate the odd-l moments and solve the even-parity system with preconditioned
    /// CG (BiCGSTAB when the boundary closure makes it nonsymmetric); see [`parity`].
    #[serde(rename = "parity-cg")]
    ParityCg,
}

impl std::str::FromStr for SolverKind {
    type Err = anyhow::Error;
    fn from_str(s: &str) -> anyhow::Result<Self> {
        match s {
            "cgnr" => Ok(SolverKind::Cgnr),
            "parity-cg" => Ok(SolverKind::ParityCg),
            _ => anyhow::bail!("unknown solver {s:?} (available: cgnr, parity-cg)"),
        }
    }
}

impl SolverKind {
    /// The solver implementation.
    pub fn solver(self) -> Box<dyn LinearSolver> {
        match self {
            SolverKind::Cgnr => Box::new(cgnr::Cgnr),
            // The parity classes are detected from the matrix; with a `Layout` at hand,
            // `parity::ParityCg::for_layout(&layout)` gives the same solver without the detection.
            SolverKind::ParityCg => Box::new(parity::ParityCg::auto(parity::Precond::Auto)),
        }
    }
}

/// Stopping and reporting options.
#[derive(Clone, Debug, PartialEq)]
pub struct SolverOptions {
    /// Relative residual tolerance ‖b − Au‖₂/‖b‖₂.
    pub tol: f64,
    /// Maximum number of iterations.
    pub max_iter: usize,
    /// Stagnation: stop when the best relative residual has not dropped by a factor
    /// `1 − stagnation_drop` within this many iterations.
    pub stagnation_window: usize,
    /// See `stagnation_window`.
    pub stagnation_drop: f64,
    /// Divergence: stop when the relative residual exceeds this value (or is not finite).
    pub divergence_limit: f64,
    /// Show a progress bar (only drawn when stderr is a terminal).
    pub progress: bool,
}

impl Default for SolverOptions {
    fn default() -> Self {
        Self {
            tol: 1e-10,
            max_iter: 100_000,
            stagnation_window: 5000,
            stagnation_drop: 1e-4,
            divergence_limit: 1e8,
            progress: true,
        }
    }
}

/// Why a solver stopped.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum SolveStatus {
    /// The relative residual reached the tolerance.
    Converged,
    /// Ran out of iterations.
    MaxIterations,
    /// The residual stopped decreasing.
    Stagnated,
    /// The residual grew without bound or became NaN.
    Diverged,
}

/// What a solve did.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct SolveStats {
    /// Solver name.
    pub solver: String,
    /// Why it stopped.
    pub status: SolveStatus,
    /// Iterations done.
    pub iterations: usize,
    /// Final ‖b − Au‖₂ / ‖b‖₂ (recomputed).
    pub relative_residual: f64,
    /// Final ‖b − Au‖₂ (recomputed).
    pub absolute_residual: f64,
    /// ‖b‖₂.
    pub rhs_norm: f64,
    /// Tolerance on the relative residual.
    pub tolerance: f64,
    /// Relative residual after each iteration (from the recurrence).
    pub history: Vec<f64>,
}

impl SolveStats {
    /// Whether the tolerance was reached.
    pub fn converged(&self) -> bool {
        self.status == SolveStatus::Converged
    }
}

/// A solver for square sparse systems.
pub trait LinearSolver: Send + Sync {
    /// Short name (`cgnr`).
    fn name(&self) -> &'static str;
    /// Solves `a u = b` starting from zero. Never fails; see the returned status.
    fn solve(&self, a: &CsMat<f64>, b: &[f64], opts: &SolverOptions) -> (Vec<f64>, SolveStats);
}

/// An indicatif progress bar that is hidden unless stderr is a terminal.
pub(crate) fn progress_bar(len: usize, enabled: bool) -> indicatif::ProgressBar {
    use std::io::IsTerminal;
    if !enabled || !std::io::stderr().is_terminal() {
        return indicatif::ProgressBar::hidden();
    }
    let pb = indicatif::ProgressBar::new(len as u64);
    if let Ok(style) = indicatif::ProgressStyle::with_template(
        "{spinner} [{elapsed_precise}] {pos} it  {msg}  ({per_sec})",
    ) {
        pb.set_style(style);
    }
    pb
}
