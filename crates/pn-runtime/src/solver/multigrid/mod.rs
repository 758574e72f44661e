//! Aggregation multigrid for the even-parity system `S` (and scalar diffusion systems such
//! as CDA), used as a preconditioner of the Krylov methods in [`super::parity`].
//!
//! * [`aggregate`](mod@aggregate): 2×2×2 geometric aggregation per moment grid (positions known from the
//!   layout), giving the piecewise-constant prolongation `P`.
//! * [`galerkin`]: coarse operators `Pᵀ A P`; on the finest level from the parity blocks,
//!   without forming `S` (docs/design.md §5).
//! * [`smoother`]: Jacobi-preconditioned Chebyshev smoothing.
//! * [`vcycle`]: the symmetric V-cycle `z = M⁻¹ r` (same smoother before and after the
//!   coarse correction, dense LU on the coarsest level), so `M` is symmetric positive
//!   definite when `S` is, as CG requires; or, with [`FineCycle::Additive`], the finest
//!   level joined additively, `M⁻¹ = ω D⁻¹ + P M_c⁻¹ Pᵀ`, which applies the finest
//!   operator not at all (the Krylov method's own products do the fine-level smoothing).
//!
//! The finest operator is not stored here: every application takes it as a closure (or,
//! as a [`Preconditioner`], bound to a [`LinearOperator`] with [`Multigrid::with_fine`]),
//! so the same hierarchy serves the matrix-free `S` and an assembled matrix.
//!
//! Nothing here knows the P_N layout or the parity split: the unknowns' classes and
//! positions come as a [`Geometry`] (built from the layout by [`super::pn_layout`]), and
//! the finest Galerkin operator as a closure (from the parity blocks in
//! [`super::parity::galerkin`]).

pub mod aggregate;
pub mod galerkin;
pub mod options;
pub mod smoother;
pub mod solve;
pub mod stencil_level;
pub mod vcycle;

pub use aggregate::Geometry;
pub use options::{FineCycle, MgOptions, SINGLE_FINE_MIN_TOL};

use aggregate::{aggregate, Aggregation};
use pn_krylov::linalg::{spmv, CompactCsr};
use pn_krylov::operator::{LinearOperator, Preconditioner};
use rayon::prelude::*;
use smoother::Chebyshev;
use sprs::CsMat;
use std::sync::Mutex;
use stencil_level::StencilLevel;

/// Why a hierarchy could not be built.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum MgError {
    /// Multigrid was asked for without the unknowns' positions.
    #[error(
        "the multigrid preconditioner needs the unknowns' grid positions (a layout); \
         build the solver with ParityCg::for_layout or SolverKind::solver_for"
    )]
    NoGeometry,
    /// The geometry does not match the operator.
    #[error("multigrid geometry has {geometry} unknowns but the operator has {rows}")]
    GeometryLength {
        /// Geometry length.
        geometry: usize,
        /// Operator rows.
        rows: usize,
    },
    /// A zero or non-finite diagonal entry (Jacobi smoothing divides by it).
    #[error("multigrid level {level} has diagonal {value:e} in row {row}")]
    BadDiagonal {
        /// Level (0 = finest).
        level: usize,
        /// Row.
        row: usize,
        /// Value.
        value: f64,
    },
    /// Aggregation stopped reducing before the coarsest level was small enough.
    #[error(
        "multigrid coarsening stalled at {unknowns} unknowns (dense coarse solve limit {limit})"
    )]
    CoarsestTooLarge {
        /// Unknowns on the last level.
        unknowns: usize,
        /// [`MgOptions::dense_max`].
        limit: usize,
    },
    /// The coarsest (dense) operator is singular.
    #[error("the coarsest multigrid operator ({unknowns} unknowns) is singular")]
    SingularCoarsest {
        /// Unknowns.
        unknowns: usize,
    },
}

/// Fewest vector entries per parallel task in the cycle's vector kernels: the coarse levels
/// are small (the 71² checkerboard's are 11,664 to 225 unknowns), and below a few thousand
/// entries scheduling costs more than the work.
pub(crate) const PAR_MIN_LEN: usize = 4096;

