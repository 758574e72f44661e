//! From a problem and a stencil kernel to a solution at cell centres:
//! layout → assembly → solve → un-stagger → energy balance.
//!
//! Three routes share the checks and the finish here: the assembled matrix (CSR `A`), the
//! parity blocks ([`assemble_split`]), and the matrix-free operator ([`matrix_free`], the
//! `-mf` solvers, on [`crate::matfree::MatFreeOperator`]).

pub mod matrix_free;

use crate::assemble::assemble;
use crate::assemble_split::{assemble_split, assemble_split_stencil, has_parity_structure};
use crate::energy::{energy_balance, EnergyBalance};
use crate::layout::Layout;
use crate::problem::Problem;
use crate::solver::pn_layout::LayoutSolver;
use crate::solver::{SolveStats, SolverKind, SolverOptions};
use crate::unstagger::{unstagger, CellMoments};
use pn_stencil::StencilKernel;
use std::time::Instant;

/// Everything a solve produced.
pub struct Solution {
    /// The unknown layout.
    pub layout: Layout,
    /// The staggered solution vector.
    pub u: Vec<f64>,
    /// All moments at cell centres.
    pub moments: CellMoments,
    /// Solver statistics.
    pub stats: SolveStats,
    /// Energy balance (None if the stencil has no centred L_0^0).
    pub energy: Option<EnergyBalance>,
    /// Unknowns.
    pub unknowns: usize,
    /// Stored non-zeros of A.
    pub nonzeros: usize,
    /// Seconds spent assembling.
    pub seconds_assembly: f64,
    /// Seconds spent in the solver.
    pub seconds_solve: f64,
}

impl Solution {
    /// L_0^0 at cell centres, x slowest (C order of `(nx, ny, nz)`).
    pub fn l00(&self) -> Vec<f64> {
        self.moments.component(0)
    }
}

/// Assembles and solves `problem` with `kernel`.
///
/// Fails on invalid input (coefficients, kernel/grid mismatch) and when the solver
/// diverged; a solve that stopped before the tolerance returns `Ok` with a non-converged
/// status in [`Solution::stats`].
pub fn solve_problem(
    problem: &Problem,
    kernel: &dyn StencilKernel,
    solver: SolverKind,
    opts: &SolverOptions,
) -> anyhow::Result<Solution> {
    solve_problem_from(problem, kernel, solver, opts, &[])
}

/// [`solve_problem`] with start guesses: staggered solution vectors ([`Solution::u`]) of
/// problems on the same grid and layout, for example the other colour channels of a medium
/// with one σ_t. The parity route starts from their residual-minimising combination
/// ([`crate::solver::parity::ParityCg::solve_split_from`]); the tolerance is the same, so
/// only the number of iterations changes. The other routes start from zero and ignore them.
/// A guess whose length differs from the layout's is an error.
pub fn solve_problem_from(
    problem: &Problem,
    kernel: &dyn StencilKernel,
    solver: SolverKind,
    opts: &SolverOptions,
    guesses: &[&[f64]],
) -> anyhow::Result<Solution> {
    if solver.is_matrix_free() {
        return matrix_free::solve_problem_matrix_free(problem, kernel, solver, opts);
    }
    problem.validate()?;
    problem.check_not_singular()?;
    let layout = Layout::new(&problem.grid, kernel.moments())?;
    if let Some(g) = guesses.iter().find(|g| g.len() != layout.len()) {
        anyhow::bail!(
            "a start guess has {} values but the layout has {} unknowns (guesses must come \
             from the same grid and stencil)",
            g.len(),
            layout.len()
        );
    }
    let split_route = match solver.parity_solver_for(&layout) {
        Some(parity) if has_parity_structure(kernel) => {
            solve_split_system(problem, kernel, &layout, &parity, opts, guesses)?
        }
        _ => None,
    };
    let solved = match split_route {
        Some(solved) => solved,
        None => solve_assembled(problem, kernel, &layout, solver, opts)?,
    };
    finish(problem, layout, solved)
}

/// What a route (assembled, parity blocks, matrix-free) produced, before un-staggering.
pub(crate) struct Solved {
    pub(crate) u: Vec<f64>,
    pub(crate) stats: SolveStats,
    pub(crate) energy: Option<EnergyBalance>,
    /// Stored entries of A (or of the operator's weight tables, matrix-free).
    pub(crate) nonzeros: usize,
    pub(crate) seconds_assembly: f64,
    pub(crate) seconds_solve: f64,
}

