//! The PETSc 3.18 and MPI calls the distributed solve makes: PETSc's own functions declared
//! as in its headers, and the shim's (`shim.c`) for everything that takes an MPI
//! communicator. `build.rs` compiles the shim, whose static assertions check that the
//! types and enum values below are this PETSc's.

#![allow(non_camel_case_types, missing_docs)]

use std::ffi::{c_char, c_int, c_void};

pub type PetscInt = i32;
pub type PetscScalar = f64;
pub type PetscReal = f64;
pub type PetscErrorCode = c_int;
pub type PetscBool = c_int;

/// Opaque PETSc objects (pointers to private structs).
#[repr(C)]
pub struct _p_Vec {
    _private: [u8; 0],
}
#[repr(C)]
pub struct _p_Mat {
    _private: [u8; 0],
}
#[repr(C)]
pub struct _p_KSP {
    _private: [u8; 0],
}
#[repr(C)]
pub struct _p_PC {
    _private: [u8; 0],
}
#[repr(C)]
pub struct _p_IS {
    _private: [u8; 0],
}
#[repr(C)]
pub struct _p_VecScatter {
    _private: [u8; 0],
}
pub type Vec = *mut _p_Vec;
pub type Mat = *mut _p_Mat;
pub type KSP = *mut _p_KSP;
pub type PC = *mut _p_PC;
pub type IS = *mut _p_IS;
pub type VecScatter = *mut _p_VecScatter;

pub const INSERT_VALUES: c_int = 1;
pub const SCATTER_FORWARD: c_int = 0;
pub const MAT_FINAL_ASSEMBLY: c_int = 0;
pub const ADD_VALUES: c_int = 2;
pub const KSP_NORM_UNPRECONDITIONED: c_int = 2;
pub const PC_RIGHT: c_int = 1;
pub const NORM_2: c_int = 1;
pub const PC_MG_GALERKIN_NONE: c_int = 3;
pub const MAT_INITIAL_MATRIX: c_int = 0;
pub const MAT_NEW_NONZERO_ALLOCATION_ERR: c_int = 19;
pub const PETSC_FALSE: PetscBool = 0;
pub const PETSC_DEFAULT: PetscInt = -2;
pub const PETSC_DEFAULT_REAL: PetscReal = -2.0;

/// `PetscErrorCode (*)(Mat, Vec, Vec)`: a shell matrix's product.
pub type MatMultFn = unsafe extern "C" fn(Mat, Vec, Vec) -> PetscErrorCode;
/// `PetscErrorCode (*)(Mat, Vec)`: a shell matrix's diagonal.
pub type MatDiagFn = unsafe extern "C" fn(Mat, Vec) -> PetscErrorCode;

extern "C" {
    pub fn pn_comm_rank() -> c_int;
    pub fn pn_comm_size() -> c_int;
    pub fn pn_abort(code: c_int);
    pub fn pn_allgather_doubles(input: *const f64, n: c_int, out: *mut f64) -> c_int;
    pub fn pn_allreduce_sum(input: *const f64, out: *mut f64, n: c_int) -> c_int;
    pub fn pn_allreduce_max_int(input: c_int, out: *mut c_int) -> c_int;
    pub fn pn_barrier() -> c_int;
    pub fn pn_wtime() -> f64;
    pub fn pn_peak_rss_bytes() -> f64;
    pub fn pn_reduction_count() -> i64;
    pub fn pn_vec_create_mpi(n: PetscInt, v: *mut Vec) -> PetscErrorCode;
    pub fn pn_vec_create_seq(n: PetscInt, v: *mut Vec) -> PetscErrorCode;
    pub fn pn_is_create_general(n: PetscInt, idx: *const PetscInt, is: *mut IS) -> PetscErrorCode;
    pub fn pn_mat_create_shell(n: PetscInt, ctx: *mut c_void, m: *mut Mat) -> PetscErrorCode;
    pub fn pn_mat_create_aij(
        n: PetscInt,
        d_nnz: *const PetscInt,
        o_nnz: *const PetscInt,
        m: *mut Mat,
    ) -> PetscErrorCode;
    pub fn pn_ksp_create(k: *mut KSP) -> PetscErrorCode;
    pub fn pn_mat_create_aij_rect(
        m: PetscInt,
        n: PetscInt,
        d_nnz: *const PetscInt,
        o_nnz: *const PetscInt,
        a: *mut Mat,
    ) -> PetscErrorCode;
    pub fn pn_pcmg_set_levels(pc: PC, levels: PetscInt) -> PetscErrorCode;
    pub fn pn_mat_shell_set_mult(m: Mat, f: MatMultFn) -> PetscErrorCode;
    pub fn pn_mat_shell_set_diagonal(m: Mat, f: MatDiagFn) -> PetscErrorCode;
}

