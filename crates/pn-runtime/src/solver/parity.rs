//! `parity-cg`: eliminate the odd-l moments and solve the even-parity system (docs/design.md §5).
//!
//! Ordering the unknowns into even-l (e) and odd-l (o) moments, the staggered P_N matrix is
//! `A = [[D_e, B], [C, D_o]]`: transport couples only even↔odd and collision/scattering is
//! diagonal. Eliminating `u_o = D_o⁻¹ (b_o − C u_e)` leaves `S u_e = b_e − B D_o⁻¹ b_o` with
//! `S = D_e − B D_o⁻¹ C`. In the interior the staggered transport is skew-adjoint
//! (`C = −Bᵀ`), so `S = D_e + B D_o⁻¹ Bᵀ` is symmetric positive (semi)definite, a
//! diffusion-like operator (for P_1 exactly CDA). The extrapolation (Neumann) closure
//! cancels some boundary differences in one of the two blocks only, so `S` can be slightly
//! nonsymmetric; this is measured with random probes and decides between preconditioned CG
//! and BiCGSTAB (see [`ParityReport::method`]; restarted GMRES is available through
//! [`ParityCg::with_method`] — on the 71² checkerboard it needs about as many applications
//! of `S` as BiCGSTAB but more time, because of the orthogonalisation).
//!
//! * [`coloring`]: finds the classes from the matrix when no mask is given.
//! * [`split`]: checks the block structure and extracts `D_e`, `D_o`, `B`, `D_o⁻¹C`.
//! * [`reduced`]: applies `S` (matrix-free or formed), the reduced rhs, back-substitution.
//! * [`precond`]: Jacobi, block-Jacobi (per cell) and ILU(0) preconditioners.
//! * [`galerkin`]: the first multigrid coarse operator `PᵀSP` from the blocks.
//! * The Krylov methods are [`pn_krylov::cg`], [`pn_krylov::bicgstab`] and
//!   [`pn_krylov::gmres`], with the stopping rules of [`SolverOptions`]
//!   ([`pn_krylov::control::Control`]).
//! * [`crate::solver::multigrid`]: the aggregation multigrid preconditioner
//!   ([`Precond::Multigrid`]); it needs the unknowns' positions ([`ParityCg::with_geometry`],
//!   from the layout in [`crate::solver::pn_layout`]), and `Precond::Auto` picks it from
//!   [`MG_MIN_NONZEROS`] stored entries on. With multigrid a nonsymmetric `S` is solved
//!   with GMRES (one cycle per iteration) instead of BiCGSTAB.
//!
//! For experiments, [`SolverOptions::tuning`] prints the time of each phase (split, setup,
//! probes, iterations), forces the Krylov method and sets the multigrid parameters.
//!
//! **Tolerance.** With the exact back-substitution, the odd rows of `b − A u` vanish and the
//! even rows equal the reduced residual, so the reduced iteration stops on
//! `‖f − S u_e‖₂ ≤ tol·‖b‖₂`; the full residual is then recomputed on the recovered vector
//! and, if rounding left it above `tol`, the iteration continues from there with a tighter
//! reduced target.
//!
//! **Work.** One matrix-free application of `S` touches each off-diagonal entry of `A` once
//! (`B` and `C` are disjoint parts of `A`), so it is counted as one application of `A`
//! ([`ParityReport::a_equivalent_applications`]); CGNR needs two (A and Aᵀ) per iteration.
//! A formed `S` is counted the same way (its nnz is 0.9–1.3 nnz(A) on the checkerboard
//! P_3–P_5). Preconditioner applications are not counted: Jacobi and block-Jacobi cost a
//! fraction of an `S` application, ILU(0) about one (compare seconds for those).

pub mod block_mat;
pub mod coloring;
pub mod fallback;
pub mod galerkin;
pub mod precond;
pub mod reduced;
pub mod split;
pub mod stencil_s;

pub use pn_krylov::krylov::{KrylovMethod, SYMMETRY_TOL};
pub use precond::Precond;
pub use reduced::ReducedMode;
pub use split::ParityError;

