//! Flux-limited diffusion through the generated stencil: a Picard iteration whose steps are
//! linear diffusion solves (docs/fld.md).
//!
//! Each step freezes the FLD coefficient at the current iterate, `D_k = F(R(φ_k))/max(σ_t, σ_ε)`
//! on the cell faces ([`super::face_diffusion_coefficients`]), assembles the linear diffusion PDE
//! `−∇·(D_k ∇φ) + σ_a φ = q` from a [`StencilKernel`] (the generated `diffusion_3d` stencil,
//! docs/design.md §2.2 with D a field), solves it with one of the project's linear solvers
//! ([`SolverKind`]) and stops when the *nonlinear* residual of the red–black solver,
//! [`super::relative_residual`], falls below `params.tol`. Both routes therefore stop on the
//! same quantity and converge to the same discrete solution.
//!
//! ## The same discretisation as the Gauss–Seidel route
//!
//! * **Grid.** The stencil rows are assembled at the interior cells of the [`FldGrid`] only;
//!   the outermost cell layer is the Dirichlet layer `φ = ε j̄ h` of the Gauss–Seidel solver.
//!   A stencil term that reaches a boundary-layer cell is moved to the right-hand side with
//!   that known value, so the unknowns are exactly the interior cells the red–black solver
//!   relaxes.
//! * **Fields.** σ_a and q are cell-centred voxel fields ([`VoxelGrid`]) over the same cells,
//!   requested by the stencil at the cell centre. `D_k` lives on the faces
//!   ([`FaceCoefficients`], the Knudsen number being evaluated there, see `operator.rs`); the
//!   stencil requests D at the half-cell offsets ±1 along one axis, which are exactly those
//!   faces, and gets the very `D_f` the red–black operator uses. A request for D anywhere
//!   else is an error.
//! * **Units.** The stencil is written for `L_0^0` with source `Q_0^0`. The equation is linear
//!   and both sides scale with `√(4π)` (`φ = √(4π) L_0^0`, `q = √(4π) Q_0^0`, docs/design.md §1), so
//!   feeding it the fluence source q yields the fluence φ directly; the caller converts to
//!   `L_0^0` where it needs P_N units.
//!
//! ## Each step
//!
//! Step k solves the linear system `A_k φ = b_k` (b_k holds q and the boundary terms) in
//! correction form: `A_k δ = b_k − A_k φ_k`, `φ_{k+1} = φ_k + δ`, with the linear solver's
//! relative tolerance [`PicardOptions::linear_tol`] measured against the current residual
//! (an inexact Picard step; the linear solvers start from 0, so this is how the previous
//! iterate is reused). The linear residual `b_k − A_k φ_k` is, row for row, the residual the
//! red–black solver measures with D frozen at φ_k.

use anyhow::{bail, ensure, Context, Result};
use pn_stencil::{Dim, FieldContext, FieldRef, HalfOffset, StencilKernel};
use rayon::prelude::*;
use sprs::CsMat;
use std::cell::Cell;

use super::faces::FaceCoefficients;
use super::grid::{FldGrid, FldProblem};
use super::operator::Operator;
use super::params::FldParams;
use super::solver::FldSolution;
use crate::field::VoxelGrid;
use crate::solver::multigrid::solve::mg_krylov;
use crate::solver::multigrid::Geometry;
use crate::solver::{SolveStatus, SolverKind, SolverOptions, SolverTuning};
use pn_krylov::linalg::residual;

/// Options of the Picard route (the nonlinear tolerance and σ_ε, ε, limiter come from
/// [`FldParams`]; `FldParams::omega` and `max_iter` belong to the red–black route).
#[derive(Debug, Clone, PartialEq)]
pub struct PicardOptions {
    /// The linear solver of each step.
    pub solver: SolverKind,
    /// Relative tolerance of each linear solve against the current residual
    /// (`‖b_k − A_k φ_{k+1}‖₂ ≤ linear_tol · ‖b_k − A_k φ_k‖₂`).
    pub linear_tol: f64,
    /// Iteration limit of each linear solve.
    pub max_linear_iter: usize,
    /// Maximum number of Picard steps.
    pub max_steps: usize,
    /// Anderson acceleration of the Picard map over this many previous steps (0: plain
    /// Picard). The stopping test is unchanged (the nonlinear residual), so the answer is the
    /// same; see [`Anderson`].
    pub anderson_depth: usize,
    /// Expert settings of the linear solver (multigrid parameters, Krylov method, profile).
    pub tuning: SolverTuning,
}

