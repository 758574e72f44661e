//! The parity-reduced P_N solve split into boxes of cells, one per process (issue 51).
//!
//! * [`partition`]: the box partition of the cells and the owner of every staggered position.
//! * [`numbering`]: the distributed numbering of the kept and the eliminated unknowns,
//!   computed by every process without communication.
//! * [`local`]: one process's rows of `A`, split into the parity blocks, and the
//!   application of `S = D_e − B D_o⁻¹ C` from its owned values and ghosts (bit for bit the
//!   same row values on any number of processes).
//! * [`simulate`]: all processes in one, the ghost exchanges by copying — the reference
//!   the MPI runs are checked against.
//! * `petsc` (feature `petsc`): the solve on PETSc and MPI — `S` as a shell matrix whose
//!   ghost exchanges are PETSc scatters, PETSc's Krylov methods, and the assembled `S` for
//!   PETSc's algebraic multigrid (GAMG) or hypre's BoomerAMG.
//!
//! Like `pn-runtime`, this crate does no file I/O and prints nothing: it returns values;
//! PETSc itself prints a traceback to standard error when one of its calls fails.

#![warn(missing_docs)]

pub mod local;
pub mod numbering;
pub mod partition;
#[cfg(feature = "petsc")]
pub mod petsc;
pub mod simulate;

pub use local::LocalReduced;
pub use numbering::Numbering;
pub use partition::{Decomposition, PartitionError, MIN_CELLS_PER_BOX};
pub use simulate::SimulatedRanks;