use super::{LinearSolver, SolveStats, SolveStatus, SolverOptions};
use crate::solver::multigrid::{Geometry, COARSE_SYMMETRY_TOL};
use pn_krylov::control::{Control, Outcome};
use pn_krylov::linalg::{dot, norm};
use pn_krylov::operator::Counted;
use pn_krylov::operator::LinearOperator;
use sprs::CsMat;
use std::borrow::Cow;
use std::sync::Arc;
use std::time::Instant;

/// Random probe pairs for the symmetry check (each costs two applications of `S`).
const PROBE_PAIRS: usize = 2;

/// The parity-eliminating solver.
#[derive(Clone, Debug)]
pub struct ParityCg {
    /// The unknowns kept in the reduced system ("even"; for even N the odd-l moments,
    /// [`crate::solver::pn_layout::Retained`]). `None`: detect the classes from the
    /// matrix ([`coloring::detect_mask`]).
    even: Option<Vec<bool>>,
    /// A second mask to split with when `even` cannot split the matrix (the even-l
    /// moments, where keeping the odd ones meets a zero absorption).
    fallback_even: Option<Vec<bool>>,
    precond: Precond,
    mode: ReducedMode,
    method: Option<KrylovMethod>,
    /// Class and position of every unknown (from the layout), for multigrid.
    geometry: Option<GeometrySource>,
}

/// Where a [`ParityCg`] gets the unknowns' classes and positions.
#[derive(Clone)]
enum GeometrySource {
    /// Given once ([`ParityCg::with_geometry`]).
    Given(Geometry),
    /// Built when a solve's setup needs it and dropped after the setup
    /// ([`ParityCg::with_geometry_from`]): 16 bytes per unknown that the iterations never
    /// read (300 MB for the 18.7 M unknowns of the 80³ P_5 point source).
    Lazy(Arc<dyn Fn() -> Geometry + Send + Sync>),
}

impl GeometrySource {
    fn get(&self) -> Cow<'_, Geometry> {
        match self {
            GeometrySource::Given(g) => Cow::Borrowed(g),
            GeometrySource::Lazy(f) => Cow::Owned(f()),
        }
    }
}

impl std::fmt::Debug for GeometrySource {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            GeometrySource::Given(g) => write!(f, "Given({} unknowns)", g.len()),
            GeometrySource::Lazy(_) => write!(f, "Lazy"),
        }
    }
}

/// Everything a parity solve did, beyond [`SolveStats`].
#[derive(Clone, Debug)]
pub struct ParityReport {
    /// The usual statistics (relative residual of the full system, history, status).
    pub stats: SolveStats,
    /// Krylov method used on the reduced system.
    pub method: KrylovMethod,
    /// Preconditioner name.
    pub precond: &'static str,
    /// Measured relative asymmetry of `S` (random probes, see
    /// [`reduced::ReducedOperator::asymmetry`]); with multigrid, when its first Galerkin
    /// operator is already asymmetric, that operator's asymmetry
    /// ([`crate::solver::multigrid::Multigrid::first_coarse_asymmetry`]) and no probes.
    pub asymmetry: f64,
    /// Whether `S` was formed as CSR.
    pub formed: bool,
    /// Unknowns kept in the reduced system (the even-l ones, or the odd-l ones for even N:
    /// [`crate::solver::pn_layout::Retained`]).
    pub even_unknowns: usize,
    /// Unknowns eliminated.
    pub odd_unknowns: usize,
    /// Applications of `S` (Krylov iterations, restarts, the symmetry probe, and for
    /// multigrid the finest-level smoothing and residuals and the setup's `λ_max` estimate).
    pub reduced_applications: usize,
    /// Applications of the full `A` (residual checks on the recovered vector).
    pub full_applications: usize,
    /// Seconds spent splitting, forming and building the preconditioner.
    pub seconds_setup: f64,
    /// Seconds spent iterating (including the final residual checks).
    pub seconds_iterate: f64,
    /// Whether the iteration started from a combination of given guesses
    /// ([`ParityCg::solve_split_from`]) rather than from zero.
    pub warm_start: bool,
}

impl ParityReport {
    /// Work in units of one product with `A`: each matrix-free `S` application touches the
    /// off-diagonal entries of `A` once; the rhs and the back-substitution add half an `A`
    /// each (one of `B`, `C`), counted as one in total.
    pub fn a_equivalent_applications(&self) -> usize {
        self.reduced_applications + self.full_applications + 1
    }
}