/// Over-correction of the coarse-grid step for scalar diffusion: piecewise-constant
/// aggregation underestimates the coarse correction of smooth modes, and with the plain
/// step MG-CG on the 7-point CDA operator needed 8/10/14 iterations at 16³/32³/64³,
/// with 1.4 it needs 9/10/11 (`tests/multigrid.rs`). On the P_N even-parity systems the
/// plain step is better (80³… 40³ P_3: 12 vs 15 iterations), so it stays 1 there.
pub const SCALAR_CORRECTION_SCALE: f64 = 1.4;

/// The multigrid cycle bound to its finest operator ([`Multigrid::with_fine`]).
pub struct MgCycle<'a> {
    mg: &'a Multigrid,
    fine: &'a dyn LinearOperator,
}

impl Preconditioner for MgCycle<'_> {
    fn apply(&self, r: &[f64], z: &mut [f64]) {
        let fine = |x: &[f64], y: &mut [f64]| self.fine.apply(x, y);
        self.mg.apply(&fine, r, z);
    }
}

/// One level above the coarsest.
struct Level {
    /// The level's operator (`None` on the finest level: passed in at each application).
    op: Option<LevelOp>,
    smoother: Chebyshev,
    agg: Aggregation,
}

/// A coarse level's operator: per-class stencils with per-row `f32` weights
/// ([`StencilLevel`], 4 bytes per stored weight, no column indices) where the level is
/// structured, else CSR with 32-bit columns and `f32` values
/// ([`CompactCsr::rounded_from_csr`], 8 bytes per entry instead of 16), unless its entries
/// do not fit `f32` or [`MgOptions::double_coarse`] asks for `f64`.
///
/// Only the preconditioner reads the coarse levels: the Krylov method's own products, its
/// residuals and the stopping test stay in double precision with the finest operator, so the
/// answer meets the same tolerance; the rounding of the coarse entries only perturbs the
/// preconditioner (docs/solvers.md, "Coarse levels in single precision"). The V-cycle's
/// traffic on the coarse levels, which after the stencil `S` (`parity::stencil_s`) is most of
/// a cycle's, halves.
enum LevelOp {
    Stencil(StencilLevel),
    Compact(CompactCsr<f32>),
    Double(CsMat<f64>),
}

impl LevelOp {
    fn new(a: CsMat<f64>, geom: &Geometry, opts: &MgOptions) -> Self {
        if opts.double_coarse {
            return LevelOp::Double(a);
        }
        if opts.stencil_coarse {
            if let Some(s) = StencilLevel::from_csr(&a, geom) {
                return LevelOp::Stencil(s);
            }
        }
        match CompactCsr::rounded_from_csr(&a) {
            Some(c) => LevelOp::Compact(c),
            None => LevelOp::Double(a),
        }
    }

    fn apply(&self, x: &[f64], y: &mut [f64]) {
        match self {
            LevelOp::Stencil(s) => s.apply(x, y),
            LevelOp::Compact(c) => c.mul(x, y),
            LevelOp::Double(a) => spmv(a, x, y),
        }
    }
}

/// Work vectors of one level.
struct Work {
    r: Vec<f64>,
    d: Vec<f64>,
    t: Vec<f64>,
    b_next: Vec<f64>,
    x_next: Vec<f64>,
}

/// The multigrid hierarchy.
pub struct Multigrid {
    levels: Vec<Level>,
    coarsest: nalgebra::LU<f64, nalgebra::Dyn, nalgebra::Dyn>,
    coarsest_len: usize,
    coarse_nnz: Vec<usize>,
    scale: f64,
    setup_apps: usize,
    /// The finest level is additive ([`FineCycle::Additive`]).
    additive: bool,
    /// [`csr_asymmetry`] of the first Galerkin operator `PᵀAP`.
    first_coarse_asymmetry: f64,
    /// Seconds of the setup phases (aggregate and diagonal, first Galerkin, symmetry check, power
    /// iteration, coarser levels), for [`Multigrid::describe_setup`].
    setup_seconds: [f64; 5],
    /// Cycles applied and nanoseconds spent in them (for the profile line).
    cycle_stats: [std::sync::atomic::AtomicU64; 2],
    work: Mutex<Vec<Work>>,
    /// The finest level in single precision ([`Multigrid::with_single_fine`]).
    single: Option<Box<SingleFine>>,
}

