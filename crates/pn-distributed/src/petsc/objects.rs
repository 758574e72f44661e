//! Owning wrappers of PETSc objects: each destroys its object when dropped.

use super::check;
use super::ffi::{self, PetscInt};
use std::ptr::null_mut;

/// A PETSc vector.
pub(crate) struct PVec(pub(crate) ffi::Vec);

impl PVec {
    /// A vector split over the processes with `n` entries here.
    pub(crate) fn mpi(n: usize) -> anyhow::Result<Self> {
        let mut v = null_mut();
        // SAFETY: `v` receives the new vector.
        check(
            unsafe { ffi::pn_vec_create_mpi(n as PetscInt, &mut v) },
            "VecCreateMPI",
        )?;
        Ok(Self(v))
    }

    /// A vector of `n` entries on this process only.
    pub(crate) fn seq(n: usize) -> anyhow::Result<Self> {
        let mut v = null_mut();
        // SAFETY: `v` receives the new vector.
        check(
            unsafe { ffi::pn_vec_create_seq(n as PetscInt, &mut v) },
            "VecCreateSeq",
        )?;
        Ok(Self(v))
    }

    /// Copies this process's entries out.
    pub(crate) fn to_vec(&self) -> anyhow::Result<Vec<f64>> {
        read(self.0, |a| a.to_vec())
    }

    /// Overwrites this process's entries with `values` (of the local length).
    pub(crate) fn fill(&self, values: &[f64]) -> anyhow::Result<()> {
        write(self.0, |a| a.copy_from_slice(values))
    }
}

impl Drop for PVec {
    fn drop(&mut self) {
        // SAFETY: the vector was created by PETSc and is destroyed once.
        unsafe {
            ffi::VecDestroy(&mut self.0);
        }
    }
}

/// The local length of `v`.
fn local_len(v: ffi::Vec) -> anyhow::Result<usize> {
    let mut n: PetscInt = 0;
    // SAFETY: `v` is a valid vector.
    check(
        unsafe { ffi::VecGetLocalSize(v, &mut n) },
        "VecGetLocalSize",
    )?;
    Ok(n as usize)
}

/// Calls `f` with the local entries of `v`, read-only.
pub(crate) fn read<T>(v: ffi::Vec, f: impl FnOnce(&[f64]) -> T) -> anyhow::Result<T> {
    let n = local_len(v)?;
    let mut p: *const f64 = std::ptr::null();
    // SAFETY: PETSc returns the local array of `n` entries, valid until restored.
    check(
        unsafe { ffi::VecGetArrayRead(v, &mut p) },
        "VecGetArrayRead",
    )?;
    let out = f(if n == 0 {
        &[]
    } else {
        // SAFETY: as above; the slice does not outlive the restore below.
        unsafe { std::slice::from_raw_parts(p, n) }
    });
    // SAFETY: restores the array obtained above.
    check(
        unsafe { ffi::VecRestoreArrayRead(v, &mut p) },
        "VecRestoreArrayRead",
    )?;
    Ok(out)
}

/// Calls `f` with the local entries of `v`, writable.
pub(crate) fn write<T>(v: ffi::Vec, f: impl FnOnce(&mut [f64]) -> T) -> anyhow::Result<T> {
    let n = local_len(v)?;
    let mut p: *mut f64 = null_mut();
    // SAFETY: PETSc returns the local array of `n` entries, valid until restored.
    check(unsafe { ffi::VecGetArray(v, &mut p) }, "VecGetArray")?;
    let out = f(if n == 0 {
        &mut []
    } else {
        // SAFETY: as above; the slice does not outlive the restore below.
        unsafe { std::slice::from_raw_parts_mut(p, n) }
    });
    // SAFETY: restores the array obtained above.
    check(
        unsafe { ffi::VecRestoreArray(v, &mut p) },
        "VecRestoreArray",
    )?;
    Ok(out)
}

/// A scatter from a distributed vector into a vector on this process (the ghost values).
pub(crate) struct Scatter {
    sc: ffi::VecScatter,
    /// The receiving vector (the ghosts, in the order of the indices).
    pub(crate) ghosts: PVec,
}