impl Default for PicardOptions {
    /// parity-cg (on this scalar system it is red–black-reduced preconditioned CG), linear
    /// tolerance 1e-2, 100 000 linear iterations, 500 steps. Measured on the LP sphere in
    /// vacuum at 24³ (`linear_tolerance_study` in `tests/fld_picard.rs`): linear tolerances
    /// 0.5 / 1e-1 / 1e-2 / 1e-4 / 1e-8 need 92 / 49 / 55 / 55 / 55 Picard steps — tighter solves
    /// do not save steps, which the nonlinearity limits; 1e-2 rather than 1e-1 because the
    /// linear CDA case then needs 3 steps (measured) where 1e-1 guarantees only a 10× reduction
    /// per step, i.e. up to 6 for tol = 1e-6 (and a step costs mostly the solver's setup).
    /// Anderson depth 5: on the four race scenes' render solves (LP, tol 1e-6) it cut the
    /// steps from 47/38/30/42 to 28/29/26/27 (nebula, cloud, puff, cumulus; depth 3 and 8
    /// gave the same counts within one step), the fluence unchanged to 3e-7 (docs/fld.md).
    fn default() -> Self {
        Self {
            solver: SolverKind::ParityCg,
            linear_tol: 1e-2,
            max_linear_iter: 100_000,
            max_steps: 500,
            anderson_depth: 5,
            tuning: SolverTuning::default(),
        }
    }
}

impl PicardOptions {
    /// Checks the options.
    pub fn validate(&self) -> Result<()> {
        ensure!(
            self.linear_tol.is_finite() && self.linear_tol > 0.0 && self.linear_tol < 1.0,
            "Picard linear tolerance must lie in (0, 1), got {}",
            self.linear_tol
        );
        ensure!(
            self.max_linear_iter >= 1,
            "Picard max_linear_iter must be at least 1"
        );
        ensure!(self.max_steps >= 1, "Picard max_steps must be at least 1");
        Ok(())
    }
}

/// The result of [`solve_fld_picard`].
#[derive(Debug, Clone, PartialEq)]
pub struct PicardSolution {
    /// φ, the Picard steps (`iterations`), the nonlinear relative residual before each step and
    /// after the last (`residual_history`), convergence, j̄ and the boundary value — the same
    /// meaning as for [`super::solve_fld`].
    pub fld: FldSolution,
    /// Linear-solver iterations of each step.
    pub linear_iterations: Vec<usize>,
    /// Name of the linear solver.
    pub solver: String,
    /// Interior unknowns of each linear system.
    pub unknowns: usize,
    /// Stored non-zeros of the last assembled matrix.
    pub nonzeros: usize,
    /// Per-step timings when the solver tuning asks for a profile (the caller prints them).
    pub notes: Vec<String>,
}

impl PicardSolution {
    /// Total linear-solver iterations over all steps.
    pub fn total_linear_iterations(&self) -> usize {
        self.linear_iterations.iter().sum()
    }
}

