//! Aggregation multigrid for the even-parity system `S` (and scalar diffusion systems such
//! as CDA), used as a preconditioner of the Krylov methods in [`super::parity`].
//!
//! * [`aggregate`]: 2×2×2 geometric aggregation per moment grid (positions known from the
//!   layout), giving the piecewise-constant prolongation `P`.
//! * [`galerkin`]: coarse operators `Pᵀ A P`; on the finest level from the parity blocks,
//!   without forming `S` (DESIGN.md §5).
//! * [`smoother`]: Jacobi-preconditioned Chebyshev smoothing.
//! * [`vcycle`]: the symmetric V-cycle `z = M⁻¹ r` (same smoother before and after the
//!   coarse correction, dense LU on the coarsest level), so `M` is symmetric positive
//!   definite when `S` is, as CG requires.
//!
//! The finest operator is not stored here: every application takes it as a closure, so
//! the same hierarchy serves the matrix-free `S` and an assembled matrix.

pub mod aggregate;
pub mod galerkin;
pub mod smoother;
pub mod solve;
pub mod vcycle;

pub use aggregate::Geometry;

use crate::linalg::spmv;
use aggregate::{aggregate, Aggregation};
use smoother::Chebyshev;
use sprs::CsMat;
use std::sync::Mutex;

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

/// Tuning of the hierarchy and the cycle.
#[derive(Clone, Debug, PartialEq)]
pub struct MgOptions {
    /// Chebyshev degree on the finest level (each costs one application of `S`, twice per
    /// cycle: before and after the coarse correction).
    pub fine_degree: usize,
    /// Chebyshev degree on the coarse levels (they are cheap).
    pub coarse_degree: usize,
    /// The smoother damps `[λ_max/ratio, λ_max]` of `D⁻¹A` (degree ≥ 2).
    pub ratio: f64,
    /// Power iterations for `λ_max`.
    pub power_steps: usize,
    /// Stop coarsening at this many unknowns.
    pub coarse_max: usize,
    /// Largest coarsest level solved by dense LU.
    pub dense_max: usize,
    /// At most this many levels.
    pub max_levels: usize,
    /// The coarse correction is added as `x += scale · P x_c` (over-correction makes up
    /// for the energy that piecewise-constant interpolation loses; 1 = plain).
    pub correction_scale: f64,
}

impl Default for MgOptions {
    fn default() -> Self {
        Self {
            fine_degree: 2,
            coarse_degree: 2,
            ratio: 10.0,
            power_steps: 8,
            coarse_max: 300,
            dense_max: 6000,
            max_levels: 25,
            correction_scale: 1.0,
        }
    }
}

impl MgOptions {
    /// The defaults with overrides from the environment (`PN_MG_FINE_DEGREE`,
    /// `PN_MG_COARSE_DEGREE`, `PN_MG_RATIO`, `PN_MG_POWER_STEPS`, `PN_MG_COARSE_MAX`,
    /// `PN_MG_SCALE`), for tuning experiments; unparsable values are ignored.
    pub fn from_env() -> Self {
        fn get<T: std::str::FromStr>(name: &str, default: T) -> T {
            std::env::var(name)
                .ok()
                .and_then(|v| v.parse().ok())
                .unwrap_or(default)
        }
        let d = Self::default();
        Self {
            fine_degree: get("PN_MG_FINE_DEGREE", d.fine_degree),
            coarse_degree: get("PN_MG_COARSE_DEGREE", d.coarse_degree),
            ratio: get("PN_MG_RATIO", d.ratio),
            power_steps: get("PN_MG_POWER_STEPS", d.power_steps),
            coarse_max: get("PN_MG_COARSE_MAX", d.coarse_max),
            correction_scale: get("PN_MG_SCALE", d.correction_scale),
            ..d
        }
    }

    /// The damped interval's ratio for a given degree: degree 1 (damped Jacobi) uses
    /// `[λ_max/2, λ_max]`, i.e. `ω = 4/(3λ_max)`, the classical smoothing weight.
    fn ratio_for(&self, degree: usize) -> f64 {
        if degree <= 1 {
            2.0
        } else {
            self.ratio
        }
    }
}

