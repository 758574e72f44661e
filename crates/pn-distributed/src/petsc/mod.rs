//! The distributed solve on PETSc and MPI (feature `petsc`).
//!
//! * [`ffi`]: the PETSc and MPI calls (and the C shim for those that take a communicator).
//! * `objects`: owning wrappers that destroy PETSc objects when dropped.
//! * [`mod@solve`]: the solve — the reduced right-hand side, the Krylov solve (`krylov`: the
//!   preconditioners, the symmetry probe, PETSc's settings) over the shell operator
//!   (`operator`), the recovery of the eliminated moments and the gather onto process 0.
//! * [`pcmg`]: the project's aggregation multigrid on PCMG; `blocks`: its first coarse
//!   operator from the parity blocks.
//! * [`probe`]: one application of the distributed `S` (the operator-parity check).

mod blocks;
pub mod ffi;
mod krylov;
mod objects;
mod operator;
mod options;
pub mod pcmg;
pub mod probe;
pub mod solve;

pub use options::{DistributedOptions, KspChoice, PcChoice};
pub use solve::{solve, DistributedSolution, RankStats};

use anyhow::Context;
use ffi::PetscErrorCode;

/// Turns a PETSc error code into an error naming the call.
pub(crate) fn check(code: PetscErrorCode, what: &str) -> anyhow::Result<()> {
    anyhow::ensure!(code == 0, "PETSc call {what} failed with error code {code}");
    Ok(())
}

/// PETSc and MPI, initialized for the life of the value (finalized when it is dropped).
/// One per process; create it before any other PETSc call.
pub struct Mpi {
    _private: (),
}

impl Mpi {
    /// Initializes PETSc (and MPI). PETSc reads no command-line arguments here; options
    /// come through [`DistributedOptions::petsc_options`].
    pub fn init() -> anyhow::Result<Self> {
        // SAFETY: PetscInitializeNoArguments may be called once before any other PETSc call;
        // `Mpi` is created once per process by the caller (see the type's documentation).
        check(
            unsafe { ffi::PetscInitializeNoArguments() },
            "PetscInitialize",
        )
        .context("starting PETSc and MPI")?;
        Ok(Self { _private: () })
    }

    /// This process's rank.
    pub fn rank(&self) -> usize {
        // SAFETY: PETSc (and so MPI) is initialized while `self` lives.
        unsafe { ffi::pn_comm_rank() as usize }
    }

    /// Number of processes.
    pub fn size(&self) -> usize {
        // SAFETY: as in `rank`.
        unsafe { ffi::pn_comm_size() as usize }
    }

    /// Ends every process with exit status `code` (MPI_Abort): what an error on one process
    /// must do, since the others would wait for it in their next collective call.
    pub fn abort(&self, code: i32) -> ! {
        // SAFETY: MPI is initialized; MPI_Abort does not return.
        unsafe { ffi::pn_abort(code) };
        std::process::abort()
    }

    /// `values` of every process, process 0's first.
    pub fn allgather(&self, values: &[f64]) -> anyhow::Result<Vec<f64>> {
        let mut out = vec![0.0; values.len() * self.size()];
        // SAFETY: `out` holds `values.len()` doubles per process, as MPI_Allgather writes.
        let code = unsafe {
            ffi::pn_allgather_doubles(values.as_ptr(), values.len() as i32, out.as_mut_ptr())
        };
        anyhow::ensure!(code == 0, "MPI_Allgather failed with error code {code}");
        Ok(out)
    }

    /// The sum over the processes of `values`, element by element.
    pub fn sum(&self, values: &[f64]) -> anyhow::Result<Vec<f64>> {
        let mut out = vec![0.0; values.len()];
        // SAFETY: both buffers hold `values.len()` doubles.
        let code = unsafe {
            ffi::pn_allreduce_sum(values.as_ptr(), out.as_mut_ptr(), values.len() as i32)
        };
        anyhow::ensure!(code == 0, "MPI_Allreduce failed with error code {code}");
        Ok(out)
    }

    /// Waits for every process.
    pub fn barrier(&self) -> anyhow::Result<()> {
        // SAFETY: MPI is initialized.
        let code = unsafe { ffi::pn_barrier() };
        anyhow::ensure!(code == 0, "MPI_Barrier failed with error code {code}");
        Ok(())
    }

    /// The global reductions (MPI_Allreduce calls on more than one process) this process has
    /// taken part in so far, as PETSc counts them (`petsc_allreduce_ct`).
    pub fn reductions(&self) -> i64 {
        // SAFETY: reads a counter.
        unsafe { ffi::pn_reduction_count() }
    }

    /// Peak resident memory of this process in bytes (getrusage).
    pub fn peak_memory_bytes(&self) -> f64 {
        // SAFETY: getrusage has no preconditions.
        unsafe { ffi::pn_peak_rss_bytes() }
    }
}

impl Drop for Mpi {
    fn drop(&mut self) {
        // SAFETY: every PETSc object is destroyed before `Mpi` is dropped (the solve's
        // objects are owned by wrappers local to it).
        unsafe {
            ffi::PetscFinalize();
        }
    }
}