/// Solves flux-limited diffusion by Picard iteration through `kernel` (a scalar cell-centred
/// diffusion stencil with D as a field, e.g. the generated `diffusion_3d`), starting from
/// `initial` (its boundary layer replaced by the Dirichlet value) or from the boundary value
/// everywhere.
///
/// Stops when [`super::relative_residual`] `< params.tol` (converged), after
/// `opts.max_steps` steps, or when a linear solve diverges or the residual is not finite
/// (not converged; [`FldSolution::into_converged`] turns that into an error). Bad input is an
/// error: the checks of [`super::solve_fld`], a kernel that is not a 3D scalar cell-centred
/// stencil, or a stencil that reaches beyond the boundary layer.
pub fn solve_fld_picard(
    problem: &FldProblem,
    params: &FldParams,
    kernel: &dyn StencilKernel,
    opts: &PicardOptions,
    initial: Option<&[f64]>,
) -> Result<PicardSolution> {
    let op = Operator::new(problem, params)?;
    opts.validate()?;
    check_kernel(kernel)?;
    let grid = op.grid;
    let len = grid.len();
    let interior = InteriorIndex::new(grid);
    // The steps are scalar diffusion systems (SPD): the parity kinds, which would find no
    // parity structure to eliminate, solve them with multigrid-preconditioned CG, as they
    // do for CDA through the pipeline (falling back to their usual route if the hierarchy
    // cannot be built); the other kinds run as given.
    let geometry = matches!(opts.solver, SolverKind::ParityCg | SolverKind::ParityMg)
        .then(|| interior.geometry());
    let solver_name = if geometry.is_some() {
        "mg-cg".to_string()
    } else {
        opts.solver.solver().name().to_string()
    };
    if let Some(phi0) = initial {
        ensure!(
            phi0.len() == len && phi0.iter().all(|v| v.is_finite()),
            "initial fluence must have {len} finite values"
        );
    }
    if op.rms_source == 0.0 {
        return Ok(PicardSolution {
            fld: FldSolution {
                phi: vec![0.0; len],
                iterations: 0,
                residual_history: vec![0.0],
                converged: true,
                rms_source: 0.0,
                phi_boundary: 0.0,
            },
            linear_iterations: Vec::new(),
            solver: solver_name,
            unknowns: interior.len(),
            nonzeros: 0,
            notes: Vec::new(),
        });
    }
    let voxels = |data: &[f64]| -> Result<VoxelGrid> {
        let max = grid.n.map(|m| m as f64 * grid.h);
        VoxelGrid::new(grid.n, [0.0; 3], max, data.to_vec())
    };
    let sigma_a = voxels(&problem.sigma_a)?;
    let source = voxels(&problem.source)?;
    let mut phi = match initial {
        Some(phi0) => op.with_boundary(phi0),
        None => op.initial_phi(),
    };
    let mut d = FaceCoefficients::zeros(grid);
    let mut history = Vec::new();
    let mut linear_iterations = Vec::new();
    let mut notes = Vec::new();
    let mut nonzeros = 0;
    let linear_opts = SolverOptions {
        tol: opts.linear_tol,
        max_iter: opts.max_linear_iter,
        tuning: opts.tuning.clone(),
        ..Default::default()
    };
    let solver = opts.solver.solver();
    let mut anderson = Anderson::new(opts.anderson_depth);
    let profile = opts.tuning.profile;
    let converged = loop {
        let t0 = std::time::Instant::now();
        op.face_coefficients(&phi, &mut d);
        let rel = op.residual_rms(&phi, &d) / op.rms_source;
        let t_nonlinear = t0.elapsed().as_secs_f64();
        history.push(rel);
        if rel < params.tol {
            break true;
        }
        if !rel.is_finite() || linear_iterations.len() >= opts.max_steps {
            break false;
        }
        let fields = CellFields {
            grid,
            diffusion: &d,
            sigma_a: &sigma_a,
            source: &source,
        };
        let t1 = std::time::Instant::now();
        let system = assemble_interior(&fields, kernel, &interior, op.phi_boundary)
            .context("assembling a Picard step")?;
        let t_assembly = t1.elapsed().as_secs_f64();
        let t2 = std::time::Instant::now();
        nonzeros = system.matrix.nnz();
        let x: Vec<f64> = interior.cells.iter().map(|&c| phi[c]).collect();
        let mut r = vec![0.0; x.len()];
        residual(&system.matrix, &x, &system.rhs, &mut r);
        let multigrid = geometry
            .as_ref()
            .and_then(|g| mg_krylov(&system.matrix, &r, g, &linear_opts).ok());
        let (delta, stats) =
            multigrid.unwrap_or_else(|| solver.solve(&system.matrix, &r, &linear_opts));
        linear_iterations.push(stats.iterations);
        if profile {
            notes.push(format!(
                "profile picard step {}: D and nonlinear residual {:.3} s, assembly {:.3} s, \
                 linear solve {:.3} s ({} iterations)",
                linear_iterations.len(),
                t_nonlinear,
                t_assembly,
                t2.elapsed().as_secs_f64(),
                stats.iterations
            ));
        }
        if stats.status == SolveStatus::Diverged || delta.iter().any(|v| !v.is_finite()) {
            bail!(
                "the {} solver diverged in Picard step {} (relative residual {:.3e})",
                stats.solver,
                linear_iterations.len(),
                stats.relative_residual
            );
        }
        let next = anderson.step(&x, &delta);
        for (&c, v) in interior.cells.iter().zip(&next) {
            phi[c] = *v;
        }
    };
    Ok(PicardSolution {
        fld: FldSolution {
            phi,
            iterations: linear_iterations.len(),
            residual_history: history,
            converged,
            rms_source: op.rms_source,
            phi_boundary: op.phi_boundary,
        },
        linear_iterations,
        solver: solver_name,
        unknowns: interior.len(),
        nonzeros,
        notes,
    })
}