impl ParityCg {
    /// A parity solver for matrices whose unknown `g` is kept in the reduced system iff
    /// `even[g]` (the even-l moments: [`crate::solver::pn_layout::even_mask`]; the parity
    /// a layout is best solved in: [`crate::solver::pn_layout::retained_mask`]), with the
    /// preconditioner `precond`.
    pub fn new(even: Vec<bool>, precond: Precond) -> Self {
        Self {
            even: Some(even),
            fallback_even: None,
            precond,
            mode: ReducedMode::Auto,
            method: None,
            geometry: None,
        }
    }

    /// A parity solver that finds the even/odd classes from the matrix itself (a bipartite
    /// 2-colouring of its couplings, [`coloring::detect_mask`]); this is what
    /// [`super::SolverKind::ParityCg`] builds, since it sees only the matrix.
    pub fn auto(precond: Precond) -> Self {
        Self {
            even: None,
            fallback_even: None,
            precond,
            mode: ReducedMode::Auto,
            method: None,
            geometry: None,
        }
    }

    /// Records the class and grid position of every unknown (needed by
    /// [`Precond::Multigrid`]; with them [`Precond::Auto`] resolves to multigrid for
    /// systems with at least [`MG_MIN_NONZEROS`] stored entries). From a layout:
    /// `ParityCg::with_layout_geometry` ([`crate::solver::pn_layout`]).
    pub fn with_geometry(mut self, geometry: Geometry) -> Self {
        self.geometry = Some(GeometrySource::Given(geometry));
        self
    }

    /// [`ParityCg::with_geometry`] with the geometry built by `make` when a solve's setup
    /// needs it, and dropped before the iterations.
    pub fn with_geometry_from(
        mut self,
        make: impl Fn() -> Geometry + Send + Sync + 'static,
    ) -> Self {
        self.geometry = Some(GeometrySource::Lazy(Arc::new(make)));
        self
    }

    /// A mask to split with when the first one fails (see [`ParityCg::for_layout`]).
    pub fn with_fallback_mask(mut self, fallback: Option<Vec<bool>>) -> Self {
        self.fallback_even = fallback;
        self
    }

    /// Replaces the preconditioner.
    pub fn with_precond(mut self, precond: Precond) -> Self {
        self.precond = precond;
        self
    }

    /// The preconditioner `Auto` stands for on a matrix with `nnz_a` stored entries.
    fn resolve_precond(&self, nnz_a: usize) -> Precond {
        match &self.precond {
            Precond::Auto if self.geometry.is_some() && nnz_a >= MG_MIN_NONZEROS => {
                Precond::Multigrid
            }
            p => p.resolve(nnz_a),
        }
    }

    /// Applies `S` matrix-free or from a formed CSR matrix (default `Auto`: formed when the
    /// preconditioner forms it anyway — fastest on the 71² checkerboard — else matrix-free).
    pub fn with_mode(mut self, mode: ReducedMode) -> Self {
        self.mode = mode;
        self
    }

    /// Forces a Krylov method instead of choosing by the measured symmetry of `S`.
    pub fn with_method(mut self, method: Option<KrylovMethod>) -> Self {
        self.method = method;
        self
    }

    /// Checks that `a` has the parity block structure this solver needs.
    pub fn check(&self, a: &CsMat<f64>) -> Result<(), ParityError> {
        self.split_matrix(a).map(|_| ())
    }

    /// Splits `a` with the mask, or with the fallback mask when the first fails.
    fn split_matrix(&self, a: &CsMat<f64>) -> Result<split::Split, ParityError> {
        match (split::split(a, &self.mask(a)?), &self.fallback_even) {
            (Err(_), Some(fallback)) => split::split(a, fallback),
            (r, _) => r,
        }
    }