/// Assembles `A` and solves with `solver` (every solver; the parity solvers split `A`).
fn solve_assembled(
    problem: &Problem,
    kernel: &dyn StencilKernel,
    layout: &Layout,
    solver: SolverKind,
    opts: &SolverOptions,
) -> anyhow::Result<Solved> {
    let t0 = Instant::now();
    let system = assemble(problem, kernel, layout)?;
    let seconds_assembly = t0.elapsed().as_secs_f64();
    check_magnitudes(&system.matrix, &system.rhs)?;
    let t1 = Instant::now();
    let (u, stats) = solve_scaled(solver, layout, &system.matrix, &system.rhs, opts);
    let seconds_solve = t1.elapsed().as_secs_f64();
    let energy = energy_balance(problem, layout, Some(&system.matrix), &u);
    Ok(Solved {
        u,
        stats,
        energy,
        nonzeros: system.matrix.nnz(),
        seconds_assembly,
        seconds_solve,
    })
}

/// The parity solvers' route: assemble straight into the even/odd blocks
/// ([`assemble_split`]) so that `A` is never held next to them, and solve from the blocks.
/// `None` when the system turns out to lack the parity structure (σ_t = 0 somewhere);
/// the caller then assembles `A` and the solver falls back as usual.
fn solve_split_system(
    problem: &Problem,
    kernel: &dyn StencilKernel,
    layout: &Layout,
    parity: &LayoutSolver,
    opts: &SolverOptions,
    guesses: &[&[f64]],
) -> anyhow::Result<Option<Solved>> {
    let t0 = Instant::now();
    // Systems the multigrid solves (from MG_MIN_NONZEROS entries on) apply `S` from its
    // stencils: assemble straight into them, without storing B and C̃. Smaller systems
    // (ILU forms `S` from the blocks) and `PN_PARITY_BLOCKS` keep the blocks.
    let entries: usize = (0..layout.moments.len())
        .map(|q| (layout.offsets[q + 1] - layout.offsets[q]) * kernel.pattern(q).len())
        .sum();
    let stencil = !opts.tuning.block_operator && entries >= crate::solver::parity::MG_MIN_NONZEROS;
    let assembled = if stencil {
        assemble_split_stencil(problem, kernel, layout)?
    } else {
        assemble_split(problem, kernel, layout)?
    };
    let system = match assembled {
        Ok(s) => s,
        Err(_) => return Ok(None),
    };
    let seconds_assembly = t0.elapsed().as_secs_f64();
    let assembly_note = opts.tuning.profile.then(|| {
        format!(
            "profile assemble-split: rows {:.3} s (parallel), append {:.3} s",
            system.seconds_rows, system.seconds_append
        )
    });
    check_magnitude_values(system.max_entry, true, &system.rhs)?;
    let t1 = Instant::now();
    // The guesses' combination is fitted to the (possibly rescaled) rhs, so they need no
    // rescaling.
    let (u, mut stats) = solve_with_scaled_rhs(&system.rhs, |b| {
        parity.solve_split_from(&system.split, b, opts, guesses)
    });
    if let Some(note) = assembly_note {
        stats.notes.insert(0, note);
    }
    let seconds_solve = t1.elapsed().as_secs_f64();
    let nonzeros = system.split.nnz_a;
    drop(system);
    let energy = energy_balance(problem, layout, None, &u);
    Ok(Some(Solved {
        u,
        stats,
        energy,
        nonzeros,
        seconds_assembly,
        seconds_solve,
    }))
}

/// The [`Solution`] of a staggered vector `u` solved elsewhere (a domain-decomposed solve
/// gathered onto one process): the energy balance, un-staggering and the status check of
/// every other route. Fails when `u` does not fit the layout or the solver diverged.
pub fn solution_from_vector(
    problem: &Problem,
    layout: Layout,
    u: Vec<f64>,
    stats: SolveStats,
    nonzeros: usize,
    seconds: [f64; 2],
) -> anyhow::Result<Solution> {
    anyhow::ensure!(
        u.len() == layout.len(),
        "a solution of {} values for a layout of {} unknowns",
        u.len(),
        layout.len()
    );
    let energy = energy_balance(problem, &layout, None, &u);
    finish(
        problem,
        layout,
        Solved {
            u,
            stats,
            energy,
            nonzeros,
            seconds_assembly: seconds[0],
            seconds_solve: seconds[1],
        },
    )
}