/// Anderson acceleration (Walker & Ni 2011, "Anderson acceleration for fixed-point
/// iterations", type II) of the Picard map `G(x) = x + δ(x)`: with the last `depth` steps'
/// differences ΔF of the updates f = δ and ΔG of the images g = x + δ, the next iterate is
/// `g_k − ΔG γ` where γ minimises `‖f_k − ΔF γ‖₂`. A fixed point of the accelerated map is
/// a fixed point of G, so it changes how fast, not where, the iteration converges.
///
/// Safeguard: φ must stay positive for the Knudsen number (docs/fld.md); a combination with
/// a cell at or below zero where the plain step is positive is replaced by the plain step
/// and the history is cleared.
pub struct Anderson {
    depth: usize,
    /// (x, f) of the previous steps, oldest first.
    past: std::collections::VecDeque<(Vec<f64>, Vec<f64>)>,
}

impl Anderson {
    /// Acceleration over `depth` previous steps (0: none).
    pub fn new(depth: usize) -> Self {
        Self {
            depth,
            past: std::collections::VecDeque::new(),
        }
    }

    /// The next iterate from `x` and its Picard update `f = G(x) − x`.
    pub fn step(&mut self, x: &[f64], f: &[f64]) -> Vec<f64> {
        let plain: Vec<f64> = x.iter().zip(f).map(|(a, b)| a + b).collect();
        if self.depth == 0 {
            return plain;
        }
        let m = self.past.len();
        let mut next = plain.clone();
        if m > 0 {
            // Columns j: ΔF_j = f − f_j, ΔG_j = (x + f) − (x_j + f_j) against each past step
            // (an equivalent basis of the differences of consecutive steps).
            let df: Vec<Vec<f64>> = self
                .past
                .iter()
                .map(|(_, fj)| f.iter().zip(fj).map(|(a, b)| a - b).collect())
                .collect();
            // Normal equations (m ≤ depth, small), Tikhonov-regularised relative to their
            // diagonal so that nearly dependent columns do not blow γ up.
            let mut a = vec![vec![0.0; m]; m];
            let mut rhs = vec![0.0; m];
            for i in 0..m {
                for j in 0..=i {
                    let v: f64 = df[i].iter().zip(&df[j]).map(|(p, q)| p * q).sum();
                    a[i][j] = v;
                    a[j][i] = v;
                }
                rhs[i] = df[i].iter().zip(f).map(|(p, q)| p * q).sum();
            }
            let trace: f64 = (0..m).map(|i| a[i][i]).sum();
            for (i, row) in a.iter_mut().enumerate() {
                row[i] += 1e-10 * trace.max(f64::MIN_POSITIVE);
            }
            if let Some(gamma) = pn_krylov::linalg::solve_small_dense(a, rhs, f64::MIN_POSITIVE) {
                for (j, (xj, fj)) in self.past.iter().enumerate() {
                    let gj = gamma[j];
                    for (k, v) in next.iter_mut().enumerate() {
                        *v -= gj * ((x[k] + f[k]) - (xj[k] + fj[k]));
                    }
                }
            }
            let lost_positivity = next
                .iter()
                .zip(&plain)
                .any(|(n, p)| *n <= 0.0 && *p > 0.0 || !n.is_finite());
            if lost_positivity {
                self.past.clear();
                next = plain;
            }
        }
        self.past.push_back((x.to_vec(), f.to_vec()));
        if self.past.len() > self.depth {
            self.past.pop_front();
        }
        next
    }
}