/// One level above the coarsest.
struct Level {
    /// The level's operator (`None` on the finest level: passed in at each application).
    op: Option<CsMat<f64>>,
    smoother: Chebyshev,
    agg: Aggregation,
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
    work: Mutex<Vec<Work>>,
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

fn csr_diagonal(a: &CsMat<f64>) -> Vec<f64> {
    let mut d = vec![0.0; a.rows()];
    for (i, row) in a.outer_iterator().enumerate() {
        d[i] = row.get(i).copied().unwrap_or(0.0);
    }
    d
}

impl Multigrid {
    /// Builds the hierarchy for a finest operator given by `fine_apply` with diagonal
    /// `fine_diag` and unknowns `geom`; `first_coarse` computes `Pᵀ A P` for the first
    /// aggregation.
    pub fn build(
        fine_apply: &dyn Fn(&[f64], &mut [f64]),
        fine_diag: &[f64],
        geom: &Geometry,
        first_coarse: impl FnOnce(&Aggregation) -> CsMat<f64>,
        opts: &MgOptions,
    ) -> Result<Self, MgError> {
        if geom.len() != fine_diag.len() {
            return Err(MgError::GeometryLength {
                geometry: geom.len(),
                rows: fine_diag.len(),
            });
        }
        let t0 = std::time::Instant::now();
        let inv = inverse_diagonal(0, fine_diag)?;
        let smoother = Chebyshev::new(
            fine_apply,
            inv,
            opts.fine_degree,
            opts.ratio_for(opts.fine_degree),
            opts.power_steps,
        );
        let t_power = t0.elapsed().as_secs_f64();
        let agg = aggregate(geom);
        let t_agg = t0.elapsed().as_secs_f64();
        let mut a = first_coarse(&agg);
        let t_first = t0.elapsed().as_secs_f64();
        let mut g = agg.coarse.clone();
        let mut levels = vec![Level {
            op: None,
            smoother,
            agg,
        }];
        let mut coarse_nnz = vec![a.nnz()];
        while a.rows() > opts.coarse_max && levels.len() + 1 < opts.max_levels {
            let agg = aggregate(&g);
            if agg.coarse_len() as f64 > 0.9 * a.rows() as f64 {
                break;
            }
            let inv = inverse_diagonal(levels.len(), &csr_diagonal(&a))?;
            let smoother = {
                let op = |x: &[f64], y: &mut [f64]| spmv(&a, x, y);
                Chebyshev::new(
                    &op,
                    inv,
                    opts.coarse_degree,
                    opts.ratio_for(opts.coarse_degree),
                    opts.power_steps.max(10),
                )
            };
            let next = galerkin::coarse_from_csr(&a, &agg);
            g = agg.coarse.clone();
            coarse_nnz.push(next.nnz());
            levels.push(Level {
                op: Some(a),
                smoother,
                agg,
            });
            a = next;
        }
        if crate::solver::parity::profile_enabled() {
            eprintln!(
                "profile mg setup: power {t_power:.3} s, aggregate {:.3} s, first Galerkin {:.3} s, coarser levels {:.3} s",
                t_agg - t_power,
                t_first - t_agg,
                t0.elapsed().as_secs_f64() - t_first
            );
        }
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
        let work = levels
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
            .collect();
        Ok(Self {
            levels,
            coarsest: lu,
            coarsest_len: n,
            coarse_nnz,
            scale: opts.correction_scale,
            setup_apps: opts.power_steps.max(1),
            work: Mutex::new(work),
        })
    }

    /// The hierarchy for an assembled matrix `a` (for example CDA) with unknowns `geom`.
    pub fn for_matrix(a: &CsMat<f64>, geom: &Geometry, opts: &MgOptions) -> Result<Self, MgError> {
        if geom.len() != a.rows() {
            return Err(MgError::GeometryLength {
                geometry: geom.len(),
                rows: a.rows(),
            });
        }
        let apply = |x: &[f64], y: &mut [f64]| spmv(a, x, y);
        Self::build(
            &apply,
            &csr_diagonal(a),
            geom,
            |agg| galerkin::coarse_from_csr(a, agg),
            opts,
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

    /// Applications of the finest operator made while building (power iteration).
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

    /// One line describing the hierarchy (sizes, non-zeros, smoother bounds).
    pub fn describe(&self) -> String {
        let sizes = self.level_sizes();
        format!(
            "{} levels, unknowns {:?}, coarse nnz {:?}, fine λ_max(D⁻¹A) ≈ {:.3}, degrees {}/{}",
            sizes.len(),
            sizes,
            self.coarse_nnz,
            self.levels
                .first()
                .map_or(0.0, |l| l.smoother.lambda_max / 1.1),
            self.levels.first().map_or(0, |l| l.smoother.degree),
            self.levels.get(1).map_or(0, |l| l.smoother.degree),
        )
    }
}