    /// The given mask, or the detected one.
    fn mask<'s>(&'s self, a: &CsMat<f64>) -> Result<std::borrow::Cow<'s, [bool]>, ParityError> {
        match &self.even {
            Some(m) => Ok(std::borrow::Cow::Borrowed(m)),
            None => coloring::detect_mask(a).map(std::borrow::Cow::Owned),
        }
    }

    /// Solves `a u = b`, or explains why the parity elimination does not apply.
    pub fn solve_detailed(
        &self,
        a: &CsMat<f64>,
        b: &[f64],
        opts: &SolverOptions,
    ) -> Result<(Vec<f64>, ParityReport), ParityError> {
        let t0 = Instant::now();
        let sp = self.split_matrix(a)?;
        let t_split = t0.elapsed().as_secs_f64();
        self.solve_split_timed(&sp, b, opts, t_split, &[])
    }

    /// Solves the system given by its parity blocks (for example straight from
    /// [`crate::assemble_split::assemble_split`], so that `A` is never held): the same
    /// iteration as [`ParityCg::solve_detailed`], with the final residual computed from
    /// the blocks ([`split::Split::residual_norm`]). Fails only when the preconditioner
    /// cannot be built.
    pub fn solve_split(
        &self,
        sp: &split::Split,
        b: &[f64],
        opts: &SolverOptions,
    ) -> Result<(Vec<f64>, ParityReport), ParityError> {
        self.solve_split_timed(sp, b, opts, 0.0, &[])
    }

    /// [`ParityCg::solve_split`] started from the best combination of `guesses` (full
    /// vectors in the unknown order of `b`, e.g. the solutions of neighbouring colour
    /// channels of the same σ_t): the iteration starts at `x₀ = Σ c_k g_k,e` with the
    /// coefficients that minimise the reduced residual `‖f − S x₀‖₂` ([`start_from`]).
    /// The stopping rule is unchanged (`‖b − A u‖ ≤ tol·‖b‖`), so the answer meets the same
    /// tolerance; a good guess only saves iterations. Guesses of the wrong length are an
    /// error; guesses that do not lower the residual below ‖f‖ are not used.
    pub fn solve_split_from(
        &self,
        sp: &split::Split,
        b: &[f64],
        opts: &SolverOptions,
        guesses: &[&[f64]],
    ) -> Result<(Vec<f64>, ParityReport), ParityError> {
        self.solve_split_timed(sp, b, opts, 0.0, guesses)
    }

    fn solve_split_timed(
        &self,
        sp: &split::Split,
        b: &[f64],
        opts: &SolverOptions,
        t_split: f64,
        guesses: &[&[f64]],
    ) -> Result<(Vec<f64>, ParityReport), ParityError> {
        if let Some(g) = guesses.iter().find(|g| g.len() != b.len()) {
            return Err(ParityError::GuessLength {
                expected: b.len(),
                got: g.len(),
            });
        }
        let t0 = Instant::now();
        let mut notes = Vec::new();
        let SplitSetup {
            op,
            pre,
            precond_used,
            method,
            asymmetry,
            probes,
            seconds,
        } = self.setup_split(sp, opts, t_split, t0, &mut notes)?;
        let tuning = &opts.tuning;
        let seconds_setup = seconds.setup;

        let t1 = Instant::now();
        let bnorm = norm(b);
        let (b_e, b_o) = sp.gather(b);
        let f = op.rhs(&b_e, &b_o);
        // Every application of S, by the Krylov method and inside the multigrid cycle.
        let s_apps = Counted::new(&op);
        let even_guesses: Vec<Vec<f64>> = guesses.iter().map(|g| sp.gather(g).0).collect();
        let (mut x, guess_used) = if bnorm > 0.0 {
            start_from(&s_apps, &f, &even_guesses)
        } else {
            (vec![0.0; op.len()], false)
        };
        let scale = if bnorm > 0.0 { bnorm } else { 1.0 };
        let mut ctl = Control::for_options(&opts.stopping(), bnorm);
        let prec = pre.with_fine(&s_apps);
        let mut full_applications = 0usize;
        let (u, status, rel, abs) = loop {
            let outcome = if bnorm == 0.0 {
                Outcome::Reached
            } else {
                method.run(&s_apps, &prec, &f, &mut x, &mut ctl)
            };
            let u_o = op.recover_odd(&x, &b_o);
            let abs = sp.residual_norm(&x, &u_o, &b_e, &b_o);
            full_applications += 1;
            let u = sp.merge(&x, &u_o);
            let rel = abs / scale;
            let status = match outcome {
                _ if rel <= opts.tol => SolveStatus::Converged,
                Outcome::Diverged => SolveStatus::Diverged,
                Outcome::MaxIterations => SolveStatus::MaxIterations,
                Outcome::Reached | Outcome::Stagnated
                    if ctl.iterations < opts.max_iter && ctl.may_restart() =>
                {
                    // Rounding drift (or a BiCGSTAB breakdown): continue from the true
                    // residual with a reduced target tightened by the observed gap.
                    if outcome == Outcome::Reached {
                        ctl.target *= 0.5 * opts.tol / rel;
                    }
                    continue;
                }
                Outcome::Reached | Outcome::Stagnated => SolveStatus::Stagnated,
            };
            break (u, status, rel, abs);
        };
        ctl.finish();
        if tuning.profile {
            let it = t1.elapsed().as_secs_f64();
            if let precond::Built::Multigrid(mg) = &pre {
                notes.push(format!("profile mg: {}", mg.describe()));
            }
            let profile = ProfileParity {
                op: &op,
                precond: precond_used.name(),
                method,
                asymmetry,
                seconds,
                iterate: it,
                iterations: ctl.iterations,
                s_applications: s_apps.count() + pre.single_applications(),
            };
            notes.push(profile.note());
        }
        let stats = SolveStats {
            solver: if precond_used == Precond::Multigrid {
                "parity-mg"
            } else {
                "parity-cg"
            }
            .into(),
            status,
            iterations: ctl.iterations,
            relative_residual: rel,
            absolute_residual: abs,
            rhs_norm: bnorm,
            tolerance: opts.tol,
            history: ctl.history,
            operator_applications: 0,
            notes,
        };
        let mut report = ParityReport {
            stats,
            method,
            precond: precond_used.name(),
            asymmetry,
            formed: op.is_formed(),
            even_unknowns: sp.even.len(),
            odd_unknowns: sp.odd.len(),
            reduced_applications: s_apps.count()
                + 2 * probes
                + pre.setup_applications()
                + pre.single_applications(),
            full_applications,
            seconds_setup,
            seconds_iterate: t1.elapsed().as_secs_f64(),
            warm_start: guess_used,
        };
        report.stats.operator_applications = report.a_equivalent_applications();
        Ok((u, report))
    }

    /// The setup of [`ParityCg::solve_split_timed`] (started at `t0`, after `t_split`
    /// seconds of splitting): the reduced operator, the preconditioner (with the multigrid
    /// setup's profile note in `notes` when [`SolverOptions::tuning`] asks for it), the
    /// symmetry measurement and the Krylov method it decides.
    fn setup_split<'s>(
        &self,
        sp: &'s split::Split,
        opts: &SolverOptions,
        t_split: f64,
        t0: Instant,
        notes: &mut Vec<String>,
    ) -> Result<SplitSetup<'s>, ParityError> {
        let nnz_a = sp.nnz_a;
        let mut precond_used = self.resolve_precond(nnz_a);
        let mode = match self.mode {
            ReducedMode::Auto if precond_used.forms_s(nnz_a) => ReducedMode::Formed,
            ReducedMode::Auto => ReducedMode::MatrixFree,
            m => m,
        };
        let tuning = &opts.tuning;
        // Only the setup reads the geometry (dropped below, before the iterations).
        let geometry = self.geometry.as_ref().map(GeometrySource::get);
        let op = match &geometry {
            Some(g) if !tuning.block_operator => {
                reduced::ReducedOperator::new(sp, mode).with_stencil(g)
            }
            _ => reduced::ReducedOperator::new(sp, mode),
        };
        let t_form = t_split + t0.elapsed().as_secs_f64();
        let built = match (&precond_used, &geometry) {
            (Precond::Multigrid, Some(g)) => {
                let mut mg_opts = tuning.multigrid_options();
                mg_opts.single_fine = Some(
                    mg_opts
                        .single_fine
                        .unwrap_or(opts.tol >= crate::solver::multigrid::SINGLE_FINE_MIN_TOL),
                );
                precond::Built::multigrid_with(sp, g, &mg_opts, &op)
            }
            _ => precond::Built::new(&precond_used, sp, op.formed()),
        };
        drop(geometry);
        let pre = match built {
            Ok(p) => p,
            // `Auto` falls back to Jacobi when ILU(0) meets a zero pivot.
            Err(_) if self.precond == Precond::Auto => {
                precond_used = Precond::Jacobi;
                precond::Built::new(&precond_used, sp, None)?
            }
            Err(e) => return Err(e),
        };
        let t_pre = t_split + t0.elapsed().as_secs_f64();
        if let (true, precond::Built::Multigrid(mg)) = (tuning.profile, &pre) {
            notes.push(format!("profile mg setup: {}", mg.describe_setup()));
        }
        // With multigrid, an asymmetric first Galerkin operator PᵀSP proves S asymmetric
        // (PᵀSP is symmetric whenever S is), so the random probes, 2·PROBE_PAIRS
        // applications of S, are skipped and its asymmetry is reported instead.
        let coarse_asymmetry = match &pre {
            precond::Built::Multigrid(mg) if mg.first_coarse_asymmetry() > COARSE_SYMMETRY_TOL => {
                Some(mg.first_coarse_asymmetry())
            }
            _ => None,
        };
        let probes = if op.is_empty() || coarse_asymmetry.is_some() {
            0
        } else {
            PROBE_PAIRS
        };
        let asymmetry = coarse_asymmetry.unwrap_or_else(|| op.asymmetry(probes));
        // Nonsymmetric S: BiCGSTAB (two preconditioner applications per iteration) is
        // cheapest for the light preconditioners; with multigrid, whose cycle costs several
        // S applications, GMRES needs one per iteration and as many iterations (80³ P_3).
        let method = self
            .method
            .or(tuning.krylov)
            .unwrap_or(if asymmetry <= SYMMETRY_TOL {
                KrylovMethod::Cg
            } else if matches!(pre, precond::Built::Multigrid(_)) {
                KrylovMethod::Gmres
            } else {
                KrylovMethod::BiCgStab
            });
        let seconds = SetupSeconds {
            split: t_split,
            form: t_form,
            precond: t_pre,
            setup: t_split + t0.elapsed().as_secs_f64(),
        };
        Ok(SplitSetup {
            op,
            pre,
            precond_used,
            method,
            asymmetry,
            probes,
            seconds,
        })
    }
}