/// The finest operator in single precision, `y = A x` ([`Multigrid::with_single_fine`]).
pub type SingleApply = Box<dyn Fn(&[f32], &mut [f32]) + Send + Sync>;

/// The finest level of the cycle in `f32`: its operator, the smoother's inverse diagonal
/// and the work vectors, all in single precision.
struct SingleFine {
    apply: SingleApply,
    inv_diag: Vec<f32>,
    work: Mutex<[Vec<f32>; 5]>,
    /// Applications of `apply` so far.
    applications: std::sync::atomic::AtomicUsize,
}

fn inverse_diagonal(level: usize, diag: &[f64]) -> Result<Vec<f64>, MgError> {
    diag.iter()
        .enumerate()
        .map(|(row, &v)| {
            if v == 0.0 || !v.is_finite() {
                Err(MgError::BadDiagonal {
                    level,
                    row,
                    value: v,
                })
            } else {
                Ok(1.0 / v)
            }
        })
        .collect()
}

/// Relative asymmetry `|a_ij − a_ji| / (max_k |a_ik| + max_k |a_jk|)` of some entry of a
/// square CSR matrix with sorted columns where it exceeds `tol` (the search stops at the
/// first such entry found), or 0 when every entry is within `tol`; infinite for a
/// non-square or non-CSR matrix.
fn csr_asymmetry(a: &CsMat<f64>, tol: f64) -> f64 {
    use rayon::prelude::*;
    if !a.is_csr() || a.rows() != a.cols() {
        return f64::INFINITY;
    }
    let ap = a.indptr();
    let ap = ap.raw_storage();
    let (ai, av) = (a.indices(), a.data());
    let scale: Vec<f64> = (0..a.rows())
        .into_par_iter()
        .map(|i| {
            av[ap[i]..ap[i + 1]]
                .iter()
                .fold(0.0f64, |m, v| m.max(v.abs()))
        })
        .collect();
    (0..a.rows())
        .into_par_iter()
        .find_map_any(|i| {
            (ap[i]..ap[i + 1]).find_map(|p| {
                let j = ai[p];
                let t = match ai[ap[j]..ap[j + 1]].binary_search(&i) {
                    Ok(q) => av[ap[j] + q],
                    Err(_) => 0.0,
                };
                let d = (av[p] - t).abs();
                (d > tol * (scale[i] + scale[j])).then(|| d / (scale[i] + scale[j]))
            })
        })
        .unwrap_or(0.0)
}

/// [`FineCycle::AdditiveIfSymmetric`] treats the finest operator as symmetric when its
/// first Galerkin operator's relative entry asymmetry is at most this tolerance: rounding in
/// the coarse sums is ~1e-15 of the row scale, while the Neumann closure's asymmetry of
/// `S` measured 4e-5 to 4e-4 (random probes) on the point source and checkerboard P_3/P_5.
pub const COARSE_SYMMETRY_TOL: f64 = 1e-11;

/// The first coarse operator `Pᵀ A P`, as [`Multigrid::build`] takes it.
pub enum FirstCoarse {
    /// A CSR matrix (sparsified by [`MgOptions::drop`] and stored as [`LevelOp::new`]
    /// decides).
    Csr(CsMat<f64>),
    /// A structured level already in stencil form, with its relative entry asymmetry
    /// measured before the weights were rounded ([`stencil_level::parts_asymmetry`]; read
    /// only by [`FineCycle::AdditiveIfSymmetric`], 0 when not measured).
    Stencil(StencilLevel, f64),
}