extern "C" {
    pub fn PetscInitializeNoArguments() -> PetscErrorCode;
    pub fn PetscInitialized(flag: *mut PetscBool) -> PetscErrorCode;
    pub fn PetscFinalize() -> PetscErrorCode;
    pub fn PetscOptionsInsertString(options: *mut c_void, s: *const c_char) -> PetscErrorCode;
    pub fn PetscOptionsSetValue(
        options: *mut c_void,
        name: *const c_char,
        value: *const c_char,
    ) -> PetscErrorCode;

    pub fn VecDestroy(v: *mut Vec) -> PetscErrorCode;
    pub fn VecGetArray(v: Vec, a: *mut *mut PetscScalar) -> PetscErrorCode;
    pub fn VecRestoreArray(v: Vec, a: *mut *mut PetscScalar) -> PetscErrorCode;
    pub fn VecGetArrayRead(v: Vec, a: *mut *const PetscScalar) -> PetscErrorCode;
    pub fn VecRestoreArrayRead(v: Vec, a: *mut *const PetscScalar) -> PetscErrorCode;
    pub fn VecGetLocalSize(v: Vec, n: *mut PetscInt) -> PetscErrorCode;
    pub fn VecNorm(v: Vec, t: c_int, n: *mut PetscReal) -> PetscErrorCode;
    pub fn VecScatterCreate(x: Vec, ix: IS, y: Vec, iy: IS, ctx: *mut VecScatter)
        -> PetscErrorCode;
    pub fn VecScatterCreateToZero(x: Vec, ctx: *mut VecScatter, y: *mut Vec) -> PetscErrorCode;
    pub fn VecScatterCreateToAll(x: Vec, ctx: *mut VecScatter, y: *mut Vec) -> PetscErrorCode;
    pub fn VecScatterBegin(s: VecScatter, x: Vec, y: Vec, im: c_int, sm: c_int) -> PetscErrorCode;
    pub fn VecScatterEnd(s: VecScatter, x: Vec, y: Vec, im: c_int, sm: c_int) -> PetscErrorCode;
    pub fn VecScatterDestroy(s: *mut VecScatter) -> PetscErrorCode;
    pub fn ISDestroy(is: *mut IS) -> PetscErrorCode;

    pub fn MatMatMult(a: Mat, b: Mat, reuse: c_int, fill: PetscReal, c: *mut Mat)
        -> PetscErrorCode;
    pub fn MatTransposeMatMult(
        a: Mat,
        b: Mat,
        reuse: c_int,
        fill: PetscReal,
        c: *mut Mat,
    ) -> PetscErrorCode;
    pub fn MatMultTranspose(a: Mat, x: Vec, y: Vec) -> PetscErrorCode;
    pub fn MatTranspose(a: Mat, reuse: c_int, b: *mut Mat) -> PetscErrorCode;
    pub fn MatDiagonalSet(a: Mat, d: Vec, im: c_int) -> PetscErrorCode;
    pub fn MatScale(a: Mat, s: PetscScalar) -> PetscErrorCode;
    pub fn MatSetOption(a: Mat, op: c_int, flag: PetscBool) -> PetscErrorCode;
    pub fn MatCreateVecs(a: Mat, right: *mut Vec, left: *mut Vec) -> PetscErrorCode;
    pub fn MatShellGetContext(m: Mat, ctx: *mut c_void) -> PetscErrorCode;
    pub fn MatSetValues(
        m: Mat,
        nr: PetscInt,
        rows: *const PetscInt,
        nc: PetscInt,
        cols: *const PetscInt,
        v: *const PetscScalar,
        im: c_int,
    ) -> PetscErrorCode;
    pub fn MatAssemblyBegin(m: Mat, t: c_int) -> PetscErrorCode;
    pub fn MatAssemblyEnd(m: Mat, t: c_int) -> PetscErrorCode;
    pub fn MatIsSymmetric(m: Mat, tol: PetscReal, flag: *mut PetscBool) -> PetscErrorCode;
    pub fn MatDestroy(m: *mut Mat) -> PetscErrorCode;

    pub fn PCMGSetInterpolation(pc: PC, level: PetscInt, m: Mat) -> PetscErrorCode;
    pub fn PCMGSetGalerkin(pc: PC, t: c_int) -> PetscErrorCode;
    pub fn PCMGGetSmoother(pc: PC, level: PetscInt, k: *mut KSP) -> PetscErrorCode;
    pub fn MatPtAP(a: Mat, p: Mat, reuse: c_int, fill: PetscReal, c: *mut Mat) -> PetscErrorCode;
    pub fn KSPSetOperators(k: KSP, a: Mat, p: Mat) -> PetscErrorCode;
    pub fn KSPSetType(k: KSP, t: *const c_char) -> PetscErrorCode;
    pub fn KSPGetPC(k: KSP, pc: *mut PC) -> PetscErrorCode;
    pub fn PCSetType(pc: PC, t: *const c_char) -> PetscErrorCode;
    pub fn KSPSetTolerances(
        k: KSP,
        rtol: PetscReal,
        abstol: PetscReal,
        dtol: PetscReal,
        maxits: PetscInt,
    ) -> PetscErrorCode;
    pub fn KSPSetNormType(k: KSP, t: c_int) -> PetscErrorCode;
    pub fn KSPSetPCSide(k: KSP, s: c_int) -> PetscErrorCode;
    pub fn KSPSetFromOptions(k: KSP) -> PetscErrorCode;
    pub fn KSPSetUp(k: KSP) -> PetscErrorCode;
    pub fn KSPSolve(k: KSP, b: Vec, x: Vec) -> PetscErrorCode;
    pub fn KSPGetIterationNumber(k: KSP, n: *mut PetscInt) -> PetscErrorCode;
    pub fn KSPGetConvergedReason(k: KSP, r: *mut c_int) -> PetscErrorCode;
    pub fn KSPGetResidualNorm(k: KSP, r: *mut PetscReal) -> PetscErrorCode;
    pub fn KSPDestroy(k: *mut KSP) -> PetscErrorCode;
}
