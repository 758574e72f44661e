//! Linear solvers for `A u = b`, behind a small trait so faster ones can be added.
//!
//! * The iterative methods, one file each, generic over the operator and preconditioner
//!   traits of [`pn_krylov::operator`] and stopped by the one controller of [`control`]:
//!   [`cg`], [`bicgstab`], [`gmres`] (square systems, chosen by name through [`krylov`]),
//!   [`cgls`], [`lsqr`], [`lsmr`] (least squares, on any operator with a transpose).
//! * The P_N-specific solvers: [`parity`] (eliminate the odd moments, Krylov on the reduced
//!   operator) and [`multigrid`] (aggregation multigrid preconditioner); they take the
//!   unknowns' classes and positions as plain data.
//! * [`pn_layout`]: the one module here that reads the P_N layout ([`crate::layout`]) and
//!   turns it into that data; [`SolverKind`] picks a solver by `--solver` name.
//!
//! Nothing here reads the environment: expert settings come in [`SolverOptions::tuning`].
//!
//! **Tolerance.** Every solver stops on the *relative* residual of the original system,
//! `‖b − A u‖₂ / ‖b‖₂ ≤ tol` (Euclidean norms over all unknowns). The absolute value
//! `‖b − A u‖₂` is reported too. The final residual in [`SolveStats`] is recomputed from
//! the returned solution, not taken from a recurrence.

pub mod cgnr;
pub mod cgnr_mf;
pub mod least_squares;
pub mod multigrid;
pub mod parity;
pub mod pn_layout;

pub use pn_krylov::{IterationObserver, SolveStats, SolveStatus, Stopping};
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
    /// `parity-cg` with the aggregation multigrid preconditioner ([`multigrid`]); needs the
    /// layout (`SolverKind::solver_for`, [`pn_layout`]). Systems without the parity structure (CDA)
    /// are solved with multigrid-preconditioned CG on the matrix itself.
    #[serde(rename = "parity-mg")]
    ParityMg,
    /// `parity-cg` with the preconditioners it chose before multigrid (ILU(0) up to
    /// [`parity::ILU_MAX_NONZEROS`] stored entries, else Jacobi), for side-by-side runs.
    #[serde(rename = "parity-ilu")]
    ParityIlu,
    /// LSQR (Paige–Saunders) on the assembled matrix; see [`lsqr`].
    Lsqr,
    /// LSMR (Fong–Saunders) on the assembled matrix; see [`lsmr`].
    Lsmr,
    /// CGNR with the matrix-free operator ([`crate::matfree`]): A is never stored.
    #[serde(rename = "cgnr-mf")]
    CgnrMf,
    /// LSQR with the matrix-free operator.
    #[serde(rename = "lsqr-mf")]
    LsqrMf,
    /// LSMR with the matrix-free operator.
    #[serde(rename = "lsmr-mf")]
    LsmrMf,
}

impl std::str::FromStr for SolverKind {
    type Err = anyhow::Error;
    fn from_str(s: &str) -> anyhow::Result<Self> {
        match s {
            "cgnr" => Ok(SolverKind::Cgnr),
            "parity-cg" => Ok(SolverKind::ParityCg),
            "parity-mg" => Ok(SolverKind::ParityMg),
            "parity-ilu" => Ok(SolverKind::ParityIlu),
            "lsqr" => Ok(SolverKind::Lsqr),
            "lsmr" => Ok(SolverKind::Lsmr),
            "cgnr-mf" => Ok(SolverKind::CgnrMf),
            "lsqr-mf" => Ok(SolverKind::LsqrMf),
            "lsmr-mf" => Ok(SolverKind::LsmrMf),
            _ => anyhow::bail!(
                "unknown solver {s:?} (available: cgnr, parity-cg, parity-mg, parity-ilu, lsqr, lsmr, cgnr-mf, lsqr-mf, lsmr-mf)"
            ),
        }
    }
}