/// A coarse operator while the hierarchy is built: CSR, or the first level built straight
/// as a stencil ([`FirstCoarse::Stencil`]).
enum Building {
    Csr(CsMat<f64>),
    Stencil(StencilLevel),
}

impl Building {
    fn rows(&self) -> usize {
        match self {
            Building::Csr(a) => a.rows(),
            Building::Stencil(s) => s.len(),
        }
    }

    fn diagonal(&self) -> Vec<f64> {
        match self {
            Building::Csr(a) => csr_diagonal(a),
            Building::Stencil(s) => s.diagonal(),
        }
    }

    /// `Pᵀ A P` of `agg`: from a stencil level straight as the next stencil level
    /// ([`StencilLevel::galerkin_level`]) where the options store coarse levels as stencils,
    /// otherwise as CSR.
    fn galerkin(&self, agg: &Aggregation, opts: &MgOptions) -> Building {
        match self {
            Building::Csr(a) => Building::Csr(galerkin::coarse_from_csr(a, agg)),
            Building::Stencil(s) => {
                if opts.stencil_coarse && !opts.double_coarse {
                    if let Some(next) = s.galerkin_level(agg) {
                        return Building::Stencil(next);
                    }
                }
                Building::Csr(s.galerkin(agg))
            }
        }
    }

    fn nonzeros(&self) -> usize {
        match self {
            Building::Csr(a) => a.nnz(),
            Building::Stencil(s) => s.nonzeros(),
        }
    }

    fn into_op(self, geom: &Geometry, opts: &MgOptions) -> LevelOp {
        match self {
            Building::Csr(a) => LevelOp::new(a, geom, opts),
            Building::Stencil(s) => LevelOp::Stencil(s),
        }
    }

    fn into_csr(self) -> CsMat<f64> {
        match self {
            Building::Csr(a) => a,
            Building::Stencil(s) => s.to_csr(),
        }
    }
}

fn csr_diagonal(a: &CsMat<f64>) -> Vec<f64> {
    let mut d = vec![0.0; a.rows()];
    for (i, row) in a.outer_iterator().enumerate() {
        d[i] = row.get(i).copied().unwrap_or(0.0);
    }
    d
}

/// The finest level's cycle ([`MgOptions::fine_cycle`] resolved) and the relative asymmetry
/// of the first Galerkin operator `a` (`first_asymmetry`: as measured when it was built as
/// a stencil), for [`Multigrid::build`].
///
/// `PᵀAP` is symmetric (to rounding) when `A` is; an asymmetric `A` could pass only if its
/// asymmetry cancelled within every aggregate pair. No application of `A`. Only the
/// additive-if-symmetric cycle needs it here; otherwise it is left unchecked (0, as for a
/// symmetric operator) and the caller measures the symmetry with a few products instead (a
/// symmetric 8.7 M-entry first level, the 32³ P_7 cloud, took 0.43 s to check in full).
fn fine_cycle_of(a: &Building, first_asymmetry: Option<f64>, opts: &MgOptions) -> (FineCycle, f64) {
    match opts.fine_cycle {
        FineCycle::AdditiveIfSymmetric => {
            let asym = match a {
                Building::Csr(c) => csr_asymmetry(c, COARSE_SYMMETRY_TOL),
                Building::Stencil(_) => first_asymmetry.unwrap_or(f64::INFINITY),
            };
            (opts.fine_cycle.resolve(asym <= COARSE_SYMMETRY_TOL), asym)
        }
        c => (c, 0.0),
    }
}