/// The linear system of one Picard step: the stencil's rows at the interior cells, with the
/// Dirichlet boundary layer moved to the right-hand side.
pub struct InteriorSystem {
    /// Square sparse matrix (CSR), one row and column per interior cell in grid order.
    pub matrix: CsMat<f64>,
    /// Right-hand side.
    pub rhs: Vec<f64>,
}

/// Assembles `−∇·(D ∇φ) + σ_a φ = q` from `kernel` at the interior cells of `problem.grid`,
/// with the face coefficients `d` (e.g. from [`super::face_diffusion_coefficients`])
/// and the boundary layer fixed at `phi_boundary`. The unknowns are the interior cells in
/// grid index order (x slowest). For tests and inspection; [`solve_fld_picard`] uses it.
pub fn assemble_picard_system(
    problem: &FldProblem,
    kernel: &dyn StencilKernel,
    d: &FaceCoefficients,
    phi_boundary: f64,
) -> Result<InteriorSystem> {
    problem.validate()?;
    check_kernel(kernel)?;
    let grid = problem.grid;
    ensure!(
        d.grid == grid,
        "face diffusion coefficients are for grid {:?}, the problem has {:?}",
        d.grid,
        grid
    );
    d.validate()?;
    let voxels = |data: &[f64]| -> Result<VoxelGrid> {
        let max = grid.n.map(|m| m as f64 * grid.h);
        VoxelGrid::new(grid.n, [0.0; 3], max, data.to_vec())
    };
    let sigma_a = voxels(&problem.sigma_a)?;
    let source = voxels(&problem.source)?;
    let fields = CellFields {
        grid,
        diffusion: d,
        sigma_a: &sigma_a,
        source: &source,
    };
    assemble_interior(&fields, kernel, &InteriorIndex::new(grid), phi_boundary)
}

/// Checks that `kernel` is a 3D stencil with one cell-centred unknown whose terms land on
/// cell centres.
fn check_kernel(kernel: &dyn StencilKernel) -> Result<()> {
    ensure!(
        kernel.dim() == Dim::Three,
        "the Picard route needs a 3D stencil, {} is {:?}",
        kernel.name(),
        kernel.dim()
    );
    let moments = kernel.moments();
    ensure!(
        moments.len() == 1 && moments[0].shift == [0, 0, 0],
        "the Picard route needs a scalar cell-centred stencil (one moment L_0^0 at cell \
         centres), {} has {} moments",
        kernel.name(),
        moments.len()
    );
    for t in kernel.pattern(0) {
        ensure!(
            t.offset.iter().all(|o| o % 2 == 0),
            "stencil {} references offset {:?}, which is not a cell centre",
            kernel.name(),
            t.offset
        );
    }
    Ok(())
}

/// Interior cells of a grid and their unknown numbers.
struct InteriorIndex {
    grid: FldGrid,
    /// Grid index of each unknown (interior cells in grid order).
    cells: Vec<usize>,
}

impl InteriorIndex {
    fn new(grid: FldGrid) -> Self {
        let [nx, ny, nz] = grid.n;
        let mut cells = Vec::with_capacity((nx - 2) * (ny - 2) * (nz - 2));
        for i in 1..nx - 1 {
            for j in 1..ny - 1 {
                for k in 1..nz - 1 {
                    cells.push(grid.index(i, j, k));
                }
            }
        }
        Self { grid, cells }
    }

    fn len(&self) -> usize {
        self.cells.len()
    }