/// What [`ParityCg::solve_split_timed`] iterates with ([`ParityCg::setup_split`]).
struct SplitSetup<'s> {
    /// The reduced operator `S`.
    op: reduced::ReducedOperator<'s>,
    pre: precond::Built,
    /// The preconditioner built (Jacobi where `Auto`'s ILU(0) met a zero pivot).
    precond_used: Precond,
    method: KrylovMethod,
    /// The measured asymmetry of `S`, and the probe pairs that measured it (0 when the
    /// multigrid's first coarse operator did).
    asymmetry: f64,
    probes: usize,
    seconds: SetupSeconds,
}

/// Seconds from the start of a split solve (the split included) to the end of each setup
/// phase: the split, the reduced operator, the preconditioner, the whole setup (probes and
/// method choice).
#[derive(Clone, Copy)]
struct SetupSeconds {
    split: f64,
    form: f64,
    precond: f64,
    setup: f64,
}

/// What the parity solve's profile note reports ([`SolverOptions::tuning`]).
struct ProfileParity<'a> {
    op: &'a reduced::ReducedOperator<'a>,
    precond: &'static str,
    method: KrylovMethod,
    asymmetry: f64,
    seconds: SetupSeconds,
    /// Seconds iterating, iterations, and applications of `S` in them (the single-precision
    /// finest level's included).
    iterate: f64,
    iterations: usize,
    s_applications: usize,
}