/// The finest level's smoother for [`Multigrid::build`] from its inverse diagonal `inv`,
/// with its `λ_max` estimated with the finest operator `single` in `f32` where there is
/// one (else `fine_apply`); and that inverse diagonal in `f32` when `single` estimated it
/// (the finest level then runs in single precision).
fn fine_smoother(
    fine_apply: &dyn Fn(&[f64], &mut [f64]),
    single: Option<&SingleApply>,
    inv: Vec<f64>,
    fine_cycle: FineCycle,
    fine_degree: usize,
    opts: &MgOptions,
) -> (Chebyshev, Option<Vec<f32>>) {
    // The inverse diagonal in f32, where the finest level runs in single precision.
    let mut inv32: Option<Vec<f32>> = None;
    let smoother = match fine_cycle {
        // The additive term ω D⁻¹ needs no spectrum: no `λ_max` estimate.
        FineCycle::Additive { omega } => Chebyshev {
            inv_diag: inv,
            lambda_max: 1.0 / omega,
            lambda_min: 1.0 / omega,
            degree: 1,
        },
        _ => {
            let ratio = if fine_degree <= 1 {
                opts.ratio_for(1)
            } else {
                opts.fine_ratio
            };
            match single {
                // With the operator the cycle will apply, in f32: half the bytes.
                Some(single) => {
                    let inv_single = inv32.insert(inv.par_iter().map(|&v| v as f32).collect());
                    let lambda_max =
                        smoother::estimate_lambda_max_with(single, inv_single, opts.power_steps);
                    Chebyshev::from_estimate(inv, lambda_max, fine_degree, ratio)
                }
                None => Chebyshev::new(fine_apply, inv, fine_degree, ratio, opts.power_steps),
            }
        }
    };
    (smoother, inv32)
}

/// The levels below `finest` for [`Multigrid::build`]: each aggregated from the one above,
/// with its operator the Galerkin operator of the one above (`a`, the first) and its own
/// smoother of degree `coarse_degree`, until [`MgOptions::coarse_max`] unknowns,
/// [`MgOptions::max_levels`] levels, or aggregation stops reducing. Returns the levels above
/// the coarsest, each coarse operator's stored entries, and the coarsest operator.
fn coarse_levels(
    finest: Level,
    mut a: Building,
    coarse_degree: usize,
    opts: &MgOptions,
) -> Result<(Vec<Level>, Vec<usize>, Building), MgError> {
    let mut g = finest.agg.coarse.clone();
    let mut levels = vec![finest];
    let mut coarse_nnz = vec![a.nonzeros()];
    while a.rows() > opts.coarse_max && levels.len() + 1 < opts.max_levels {
        let agg = aggregate(&g);
        if agg.coarse_len() as f64 > 0.9 * a.rows() as f64 {
            break;
        }
        let inv = inverse_diagonal(levels.len(), &a.diagonal())?;
        let next = a.galerkin(&agg, opts);
        let op = a.into_op(&g, opts);
        // λ_max of the operator the cycle applies, whose stored f32 form reads fewer bytes
        // than the f64 CSR (80³ P_5 point source, coarser levels 1.1 → 0.78 s).
        let smoother = Chebyshev::new(
            &|x: &[f64], y: &mut [f64]| op.apply(x, y),
            inv,
            coarse_degree,
            opts.ratio_for(coarse_degree),
            opts.power_steps.max(10),
        );
        g = agg.coarse.clone();
        coarse_nnz.push(next.nonzeros());
        levels.push(Level {
            op: Some(op),
            smoother,
            agg,
        });
        a = next;
    }
    Ok((levels, coarse_nnz, a))
}

/// The dense LU factors of the coarsest operator `a` and its size (at most
/// [`MgOptions::dense_max`]).
fn coarsest_lu(
    a: CsMat<f64>,
    opts: &MgOptions,
) -> Result<(nalgebra::LU<f64, nalgebra::Dyn, nalgebra::Dyn>, usize), MgError> {
    let n = a.rows();
    if n > opts.dense_max {
        return Err(MgError::CoarsestTooLarge {
            unknowns: n,
            limit: opts.dense_max,
        });
    }
    let mut dense = nalgebra::DMatrix::<f64>::zeros(n, n);
    for (i, row) in a.outer_iterator().enumerate() {
        for (j, &v) in row.iter() {
            dense[(i, j)] += v;
        }
    }
    let lu = dense.lu();
    if !lu.is_invertible() {
        return Err(MgError::SingularCoarsest { unknowns: n });
    }
    Ok((lu, n))
}