    /// The unknowns' positions for the multigrid preconditioner: one class (φ), the
    /// interior cell `(i, j, k)` at `(i − 1, j − 1, k − 1)`, in unknown order.
    fn geometry(&self) -> Geometry {
        let [nx, ny, nz] = self.grid.n;
        let mut coords = Vec::with_capacity(self.len());
        for i in 0..nx - 2 {
            for j in 0..ny - 2 {
                for k in 0..nz - 2 {
                    coords.push([i, j, k].map(|v| v as u32));
                }
            }
        }
        Geometry {
            class: vec![0; coords.len()],
            coords,
        }
    }

    /// Unknown number of interior cell `(i, j, k)`.
    fn unknown(&self, [i, j, k]: [usize; 3]) -> usize {
        let [_, ny, nz] = self.grid.n;
        ((i - 1) * (ny - 2) + (j - 1)) * (nz - 2) + (k - 1)
    }
}

/// The fields of one Picard step: D on the faces, σ_a and q cell-centred (sampled like voxel
/// data).
struct CellFields<'a> {
    grid: FldGrid,
    diffusion: &'a FaceCoefficients,
    sigma_a: &'a VoxelGrid,
    source: &'a VoxelGrid,
}

/// [`FieldContext`] of one row at cell `cell`: D at a face offset is that face's coefficient;
/// σ_a and q at a half-cell offset are the voxel fields at that world position.
struct CellContext<'a> {
    fields: &'a CellFields<'a>,
    cell: [usize; 3],
    inv_h: f64,
    unsupported: Cell<Option<FieldRefName>>,
}

/// The face at half-cell `offset` from a cell centre: `(axis, upper)` if the offset is ±1
/// along exactly one axis and 0 along the others.
fn face_of(offset: HalfOffset) -> Option<(usize, bool)> {
    let mut face = None;
    for (axis, &o) in offset.iter().enumerate() {
        match (o, face) {
            (0, _) => {}
            (1 | -1, None) => face = Some((axis, o == 1)),
            _ => return None,
        }
    }
    face
}

/// Name of a field the Picard route cannot provide (for the error message).
#[derive(Clone, Copy, Debug)]
struct FieldRefName(&'static str);

impl FieldContext for CellContext<'_> {
    fn field(&self, field: &FieldRef, offset: HalfOffset) -> f64 {
        let h = self.fields.grid.h;
        // Absolute half coordinate 2i+1 (+ offset), at world position half·h/2.
        let p =
            [0, 1, 2].map(|d| (2 * self.cell[d] as i64 + 1 + offset[d] as i64) as f64 * 0.5 * h);
        match field {
            FieldRef::Diffusion => match face_of(offset) {
                Some((axis, upper)) => self
                    .fields
                    .diffusion
                    .at(self.cell, axis, upper)
                    .unwrap_or_else(|| {
                        self.unsupported
                            .set(Some(FieldRefName("D beyond the domain")));
                        0.0
                    }),
                None => {
                    self.unsupported
                        .set(Some(FieldRefName("D away from a cell face")));
                    0.0
                }
            },
            FieldRef::SigmaA => self.fields.sigma_a.sample(p),
            FieldRef::Source { l: 0, m: 0 } => self.fields.source.sample(p),
            // An isotropic source has no higher moments.
            FieldRef::Source { .. } => 0.0,
            FieldRef::SigmaT => {
                self.unsupported.set(Some(FieldRefName("sigma_t")));
                0.0
            }
            FieldRef::SigmaS => {
                self.unsupported.set(Some(FieldRefName("sigma_s")));
                0.0
            }
            FieldRef::PhaseMoment(_) => {
                self.unsupported.set(Some(FieldRefName("phase moment")));
                0.0
            }
        }
    }

    fn inv_h(&self, _axis: usize) -> f64 {
        self.inv_h
    }
}

/// Rows of one x-plane of interior cells.
struct PlaneRows {
    row_nnz: Vec<usize>,
    cols: Vec<usize>,
    vals: Vec<f64>,
    rhs: Vec<f64>,
}