impl ProfileParity<'_> {
    /// The note: the time of each phase, the iterations and the method.
    fn note(&self) -> String {
        let (it, asymmetry, t) = (self.iterate, self.asymmetry, self.seconds);
        let t_split = t.split;
        format!(
            "profile parity: split {t_split:.3} s, form S {:.3} s (nnz {:?}, stencil {}), precond {} {:.3} s, \
             probes {:.3} s, iterate {it:.3} s ({} it, {} S-apps, {:.4} s/it), asymmetry {asymmetry:.2e}, {}",
            t.form - t_split,
            self.op.formed_nnz(),
            self.op.is_stencil(),
            self.precond,
            t.precond - t.form,
            t.setup - t.precond,
            self.iterations,
            self.s_applications,
            it / self.iterations.max(1) as f64,
            self.method.name(),
        )
    }
}

/// The start of a warm-started iteration on `S x = f`: `x₀ = Σ_k c_k g_k` with the `c` that
/// minimises `‖f − S x₀‖₂`, from the normal equations `Σ_j (w_i·w_j) c_j = w_i·f` with
/// `w_k = S g_k` (k ≤ a few; one application of `S` each). Returns zero and `false` when
/// there are no guesses, the Gram matrix is singular, or the combination does not bring
/// the residual below `‖f‖` (the residual of the zero start).
fn start_from(s: &dyn LinearOperator, f: &[f64], guesses: &[Vec<f64>]) -> (Vec<f64>, bool) {
    let n = f.len();
    let zero = || (vec![0.0; n], false);
    if guesses.is_empty() {
        return zero();
    }
    let w: Vec<Vec<f64>> = guesses
        .iter()
        .map(|g| {
            let mut y = vec![0.0; n];
            s.apply(g, &mut y);
            y
        })
        .collect();
    let k = w.len();
    let gram: Vec<Vec<f64>> = (0..k)
        .map(|i| (0..k).map(|j| dot(&w[i], &w[j])).collect())
        .collect();
    let wf: Vec<f64> = w.iter().map(|wi| dot(wi, f)).collect();
    // Numerically singular: a pivot below 1e-14 of the largest diagonal entry.
    let scale = (0..k).fold(0.0f64, |m, i| m.max(gram[i][i].abs()));
    if !(scale.is_finite() && scale > 0.0) {
        return zero();
    }
    let Some(c) = pn_krylov::linalg::solve_small_dense(gram, wf, 1e-14 * scale) else {
        return zero();
    };
    let mut x = vec![0.0; n];
    for (ck, g) in c.iter().zip(guesses) {
        x.iter_mut().zip(g).for_each(|(xi, gi)| *xi += ck * gi);
    }
    // ‖f − S x₀‖² = ‖f‖² − cᵀ(w·f) at the minimiser; recompute it plainly instead.
    let mut r = vec![0.0; n];
    s.apply(&x, &mut r);
    r.iter_mut().zip(f).for_each(|(ri, fi)| *ri = fi - *ri);
    if norm(&r).is_finite() && norm(&r) < norm(f) {
        (x, true)
    } else {
        zero()
    }
}