impl SolverKind {
    /// The solver implementation.
    pub fn solver(self) -> Box<dyn LinearSolver> {
        match self {
            SolverKind::Cgnr => Box::new(cgnr::Cgnr),
            // The parity classes are detected from the matrix; with a `Layout` at hand,
            // `SolverKind::solver_for` gives the same solver without the detection.
            SolverKind::ParityCg => Box::new(parity::ParityCg::auto(parity::Precond::Auto)),
            // Without a layout there are no positions to aggregate: parity-cg's default.
            SolverKind::ParityMg | SolverKind::ParityIlu => {
                Box::new(parity::ParityCg::auto(parity::Precond::Auto))
            }
            // Given an assembled matrix, the matrix-free kinds run on it; the pipeline routes
            // them to `crate::pipeline::matrix_free` so that A is never assembled.
            SolverKind::Lsqr | SolverKind::LsqrMf => Box::new(least_squares::Lsqr),
            SolverKind::Lsmr | SolverKind::LsmrMf => Box::new(least_squares::Lsmr),
            SolverKind::CgnrMf => Box::new(cgnr_mf::CgnrMf),
        }
    }

    /// Whether the solver works on the matrix-free operator (the `-mf` names).
    pub fn is_matrix_free(self) -> bool {
        matches!(
            self,
            SolverKind::CgnrMf | SolverKind::LsqrMf | SolverKind::LsmrMf
        )
    }

    /// The `--solver` name.
    pub fn name(self) -> &'static str {
        match self {
            SolverKind::Cgnr => "cgnr",
            SolverKind::ParityCg => "parity-cg",
            SolverKind::ParityMg => "parity-mg",
            SolverKind::ParityIlu => "parity-ilu",
            SolverKind::Lsqr => "lsqr",
            SolverKind::Lsmr => "lsmr",
            SolverKind::CgnrMf => "cgnr-mf",
            SolverKind::LsqrMf => "lsqr-mf",
            SolverKind::LsmrMf => "lsmr-mf",
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
    /// Called after every iteration (None: nobody watches).
    pub observer: Option<IterationObserver>,
    /// Expert settings for experiments (multigrid parameters, a forced Krylov method,
    /// per-phase timing); the defaults are the tuned choices.
    pub tuning: SolverTuning,
}

/// Expert solver settings, passed in as values: the library never reads the environment.
/// The `pn` binary fills them from `PN_MG_*`, `PN_PARITY_METHOD`, `PN_SOLVER_PROFILE` and
/// `PN_PARITY_BLOCKS`
/// through [`SolverTuning::from_vars`].
#[derive(Clone, Debug, Default, PartialEq)]
pub struct SolverTuning {
    /// Multigrid parameters; `None`: each solver's tuned defaults.
    pub multigrid: Option<multigrid::MgOptions>,
    /// Force the Krylov method of the parity solvers (`cg`, `bicgstab`, `gmres`).
    pub krylov: Option<parity::KrylovMethod>,
    /// Print a per-phase timing line.
    pub profile: bool,
    /// Apply the reduced operator `S` from the stored parity blocks even where their
    /// stencils could be recovered ([`parity::stencil_s`]; for comparisons).
    pub block_operator: bool,
}

impl SolverTuning {
    /// The settings from named variables (`get("PN_MG_RATIO")` etc.; unset or unparsable
    /// values leave the default): `PN_MG_FINE_DEGREE`, `PN_MG_COARSE_DEGREE`,
    /// `PN_MG_COARSE_DEGREE_2D`, `PN_MG_RATIO`, `PN_MG_FINE_RATIO`, `PN_MG_POWER_STEPS`,
    /// `PN_MG_COARSE_MAX`, `PN_MG_SCALE` (see [`multigrid::MgOptions`]; `PN_MG_ADDITIVE=ω`
    /// with `ω > 0` forces [`multigrid::FineCycle::Additive`], `PN_MG_ADDITIVE=0`
    /// [`multigrid::FineCycle::Multiplicative`]), `PN_PARITY_METHOD=cg|bicgstab|gmres`,
    /// `PN_SOLVER_PROFILE` (set, to anything: profile), `PN_PARITY_BLOCKS` (set: apply `S`
    /// from the blocks, [`SolverTuning::block_operator`]). With none of them set it is
    /// [`SolverTuning::default`].
    pub fn from_vars(get: impl Fn(&str) -> Option<String>) -> Self {
        let mg = multigrid::MgOptions::from_vars(&get);
        Self {
            multigrid: (mg != multigrid::MgOptions::default()).then_some(mg),
            krylov: get("PN_PARITY_METHOD")
                .as_deref()
                .and_then(pn_krylov::KrylovMethod::from_name),
            profile: get("PN_SOLVER_PROFILE").is_some(),
            block_operator: get("PN_PARITY_BLOCKS").is_some(),
        }
    }