fn assemble_interior(
    fields: &CellFields<'_>,
    kernel: &dyn StencilKernel,
    interior: &InteriorIndex,
    phi_boundary: f64,
) -> Result<InteriorSystem> {
    let grid = fields.grid;
    let [nx, ny, nz] = grid.n;
    let pattern = kernel.pattern(0);
    let planes: Vec<PlaneRows> = (1..nx - 1)
        .into_par_iter()
        .map(|i| -> Result<PlaneRows> {
            let rows = (ny - 2) * (nz - 2);
            let mut out = PlaneRows {
                row_nnz: Vec::with_capacity(rows),
                cols: Vec::with_capacity(rows * pattern.len()),
                vals: Vec::with_capacity(rows * pattern.len()),
                rhs: Vec::with_capacity(rows),
            };
            let mut weights = vec![0.0; pattern.len()];
            let mut entries: Vec<(usize, f64)> = Vec::with_capacity(pattern.len());
            for j in 1..ny - 1 {
                for k in 1..nz - 1 {
                    let cell = [i, j, k];
                    let ctx = CellContext {
                        fields,
                        cell,
                        inv_h: 1.0 / grid.h,
                        unsupported: Cell::new(None),
                    };
                    let mut rhs = kernel.eval_row(0, &ctx, &mut weights);
                    if let Some(FieldRefName(name)) = ctx.unsupported.get() {
                        bail!(
                            "stencil {} requests the field {name}, which the Picard route does \
                             not provide (it supplies D, sigma_a and the source)",
                            kernel.name()
                        );
                    }
                    ensure!(
                        rhs.is_finite() && weights.iter().all(|w| w.is_finite()),
                        "non-finite stencil weight at cell {cell:?}"
                    );
                    entries.clear();
                    for (t, &w) in pattern.iter().zip(&weights) {
                        let nb = neighbour(grid, cell, t.offset).with_context(|| {
                            format!(
                                "stencil {} reaches offset {:?} from cell {cell:?}, beyond the \
                                 boundary layer",
                                kernel.name(),
                                t.offset
                            )
                        })?;
                        if grid.is_boundary(nb) {
                            rhs -= w * phi_boundary;
                        } else {
                            entries.push((interior.unknown(nb), w));
                        }
                    }
                    entries.sort_unstable_by_key(|e| e.0);
                    let start = out.cols.len();
                    let mut last: Option<usize> = None;
                    for &(col, w) in &entries {
                        match (last, out.vals.last_mut()) {
                            // A repeated column (sorted): merge into the previous entry.
                            (Some(l), Some(v)) if l == col => *v += w,
                            _ => {
                                out.cols.push(col);
                                out.vals.push(w);
                                last = Some(col);
                            }
                        }
                    }
                    out.row_nnz.push(out.cols.len() - start);
                    out.rhs.push(rhs);
                }
            }
            Ok(out)
        })
        .collect::<Result<_>>()?;
    let n = interior.len();
    let nnz: usize = planes.iter().map(|p| p.cols.len()).sum();
    let mut indptr = Vec::with_capacity(n + 1);
    let mut indices = Vec::with_capacity(nnz);
    let mut data = Vec::with_capacity(nnz);
    let mut rhs = Vec::with_capacity(n);
    let mut total = 0usize;
    indptr.push(total);
    for p in planes {
        for k in p.row_nnz {
            total += k;
            indptr.push(total);
        }
        indices.extend(p.cols);
        data.extend(p.vals);
        rhs.extend(p.rhs);
    }
    let matrix = CsMat::try_new((n, n), indptr, indices, data)
        .map_err(|e| anyhow::anyhow!("internal error building the Picard matrix: {}", e.3))?;
    Ok(InteriorSystem { matrix, rhs })
}

/// The cell at half-cell `offset` (even on every axis) from `cell`, if it is in the grid.
fn neighbour(grid: FldGrid, cell: [usize; 3], offset: HalfOffset) -> Option<[usize; 3]> {
    let mut out = [0usize; 3];
    for d in 0..3 {
        let v = cell[d] as i64 + (offset[d] / 2) as i64;
        if v < 0 || v >= grid.n[d] as i64 {
            return None;
        }
        out[d] = v as usize;
    }
    Some(out)
}