/// Checks the solver's status, un-staggers and packs the [`Solution`].
pub(crate) fn finish(
    problem: &Problem,
    layout: Layout,
    solved: Solved,
) -> anyhow::Result<Solution> {
    let Solved {
        u,
        stats,
        energy,
        nonzeros,
        seconds_assembly,
        seconds_solve,
    } = solved;
    if stats.status == crate::solver::SolveStatus::Diverged {
        anyhow::bail!(
            "the {} solver diverged after {} iterations (relative residual {:.3e})",
            stats.solver,
            stats.iterations,
            stats.relative_residual
        );
    }
    let moments = unstagger(&problem.grid, &layout, &u);
    Ok(Solution {
        unknowns: layout.len(),
        nonzeros,
        layout,
        u,
        moments,
        stats,
        energy,
        seconds_assembly,
        seconds_solve,
    })
}

/// Largest matrix or right-hand-side magnitude the solvers accept: CGNR works with squared
/// norms (‖A p‖², AᵀA's condition number), which overflow f64 (≈ 1.8e308) for entries near
/// 1e154 already; 1e150 leaves room for sums over the rows.
pub const MAX_ENTRY_MAGNITUDE: f64 = 1e150;

/// Refuses a system with non-finite entries or entries too large for the solvers, naming
/// the value (e.g. σ_t = 1e300, or a source of 1e200), instead of a NaN residual later.
fn check_magnitudes(a: &sprs::CsMat<f64>, b: &[f64]) -> anyhow::Result<()> {
    let max_a = a.data().iter().fold(0.0f64, |m, v| m.max(v.abs()));
    let finite = a.data().iter().all(|v| v.is_finite());
    check_magnitude_values(max_a, finite, b)
}

/// [`check_magnitudes`] given the matrix's largest magnitude and finiteness (for the
/// parity blocks and the matrix-free operator, which hold no CSR `A`).
pub(crate) fn check_magnitude_values(max_a: f64, finite_a: bool, b: &[f64]) -> anyhow::Result<()> {
    use rayon::prelude::*;
    let max_b = b.par_iter().map(|v| v.abs()).reduce(|| 0.0f64, f64::max);
    let finite = finite_a && max_a.is_finite() && b.par_iter().all(|v| v.is_finite());
    anyhow::ensure!(
        finite && max_a <= MAX_ENTRY_MAGNITUDE && max_b <= MAX_ENTRY_MAGNITUDE,
        "the system has entries up to {max_a:.3e} (matrix) and {max_b:.3e} \
         (right-hand side){}; the solvers need magnitudes below {MAX_ENTRY_MAGNITUDE:.0e} \
         (their squares must fit in f64): rescale σ_t, the sources or the domain",
        if finite { "" } else { ", some not finite" }
    );
    Ok(())
}

/// Solves `a u = b`, first scaling `b` by a power of two when its largest entry is outside
/// [1e-100, 1e100]: the solvers work with ‖b‖², which underflows to 0 for a source of
/// 1e-300 (the solver would then return u = 0 as "converged") or overflows for 1e200.
/// Power-of-two scaling is exact, the relative residual is unchanged, and the absolute
/// residual and ‖b‖ are scaled back.
fn solve_scaled(
    solver: SolverKind,
    layout: &Layout,
    a: &sprs::CsMat<f64>,
    b: &[f64],
    opts: &SolverOptions,
) -> (Vec<f64>, SolveStats) {
    let solver = solver.solver_for(layout);
    solve_with_scaled_rhs(b, |b| solver.solve(a, b, opts))
}

/// Solves `solve(b')` with `b' = b / 2^k` when `b`'s largest entry is outside
/// [1e-100, 1e100] and scales the solution and the absolute residuals back: the solvers
/// work with ‖b‖², which underflows for a source of 1e-300 (u = 0 would be "converged") or
/// overflows for 1e200. Power-of-two scaling is exact and leaves the relative residual as is.
pub fn solve_with_scaled_rhs(
    b: &[f64],
    solve: impl FnOnce(&[f64]) -> (Vec<f64>, SolveStats),
) -> (Vec<f64>, SolveStats) {
    let max_b = b.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    if max_b == 0.0 || (1e-100..=1e100).contains(&max_b) {
        return solve(b);
    }
    let scale = 2f64.powi(max_b.log2().round() as i32);
    let scaled: Vec<f64> = b.iter().map(|v| v / scale).collect();
    let (mut u, mut stats) = solve(&scaled);
    u.iter_mut().for_each(|v| *v *= scale);
    stats.absolute_residual *= scale;
    stats.rhs_norm *= scale;
    (u, stats)
}