    /// The multigrid parameters to use: the given ones, or the tuned defaults.
    pub fn multigrid_options(&self) -> multigrid::MgOptions {
        self.multigrid.clone().unwrap_or_default()
    }
}

impl SolverOptions {
    /// The stopping rules the Krylov methods of `pn_krylov` take.
    pub fn stopping(&self) -> Stopping {
        Stopping {
            tol: self.tol,
            max_iter: self.max_iter,
            stagnation_window: self.stagnation_window,
            stagnation_drop: self.stagnation_drop,
            divergence_limit: self.divergence_limit,
            observer: self.observer.clone(),
        }
    }
}

impl Default for SolverOptions {
    fn default() -> Self {
        Self {
            tol: 1e-10,
            max_iter: 100_000,
            stagnation_window: 5000,
            stagnation_drop: 1e-4,
            divergence_limit: 1e8,
            observer: None,
            tuning: SolverTuning::default(),
        }
    }
}

/// A solver for square sparse systems.
pub trait LinearSolver: Send + Sync {
    /// Short name (`cgnr`).
    fn name(&self) -> &'static str;
    /// Solves `a u = b` starting from zero. Never fails; see the returned status.
    fn solve(&self, a: &CsMat<f64>, b: &[f64], opts: &SolverOptions) -> (Vec<f64>, SolveStats);
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::collections::HashMap;

    fn tuning(vars: &[(&str, &str)]) -> SolverTuning {
        let map: HashMap<String, String> = vars
            .iter()
            .map(|(k, v)| (k.to_string(), v.to_string()))
            .collect();
        SolverTuning::from_vars(|k| map.get(k).cloned())
    }

    #[test]
    fn no_variables_give_the_defaults() {
        assert_eq!(tuning(&[]), SolverTuning::default());
        assert_eq!(
            SolverTuning::default().multigrid_options(),
            multigrid::MgOptions::default()
        );
        // Unparsable values and unknown methods are ignored.
        assert_eq!(
            tuning(&[
                ("PN_MG_RATIO", "ten"),
                ("PN_PARITY_METHOD", "minres"),
                ("PN_MG_ADDITIVE", "-1")
            ]),
            SolverTuning::default()
        );
    }

    #[test]
    fn variables_set_the_fields() {
        let t = tuning(&[
            ("PN_MG_FINE_DEGREE", "3"),
            ("PN_MG_COARSE_DEGREE", "4"),
            ("PN_MG_COARSE_DEGREE_2D", "5"),
            ("PN_MG_RATIO", "12.5"),
            ("PN_MG_FINE_RATIO", "20"),
            ("PN_MG_POWER_STEPS", "6"),
            ("PN_MG_COARSE_MAX", "100"),
            ("PN_MG_SCALE", "1.2"),
            ("PN_MG_ADDITIVE", "0.5"),
            ("PN_PARITY_METHOD", "gmres"),
            ("PN_SOLVER_PROFILE", ""),
            ("PN_PARITY_BLOCKS", "1"),
        ]);
        let want = multigrid::MgOptions {
            fine_degree: 3,
            coarse_degree: 4,
            coarse_degree_2d: 5,
            ratio: 12.5,
            fine_ratio: 20.0,
            power_steps: 6,
            coarse_max: 100,
            correction_scale: Some(1.2),
            fine_cycle: multigrid::FineCycle::Additive { omega: 0.5 },
            ..multigrid::MgOptions::default()
        };
        assert_eq!(t.multigrid, Some(want));
        assert_eq!(t.krylov, Some(pn_krylov::KrylovMethod::Gmres));
        assert!(t.profile);
        assert!(t.block_operator);
        let m = tuning(&[("PN_MG_ADDITIVE", "0")]).multigrid_options();
        assert_eq!(m.fine_cycle, multigrid::FineCycle::Multiplicative);
        let b = tuning(&[("PN_PARITY_METHOD", "bicgstab")]);
        assert_eq!(b.krylov, Some(pn_krylov::KrylovMethod::BiCgStab));
        assert_eq!(b.multigrid, None);
    }
}