/// The work vectors of the levels above the coarsest.
fn work_vectors(levels: &[Level]) -> Vec<Work> {
    levels
        .iter()
        .enumerate()
        .map(|(l, lev)| {
            let n_l = lev.agg.agg.len();
            let n_next = lev.agg.coarse_len();
            debug_assert!(l + 1 >= levels.len() || levels[l + 1].agg.agg.len() == n_next);
            Work {
                r: vec![0.0; n_l],
                d: vec![0.0; n_l],
                t: vec![0.0; n_l],
                b_next: vec![0.0; n_next],
                x_next: vec![0.0; n_next],
            }
        })
        .collect()
}

impl Multigrid {
    /// Builds the hierarchy for a finest operator given by `fine_apply` with the diagonal
    /// `fine_diag()` and unknowns `geom`; `first_coarse` computes `Pᵀ A P` for the first
    /// aggregation. `single`, the finest operator in `f32`, makes the finest level of the
    /// cycle single-precision ([`Multigrid::with_single_fine`]) and estimates its `λ_max`
    /// with it (80³ P_5 point source: 8 Lanczos steps 0.53 s in `f64`).
    ///
    /// The diagonal is computed while the unknowns are aggregated (the aggregation is one
    /// serial pass; the diagonal's parallel work takes the other threads).
    pub fn build(
        fine_apply: &dyn Fn(&[f64], &mut [f64]),
        single: Option<SingleApply>,
        fine_diag: impl FnOnce() -> Vec<f64> + Send,
        geom: &Geometry,
        first_coarse: impl FnOnce(&Aggregation) -> FirstCoarse,
        opts: &MgOptions,
    ) -> Result<Self, MgError> {
        let t0 = std::time::Instant::now();
        let (agg, fine_diag) = rayon::join(|| aggregate(geom), fine_diag);
        if geom.len() != fine_diag.len() {
            return Err(MgError::GeometryLength {
                geometry: geom.len(),
                rows: fine_diag.len(),
            });
        }
        let inv = inverse_diagonal(0, &fine_diag)?;
        let t_agg = t0.elapsed().as_secs_f64();
        let (a, first_asymmetry) = match first_coarse(&agg) {
            FirstCoarse::Csr(c) => (Building::Csr(c), None),
            FirstCoarse::Stencil(s, asym) => (Building::Stencil(s), Some(asym)),
        };
        let t_first = t0.elapsed().as_secs_f64();
        let (fine_cycle, first_coarse_asymmetry) = fine_cycle_of(&a, first_asymmetry, opts);
        let fine_degree = if first_coarse_asymmetry > COARSE_SYMMETRY_TOL {
            opts.fine_degree_nonsymmetric
        } else {
            opts.fine_degree
        };
        let t_sym = t0.elapsed().as_secs_f64();
        let (smoother, inv32) = fine_smoother(
            fine_apply,
            single.as_ref(),
            inv,
            fine_cycle,
            fine_degree,
            opts,
        );
        let additive = matches!(fine_cycle, FineCycle::Additive { .. });
        let t_power = t0.elapsed().as_secs_f64();
        // 2D-like coarsening (at most 4 fine unknowns per aggregate on average).
        let coarse_degree = if 4 * agg.coarse_len() >= geom.len() {
            opts.coarse_degree_2d
        } else {
            opts.coarse_degree
        };
        let finest = Level {
            op: None,
            smoother,
            agg,
        };
        let (levels, coarse_nnz, a) = coarse_levels(finest, a, coarse_degree, opts)?;
        let setup_seconds = [
            t_agg,
            t_first - t_agg,
            t_sym - t_first,
            t_power - t_sym,
            t0.elapsed().as_secs_f64() - t_power,
        ];
        let (lu, n) = coarsest_lu(a.into_csr(), opts)?;
        let work = work_vectors(&levels);
        let mg = Self {
            levels,
            coarsest: lu,
            coarsest_len: n,
            coarse_nnz,
            scale: opts.correction_scale.unwrap_or(1.0),
            setup_seconds,
            setup_apps: if additive { 0 } else { opts.power_steps.max(1) },
            additive,
            first_coarse_asymmetry,
            cycle_stats: Default::default(),
            work: Mutex::new(work),
            single: None,
        };
        // (The additive finest level never applies the finest operator: no single form.)
        Ok(match (single, inv32) {
            (Some(apply), Some(inv_diag)) => mg.attach_single(apply, inv_diag),
            _ => mg,
        })
    }