impl LinearSolver for ParityCg {
    fn name(&self) -> &'static str {
        "parity-cg"
    }

    /// Solves with parity elimination; when the matrix lacks the parity structure (a user
    /// PDE, a collocated stencil), prints why and falls back to ILU(0)-GMRES, then CGNR
    /// ([`fallback::fallback`]). Call
    /// [`ParityCg::check`] first to turn that case into an error instead.
    fn solve(&self, a: &CsMat<f64>, b: &[f64], opts: &SolverOptions) -> (Vec<f64>, SolveStats) {
        match self.solve_detailed(a, b, opts) {
            Ok((u, report)) => (u, report.stats),
            Err(e) => fallback::fallback(a, b, opts, &e.to_string()),
        }
    }
}

/// With a layout, `Precond::Auto` uses multigrid when `A` has at least this many stored
/// entries, else ILU(0) (Jacobi beyond [`ILU_MAX_NONZEROS`]). Measured on the 71²
/// checkerboard to 1e-10 (2 shared cores, load 3–5, 3 runs each): P_1 (0.1M entries)
/// ILU(0) 0.014 s vs multigrid 0.028 s; P_3 (0.5M) both 0.20 s; P_5 (1.1M) ILU(0)
/// 1.26–1.71 s vs multigrid 0.90–1.06 s. On the 80³ point source multigrid needs 12–19
/// iterations where ILU(0)/Jacobi need 53–342 (P_1–P_5).
pub const MG_MIN_NONZEROS: usize = 1_000_000;

/// `Precond::Auto` uses ILU(0) when `A` has at most this many stored entries. Its factors
/// (and the formed `S` they reuse) hold about 1–1.5 nnz(A) entries (measured on the 2D
/// checkerboard P_3/P_5), i.e. up to ~0.5 GB each here; beyond, Jacobi (no fill, parallel).
pub const ILU_MAX_NONZEROS: usize = 30_000_000;
