//! What a solve reports ([`SolveStats`], [`SolveStatus`]), how a caller watches it
//! ([`IterationObserver`]) and when it stops ([`Stopping`]).

/// A function called after every iteration of a solve with (iteration, relative residual),
/// from the thread that runs the solve: how a caller that is not a terminal (the Python
/// package's progress callback) watches a long solve. Two observers are equal when they are
/// the same function object.
#[derive(Clone)]
pub struct IterationObserver {
    each: std::sync::Arc<dyn Fn(usize, f64) + Send + Sync>,
    finished: Option<std::sync::Arc<dyn Fn() + Send + Sync>>,
}

impl IterationObserver {
    /// Wraps `f`.
    pub fn new(f: impl Fn(usize, f64) + Send + Sync + 'static) -> Self {
        Self {
            each: std::sync::Arc::new(f),
            finished: None,
        }
    }

    /// Wraps `f`, and `done`, called once when a method has finished (a command line clears
    /// its progress bar there).
    pub fn with_finish(
        f: impl Fn(usize, f64) + Send + Sync + 'static,
        done: impl Fn() + Send + Sync + 'static,
    ) -> Self {
        Self {
            each: std::sync::Arc::new(f),
            finished: Some(std::sync::Arc::new(done)),
        }
    }

    /// Reports one iteration.
    pub fn notify(&self, iteration: usize, relative_residual: f64) {
        (self.each)(iteration, relative_residual)
    }

    /// Reports the end of a method's iterations.
    pub fn finish(&self) {
        if let Some(done) = &self.finished {
            done()
        }
    }
}

impl std::fmt::Debug for IterationObserver {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str("IterationObserver(..)")
    }
}

impl PartialEq for IterationObserver {
    fn eq(&self, other: &Self) -> bool {
        std::sync::Arc::ptr_eq(&self.each, &other.each)
    }
}

/// The stopping rules of one solve, shared by every method (see [`crate::control`]).
#[derive(Clone, Debug, PartialEq)]
pub struct Stopping {
    /// Relative residual tolerance ‖b − Au‖₂/‖b‖₂.
    pub tol: f64,
    /// Maximum number of iterations (over restarts).
    pub max_iter: usize,
    /// Stagnation: stop when the best relative residual has not dropped by a factor
    /// `1 − stagnation_drop` within this many iterations.
    pub stagnation_window: usize,
    /// See `stagnation_window`.
    pub stagnation_drop: f64,
    /// Divergence: stop when the relative residual exceeds this value (or is not finite).
    pub divergence_limit: f64,
    /// Called after every iteration (None: nobody watches). A command line draws its
    /// progress bar from it; the methods never print.
    pub observer: Option<IterationObserver>,
}

impl Default for Stopping {
    fn default() -> Self {
        Self {
            tol: 1e-10,
            max_iter: 100_000,
            stagnation_window: 5000,
            stagnation_drop: 1e-4,
            divergence_limit: 1e8,
            observer: None,
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
    /// Work in products with `A`: CGNR, LSQR and LSMR count every product with `A` and
    /// `Aᵀ` (two per iteration, plus the start and the residual checks); the parity solvers
    /// count every application of the reduced operator `S` — Krylov steps, multigrid
    /// smoothing and residuals on the finest level, setup and probes — as one each, since it
    /// touches the off-diagonal entries of `A` once
    /// (`pn_runtime`'s parity report); multigrid-CG on a scalar
    /// system counts its products with the matrix. 0 where nothing is counted (FLD).
    pub operator_applications: usize,
    /// What the solve wants its caller to know (a preconditioner that could not be built, a
    /// fallback taken, per-phase timings when asked for): the libraries never print, a
    /// command line prints these.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub notes: Vec<String>,
}

impl SolveStats {
    /// The same statistics with `note` added after the existing notes.
    pub fn with_note(mut self, note: impl Into<String>) -> Self {
        self.notes.push(note.into());
        self
    }

    /// Whether the tolerance was reached.
    pub fn converged(&self) -> bool {
        self.status == SolveStatus::Converged
    }
}