    /// Runs the finest level of the cycle (its smoothing, residual, restriction and
    /// prolongation) in single precision with the operator `apply` (the finest operator in
    /// `f32`); the coarse levels, which already store `f32` values, keep `f64` vectors.
    /// The cycle is a preconditioner: the Krylov method, its residuals and its stopping test
    /// stay in `f64` with the finest operator, so the answer meets the same tolerance; the
    /// finest level's traffic (vectors and diagonals) halves. Ignored for the additive
    /// finest level, which never applies the finest operator.
    pub fn with_single_fine(self, apply: SingleApply) -> Self {
        if self.additive || self.levels.is_empty() {
            return self;
        }
        let inv_diag: Vec<f32> = self.levels[0]
            .smoother
            .inv_diag
            .iter()
            .map(|&v| v as f32)
            .collect();
        self.attach_single(apply, inv_diag)
    }

    /// [`Multigrid::with_single_fine`] with the finest inverse diagonal already in `f32`.
    fn attach_single(mut self, apply: SingleApply, inv_diag: Vec<f32>) -> Self {
        let n = inv_diag.len();
        self.single = Some(Box::new(SingleFine {
            apply,
            inv_diag,
            work: Mutex::new(std::array::from_fn(|_| vec![0.0f32; n])),
            applications: Default::default(),
        }));
        self
    }

    /// Whether the finest level runs in single precision.
    pub fn is_single_fine(&self) -> bool {
        self.single.is_some()
    }

    /// Applications of the single-precision finest operator so far (the cycle's smoothing
    /// and residuals on the finest level; 0 in double precision, where the caller counts
    /// them through its own operator).
    pub fn single_fine_applications(&self) -> usize {
        self.single.as_ref().map_or(0, |s| {
            s.applications.load(std::sync::atomic::Ordering::Relaxed)
        })
    }

    /// The hierarchy for an assembled matrix `a` (for example CDA) with unknowns `geom`;
    /// an unset [`MgOptions::correction_scale`] is [`SCALAR_CORRECTION_SCALE`] here.
    pub fn for_matrix(a: &CsMat<f64>, geom: &Geometry, opts: &MgOptions) -> Result<Self, MgError> {
        if geom.len() != a.rows() {
            return Err(MgError::GeometryLength {
                geometry: geom.len(),
                rows: a.rows(),
            });
        }
        let apply = |x: &[f64], y: &mut [f64]| spmv(a, x, y);
        // Scalar systems (CDA): the multiplicative cycle unless asked, one coarse degree
        // and one damped interval on all levels, as tested (a finest ratio of 15 gave
        // 11 / 11 / 12 CG iterations at 16³ / 32³ / 64³ instead of 9 / 10 / 11; the
        // additive form is untested there).
        let opts = MgOptions {
            fine_cycle: match opts.fine_cycle {
                FineCycle::AdditiveIfSymmetric => FineCycle::Multiplicative,
                c => c,
            },
            fine_ratio: opts.ratio,
            coarse_degree_2d: opts.coarse_degree,
            correction_scale: Some(opts.correction_scale.unwrap_or(SCALAR_CORRECTION_SCALE)),
            ..opts.clone()
        };
        Self::build(
            &apply,
            None,
            || csr_diagonal(a),
            geom,
            |agg| FirstCoarse::Csr(galerkin::coarse_from_csr(a, agg)),
            &opts,
        )
    }