impl Scatter {
    /// Gathers the entries `global` (numbers in `from`'s distribution) into `ghosts`.
    pub(crate) fn new(from: &PVec, global: &[PetscInt]) -> anyhow::Result<Self> {
        let ghosts = PVec::seq(global.len())?;
        let mut is = null_mut();
        // SAFETY: `global` holds `global.len()` indices; PETSc copies them.
        check(
            unsafe {
                ffi::pn_is_create_general(global.len() as PetscInt, global.as_ptr(), &mut is)
            },
            "ISCreateGeneral",
        )?;
        let mut sc = null_mut();
        // SAFETY: `from`, `is` and `ghosts` are valid; a null `iy` means all of `ghosts`.
        let made = check(
            unsafe { ffi::VecScatterCreate(from.0, is, ghosts.0, null_mut(), &mut sc) },
            "VecScatterCreate",
        );
        // SAFETY: the scatter keeps what it needs of the index set.
        unsafe {
            ffi::ISDestroy(&mut is);
        }
        made?;
        Ok(Self { sc, ghosts })
    }

    /// Fills the ghosts from `from`.
    pub(crate) fn run(&self, from: ffi::Vec) -> anyhow::Result<()> {
        let (i, s) = (ffi::INSERT_VALUES, ffi::SCATTER_FORWARD);
        // SAFETY: the vectors are those the scatter was made for.
        check(
            unsafe { ffi::VecScatterBegin(self.sc, from, self.ghosts.0, i, s) },
            "VecScatterBegin",
        )?;
        // SAFETY: as above.
        check(
            unsafe { ffi::VecScatterEnd(self.sc, from, self.ghosts.0, i, s) },
            "VecScatterEnd",
        )
    }
}

impl Drop for Scatter {
    fn drop(&mut self) {
        // SAFETY: created by PETSc, destroyed once.
        unsafe {
            ffi::VecScatterDestroy(&mut self.sc);
        }
    }
}

/// A PETSc matrix.
pub(crate) struct PMat(pub(crate) ffi::Mat);

impl Drop for PMat {
    fn drop(&mut self) {
        if !self.0.is_null() {
            // SAFETY: created by PETSc, destroyed once.
            unsafe {
                ffi::MatDestroy(&mut self.0);
            }
        }
    }
}

impl PMat {
    /// Finishes a matrix whose values are all set (PETSc's final assembly: the entries set
    /// for other processes' rows are sent to them).
    pub(crate) fn assemble(&self) -> anyhow::Result<()> {
        // SAFETY: a valid matrix; every process calls this for its share.
        unsafe {
            check(
                ffi::MatAssemblyBegin(self.0, ffi::MAT_FINAL_ASSEMBLY),
                "MatAssemblyBegin",
            )?;
            check(
                ffi::MatAssemblyEnd(self.0, ffi::MAT_FINAL_ASSEMBLY),
                "MatAssemblyEnd",
            )
        }
    }
}

/// A PETSc Krylov solver.
pub(crate) struct Ksp(pub(crate) ffi::KSP);

impl Drop for Ksp {
    fn drop(&mut self) {
        // SAFETY: created by PETSc, destroyed once.
        unsafe {
            ffi::KSPDestroy(&mut self.0);
        }
    }
}

/// The whole of a distributed vector on process 0 (empty elsewhere), or on every process.
pub(crate) fn gather(v: &PVec, everywhere: bool) -> anyhow::Result<Vec<f64>> {
    let mut sc = null_mut();
    let mut out = null_mut();
    // SAFETY: `v` is valid; PETSc creates the scatter and the receiving vector.
    check(
        unsafe {
            if everywhere {
                ffi::VecScatterCreateToAll(v.0, &mut sc, &mut out)
            } else {
                ffi::VecScatterCreateToZero(v.0, &mut sc, &mut out)
            }
        },
        "VecScatterCreateTo…",
    )?;
    let out = PVec(out);
    let (i, s) = (ffi::INSERT_VALUES, ffi::SCATTER_FORWARD);
    // SAFETY: the vectors are those the scatter was made for.
    let run = check(
        unsafe { ffi::VecScatterBegin(sc, v.0, out.0, i, s) },
        "VecScatterBegin",
    )
    // SAFETY: as above.
    .and_then(|_| {
        check(
            unsafe { ffi::VecScatterEnd(sc, v.0, out.0, i, s) },
            "VecScatterEnd",
        )
    });
    // SAFETY: created above, destroyed once.
    unsafe {
        ffi::VecScatterDestroy(&mut sc);
    }
    run?;
    out.to_vec()
}
