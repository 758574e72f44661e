/* The C side of pn-distributed's PETSc binding: the calls that take an MPI communicator
 * (whose C type differs between MPI implementations, so Rust never holds one), MPI's
 * collectives on PETSC_COMM_WORLD, and compile-time checks that the types and enum values
 * the Rust declarations (ffi.rs) assume are this PETSc's. */
#include <petscksp.h>
#include <sys/resource.h>

_Static_assert(sizeof(PetscInt) == 4, "pn-distributed needs PETSc with 32-bit PetscInt");
_Static_assert(sizeof(PetscScalar) == sizeof(double), "pn-distributed needs real double PetscScalar");
_Static_assert(sizeof(PetscReal) == sizeof(double), "pn-distributed needs double PetscReal");
_Static_assert(sizeof(PetscErrorCode) == sizeof(int), "PetscErrorCode is an int");
_Static_assert(sizeof(PetscBool) == sizeof(int), "PetscBool is an int-sized enum");
_Static_assert(INSERT_VALUES == 1, "InsertMode INSERT_VALUES");
_Static_assert(SCATTER_FORWARD == 0, "ScatterMode SCATTER_FORWARD");
_Static_assert(MAT_FINAL_ASSEMBLY == 0, "MatAssemblyType MAT_FINAL_ASSEMBLY");
_Static_assert(MATOP_MULT == 3, "MatOperation MATOP_MULT");
_Static_assert(MATOP_GET_DIAGONAL == 17, "MatOperation MATOP_GET_DIAGONAL");
_Static_assert(ADD_VALUES == 2, "InsertMode ADD_VALUES");
_Static_assert(KSP_NORM_UNPRECONDITIONED == 2, "KSPNormType KSP_NORM_UNPRECONDITIONED");
_Static_assert(PC_RIGHT == 1, "PCSide PC_RIGHT");
_Static_assert(NORM_2 == 1, "NormType NORM_2");
_Static_assert(PETSC_COPY_VALUES == 0, "PetscCopyMode PETSC_COPY_VALUES");
_Static_assert(PC_MG_GALERKIN_NONE == 3, "PCMGGalerkinType PC_MG_GALERKIN_NONE");
_Static_assert(MAT_INITIAL_MATRIX == 0, "MatReuse MAT_INITIAL_MATRIX");
_Static_assert(MAT_NEW_NONZERO_ALLOCATION_ERR == 19, "MatOption MAT_NEW_NONZERO_ALLOCATION_ERR");
_Static_assert(PETSC_FALSE == 0, "PetscBool PETSC_FALSE");
_Static_assert(PETSC_DECIDE == -1 && PETSC_DETERMINE == -1, "PETSC_DECIDE");

int pn_comm_rank(void) {
  PetscMPIInt r = 0;
  MPI_Comm_rank(PETSC_COMM_WORLD, &r);
  return r;
}

int pn_comm_size(void) {
  PetscMPIInt s = 1;
  MPI_Comm_size(PETSC_COMM_WORLD, &s);
  return s;
}

void pn_abort(int code) { MPI_Abort(PETSC_COMM_WORLD, code); }

/* out[k*n + i] = in[i] of process k, on every process. */
int pn_allgather_doubles(const double *in, int n, double *out) {
  return MPI_Allgather(in, n, MPI_DOUBLE, out, n, MPI_DOUBLE, PETSC_COMM_WORLD);
}

int pn_allreduce_sum(const double *in, double *out, int n) {
  return MPI_Allreduce(in, out, n, MPI_DOUBLE, MPI_SUM, PETSC_COMM_WORLD);
}

int pn_allreduce_max_int(int in, int *out) {
  return MPI_Allreduce(&in, out, 1, MPI_INT, MPI_MAX, PETSC_COMM_WORLD);
}

int pn_barrier(void) { return MPI_Barrier(PETSC_COMM_WORLD); }

double pn_wtime(void) { return MPI_Wtime(); }

/* Peak resident memory of this process in bytes (Linux reports kilobytes). */
double pn_peak_rss_bytes(void) {
  struct rusage u;
  if (getrusage(RUSAGE_SELF, &u) != 0) return -1.0;
  return 1024.0 * (double)u.ru_maxrss;
}

PetscErrorCode pn_vec_create_mpi(PetscInt n, Vec *v) { return VecCreateMPI(PETSC_COMM_WORLD, n, PETSC_DETERMINE, v); }

PetscErrorCode pn_vec_create_seq(PetscInt n, Vec *v) { return VecCreateSeq(PETSC_COMM_SELF, n, v); }

PetscErrorCode pn_is_create_general(PetscInt n, const PetscInt *idx, IS *is) {
  return ISCreateGeneral(PETSC_COMM_SELF, n, idx, PETSC_COPY_VALUES, is);
}

PetscErrorCode pn_mat_create_shell(PetscInt n, void *ctx, Mat *m) {
  return MatCreateShell(PETSC_COMM_WORLD, n, n, PETSC_DETERMINE, PETSC_DETERMINE, ctx, m);
}

PetscErrorCode pn_mat_create_aij(PetscInt n, const PetscInt *d_nnz, const PetscInt *o_nnz, Mat *m) {
  return MatCreateAIJ(PETSC_COMM_WORLD, n, n, PETSC_DETERMINE, PETSC_DETERMINE, 0, d_nnz, 0, o_nnz, m);
}

PetscErrorCode pn_ksp_create(KSP *k) { return KSPCreate(PETSC_COMM_WORLD, k); }

PetscErrorCode pn_mat_create_aij_rect(PetscInt m, PetscInt n, const PetscInt *d_nnz, const PetscInt *o_nnz, Mat *a) {
  return MatCreateAIJ(PETSC_COMM_WORLD, m, n, PETSC_DETERMINE, PETSC_DETERMINE, 0, d_nnz, 0, o_nnz, a);
}

/* PCMG with `levels` levels on PETSC_COMM_WORLD (no per-level communicators). */
PetscErrorCode pn_pcmg_set_levels(PC pc, PetscInt levels) { return PCMGSetLevels(pc, levels, NULL); }

/* A shell matrix's product and diagonal (MatShellSetOperation takes a void(*)(void)). */
PetscErrorCode pn_mat_shell_set_mult(Mat m, PetscErrorCode (*f)(Mat, Vec, Vec)) {
  return MatShellSetOperation(m, MATOP_MULT, (void (*)(void))f);
}

PetscErrorCode pn_mat_shell_set_diagonal(Mat m, PetscErrorCode (*f)(Mat, Vec)) {
  return MatShellSetOperation(m, MATOP_GET_DIAGONAL, (void (*)(void))f);
}

/* The global reductions (MPI_Allreduce on more than one process) this process has taken
 * part in: PETSc counts them itself (petsclog.h wraps its calls of MPI_Allreduce). */
long long pn_reduction_count(void) { return (long long)petsc_allreduce_ct; }