    /// `z = D⁻¹ r` with the finest level's diagonal (what [`Multigrid::apply`] reduces to
    /// without the finest operator).
    pub fn apply_jacobi(&self, r: &[f64], z: &mut [f64]) {
        match self.levels.first() {
            Some(l) => z
                .iter_mut()
                .zip(r.iter().zip(&l.smoother.inv_diag))
                .for_each(|(zi, (ri, di))| *zi = ri * di),
            None => z.copy_from_slice(r),
        }
    }

    /// Applications of the finest operator made while building (the `λ_max` estimate).
    pub fn setup_fine_applications(&self) -> usize {
        self.setup_apps
    }

    /// Unknowns per level, finest first (the last is the dense coarsest level).
    pub fn level_sizes(&self) -> Vec<usize> {
        let mut v: Vec<usize> = self.levels.iter().map(|l| l.agg.agg.len()).collect();
        v.push(self.coarsest_len);
        v
    }

    /// Stored entries of the coarse operators (levels 1, 2, …).
    pub fn coarse_nonzeros(&self) -> &[usize] {
        &self.coarse_nnz
    }

    /// Whether the finest level is additive ([`FineCycle::Additive`]).
    pub fn is_additive(&self) -> bool {
        self.additive
    }

    /// Relative asymmetry of an entry of the first Galerkin operator `PᵀAP` above
    /// [`COARSE_SYMMETRY_TOL`], or 0 if there is none or it was not checked (only
    /// [`FineCycle::AdditiveIfSymmetric`] checks it). `PᵀAP` is
    /// symmetric to rounding (~1e-15) whenever `A` is, so a positive value proves `A`
    /// nonsymmetric without a single application of `A`.
    pub fn first_coarse_asymmetry(&self) -> f64 {
        self.first_coarse_asymmetry
    }

    /// The multigrid cycle as a [`Preconditioner`], with `fine` the finest operator.
    pub fn with_fine<'a>(&'a self, fine: &'a dyn LinearOperator) -> MgCycle<'a> {
        MgCycle { mg: self, fine }
    }

    /// One line with the seconds of the setup phases (for the solvers' profile output).
    pub fn describe_setup(&self) -> String {
        let [agg, first, sym, power, coarse] = self.setup_seconds;
        format!(
            "aggregate and diagonal {agg:.3} s, first Galerkin {first:.3} s, symmetry check {sym:.3} s, power {power:.3} s, coarser levels {coarse:.3} s"
        )
    }

    /// Coarse levels whose operator is stored as per-class stencils ([`StencilLevel`])
    /// rather than CSR.
    pub fn stencil_levels(&self) -> usize {
        self.levels
            .iter()
            .filter(|l| matches!(l.op, Some(LevelOp::Stencil(_))))
            .count()
    }

    /// One line describing the hierarchy (sizes, non-zeros, smoother bounds, and the
    /// cycles applied so far with their time).
    pub fn describe(&self) -> String {
        use std::sync::atomic::Ordering::Relaxed;
        let sizes = self.level_sizes();
        let fine = match self.levels.first() {
            Some(l) if self.additive => {
                format!("fine additive ω = {:.3}", 1.0 / l.smoother.lambda_max)
            }
            Some(l) => format!(
                "fine λ_max(D⁻¹A) ≈ {:.3}, degree {}",
                l.smoother.lambda_max, l.smoother.degree
            ),
            None => "no fine level".into(),
        };
        format!(
            "{} levels, unknowns {:?}, coarse nnz {:?} ({} as stencils), {fine}{}, coarse degree {}, {} cycles in {:.3} s",
            sizes.len(),
            sizes,
            self.coarse_nnz,
            self.stencil_levels(),
            if self.single.is_some() { " (f32)" } else { "" },
            self.levels.get(1).map_or(0, |l| l.smoother.degree),
            self.cycle_stats[0].load(Relaxed),
            self.cycle_stats[1].load(Relaxed) as f64 * 1e-9,
        )
    }
}
