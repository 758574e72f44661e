//! The arguments of each `pn` subcommand and their conversion into the drivers' requests;
//! the environment the binary reads ([`Env`]).

pub mod bench;
pub mod compare;
pub mod derive;
pub mod export_mitsuba;
pub mod figure;
pub mod race;
pub mod render;
pub mod solve;
pub mod stencil;
pub mod tradeoff;

use pn_render::mitsuba::PYTHON_ENV;
use pn_runtime::solver::SolverTuning;
use std::path::{Path, PathBuf};

/// What `pn` reads from the environment, once, in `main` (the libraries read none of it).
#[derive(Clone, Debug, Default)]
pub struct Env {
    /// Expert solver settings from `PN_MG_*`, `PN_PARITY_METHOD`, `PN_SOLVER_PROFILE`.
    pub tuning: SolverTuning,
    /// `$PN_MITSUBA_PYTHON`, when set and not empty.
    pub mitsuba_python: Option<PathBuf>,
}

impl Env {
    /// Reads the process environment.
    pub fn from_process() -> Self {
        Self {
            tuning: SolverTuning::from_vars(|k| std::env::var(k).ok()),
            mitsuba_python: std::env::var_os(PYTHON_ENV)
                .filter(|p| !p.is_empty())
                .map(PathBuf::from),
        }
    }

    /// The Mitsuba interpreter the user chose: `--python`, else `$PN_MITSUBA_PYTHON`.
    pub fn python(&self, flag: Option<&Path>) -> Option<PathBuf> {
        flag.map(Path::to_path_buf)
            .or_else(|| self.mitsuba_python.clone())
    }
}

/// `--threads N`: a whole number from 1 to what the machine can use
/// ([`pn_runtime::max_threads`]), checked before anything is read or started.
pub fn parse_threads(s: &str) -> Result<usize, String> {
    let n: usize = s
        .trim()
        .parse()
        .map_err(|_| format!("--threads must be a whole number of at least 1, not {s:?}"))?;
    pn_runtime::check_threads(n).map_err(|e| e.to_string())
}
