//! The tuning of the multigrid hierarchy and its cycle ([`MgOptions`], with
//! [`MgOptions::from_vars`] reading the `PN_MG_*` variables), and how the finest level
//! enters the cycle ([`FineCycle`]).

/// Tuning of the hierarchy and the cycle.
#[derive(Clone, Debug, PartialEq)]
pub struct MgOptions {
    /// Chebyshev degree on the finest level (each costs one application of `S`, twice per
    /// cycle: before and after the coarse correction).
    pub fine_degree: usize,
    /// The finest level's degree instead of `fine_degree` where
    /// [`FineCycle::AdditiveIfSymmetric`] finds the operator nonsymmetric, which the parity
    /// solver then solves with GMRES: a GMRES iteration costs more than a CG iteration (its
    /// own `f64` product and an orthogonalisation against the growing basis), so a
    /// stronger smoother that saves iterations pays there. Measured (`pn solve … --tol 1e-6`
    /// except the checkerboard's 1e-10, GMRES iterations and solve seconds, degree 2 → 3, two
    /// runs each, 2026-12-06): 71² checkerboard P_5 53 → 44 it (0.19–0.28 → 0.18–0.19 s),
    /// 40³ point source P_5 14 → 11 it (0.95–1.04 → 0.91–0.92 s), P_3 11 → 10 it (0.29 →
    /// 0.28–0.30 s), 80³ P_5 19 → 15 it (solve 10.6 → 10.3–10.4 s); degree 4 at 80³ P_5: 15 it,
    /// 11.2 s. Under CG the cheaper iteration favours degree 2 at low orders (32³ cloud
    /// P_4 / P_5 render solves 0.65 / 0.88 s at degree 2 against 0.74 / 0.94 s at 3; P_7
    /// equal, P_9 6.1 → 5.7 s).
    pub fine_degree_nonsymmetric: usize,
    /// Chebyshev degree on the coarse levels (they are cheap).
    pub coarse_degree: usize,
    /// Chebyshev degree on the coarse levels where aggregation coarsens by at most 4 per
    /// level (2D grids), where the coarse levels are relatively larger. Degree 3 saves 3
    /// iterations on the 71² checkerboard P_5 (GMRES to 1e-10: 50 vs 53) but costs more
    /// time than they save: the whole `pn solve checkerboard`, 10 alternating runs on the
    /// x86-64-v3 build (2026-12-05), median 0.256 s with 3 against 0.244 s with 2 (P_3:
    /// 0.165 / 0.163 s, 99 iterations either way). So the default is 2, as in 3D.
    pub coarse_degree_2d: usize,
    /// The smoother damps `[λ_max/ratio, λ_max]` of `D⁻¹A` (degree ≥ 2).
    pub ratio: f64,
    /// The same for the finest level's smoother (degree ≥ 2). On the even-parity
    /// systems 15 saves about one iteration against 10 (5 applications of `S`; GMRES
    /// iterations 15 vs 10 vs 20): 40³ P_3 point source 11 / 12 / 11, 32³ P_5 12 / 13 / 13,
    /// 71² checkerboard P_5 53 / 54 / 53, P_3 42 / 42 / 42. [`Multigrid::for_matrix`](super::Multigrid::for_matrix) uses
    /// `ratio` instead.
    pub fine_ratio: f64,
    /// Lanczos steps for the estimate of `λ_max` ([`smoother::estimate_lambda_max`](super::smoother::estimate_lambda_max); the
    /// variable keeps its older name, `PN_MG_POWER_STEPS`).
    pub power_steps: usize,
    /// Stop coarsening at this many unknowns.
    pub coarse_max: usize,
    /// Largest coarsest level solved by dense LU.
    pub dense_max: usize,
    /// At most this many levels.
    pub max_levels: usize,
    /// The coarse correction is added as `x += scale · P x_c` (over-correction makes up
    /// for the energy that piecewise-constant interpolation loses; 1 = plain). `None`:
    /// 1 on the parity systems ([`Multigrid::build`](super::Multigrid::build)), [`SCALAR_CORRECTION_SCALE`](super::SCALAR_CORRECTION_SCALE) on
    /// scalar ones ([`Multigrid::for_matrix`](super::Multigrid::for_matrix)).
    pub correction_scale: Option<f64>,
    /// How the finest level enters the preconditioner.
    pub fine_cycle: FineCycle,
    /// Keep the coarse levels' operators in double precision instead of the compact
    /// single-precision storage ([`LevelOp`](super::LevelOp)). For comparisons in tests
    /// only: the experiment concluded for `f32` (docs/lab/solvers-history.md).
    pub double_coarse: bool,
    /// Store the structured coarse levels as per-class stencils with per-row weights
    /// ([`StencilLevel`](super::StencilLevel)) instead of the compact CSR. `false` is for
    /// the tests' cross-checks of the two storages only: the experiment concluded for the
    /// stencils.
    pub stencil_coarse: bool,
    /// Run the finest level of the cycle in single precision where the finest operator has
    /// an `f32` form ([`Multigrid::with_single_fine`](super::Multigrid::with_single_fine)): `None` decides by the solve's
    /// tolerance ([`SINGLE_FINE_MIN_TOL`]); `PN_MG_SINGLE=0|1` forces it.
    pub single_fine: Option<bool>,
}

/// The tightest relative tolerance for which the parity solves run the finest
/// level of the cycle in single precision by default: rounding `f32` perturbs the
/// preconditioner by about 1e-7 relative, far below what a solve to 1e-6 or looser needs.
pub const SINGLE_FINE_MIN_TOL: f64 = 1e-6;

/// How the finest level enters the preconditioner.
///
/// Measured (`pn solve pointsource --tol 1e-6`, CG iterations / applications of `S` in the
/// iteration, the multiplicative setup's 8 power steps not included): 40³ P_1
/// multiplicative 9 / 46, additive 19 / 20; 80³ P_1 12 / 61 vs 22 / 23 (iterate 0.46 s vs
/// 0.26 s); 40³ P_3 Dirichlet 12 / 61 vs 39 / 40 (iterate 0.56–0.65 s vs 0.53–0.58 s,
/// three runs each). Under GMRES (the slightly nonsymmetric Neumann `S` from P_3 on) the
/// additive form also needs fewer applications, but its many more iterations cost more
/// orthogonalisation than they save: 80³ P_5 19 / 101 vs 64 / 69, iterate 26 s vs 36 s;
/// 71² checkerboard P_5 54 vs 178 iterations, 0.49 s vs 1.12 s. (CG instead of GMRES
/// diverged on the checkerboard.) Hence the default [`FineCycle::AdditiveIfSymmetric`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum FineCycle {
    /// Chebyshev smoothing before and after the coarse correction (V-cycle): `2·degree`
    /// applications of the finest operator per cycle.
    Multiplicative,
    /// `M⁻¹ = ω D⁻¹ + P M_c⁻¹ Pᵀ` with `M_c⁻¹` the V-cycle of the coarse levels: no
    /// application of the finest operator in the cycle and no `λ_max` estimate. Symmetric;
    /// the Krylov method needs more iterations (one application each).
    Additive {
        /// Weight of the fine-level Jacobi term relative to the coarse correction (the
        /// iteration counts hardly depend on it: 0.5, 1 and 2 gave 39, 39 and 40
        /// iterations on the 40³ P_3 point source).
        omega: f64,
    },
    /// Additive (`ω = 1`) where the finest operator is symmetric (so that CG, with its
    /// short recurrence, runs), multiplicative elsewhere. Symmetry is read off the first
    /// Galerkin operator `PᵀAP` (no application of `A`). [`Multigrid::for_matrix`](super::Multigrid::for_matrix) (scalar
    /// systems such as CDA) takes it as multiplicative.
    AdditiveIfSymmetric,
}

impl FineCycle {
    /// `AdditiveIfSymmetric` resolved for an operator that is (or is not) symmetric.
    pub fn resolve(self, symmetric: bool) -> Self {
        match self {
            FineCycle::AdditiveIfSymmetric if symmetric => FineCycle::Additive { omega: 1.0 },
            FineCycle::AdditiveIfSymmetric => FineCycle::Multiplicative,
            other => other,
        }
    }
}

impl Default for MgOptions {
    fn default() -> Self {
        Self {
            fine_degree: 2,
            fine_degree_nonsymmetric: 3,
            coarse_degree: 2,
            coarse_degree_2d: 2,
            ratio: 10.0,
            fine_ratio: 15.0,
            power_steps: 8,
            coarse_max: 300,
            dense_max: 6000,
            max_levels: 25,
            correction_scale: None,
            fine_cycle: FineCycle::AdditiveIfSymmetric,
            double_coarse: false,
            stencil_coarse: true,
            single_fine: None,
        }
    }
}

impl MgOptions {
    /// The defaults with overrides from named variables (`get("PN_MG_RATIO")` etc.):
    /// `PN_MG_FINE_DEGREE` (both finest degrees unless `PN_MG_FINE_DEGREE_NONSYMMETRIC` sets
    /// the second), `PN_MG_COARSE_DEGREE`, `PN_MG_COARSE_DEGREE_2D`, `PN_MG_RATIO`,
    /// `PN_MG_FINE_RATIO`, `PN_MG_POWER_STEPS`, `PN_MG_COARSE_MAX`, `PN_MG_SCALE`;
    /// `PN_MG_ADDITIVE=ω` (ω > 0) forces [`FineCycle::Additive`], `PN_MG_ADDITIVE=0`
    /// [`FineCycle::Multiplicative`]; `PN_MG_SINGLE=0|1`. Unset or unparsable values leave
    /// the default. The
    /// command line passes the environment ([`crate::solver::SolverTuning::from_vars`]).
    pub fn from_vars(get: &dyn Fn(&str) -> Option<String>) -> Self {
        fn parse<T: std::str::FromStr>(
            get: &dyn Fn(&str) -> Option<String>,
            name: &str,
        ) -> Option<T> {
            get(name).and_then(|v| v.parse().ok())
        }
        let d = Self::default();
        Self {
            fine_degree: parse(get, "PN_MG_FINE_DEGREE").unwrap_or(d.fine_degree),
            fine_degree_nonsymmetric: parse(get, "PN_MG_FINE_DEGREE_NONSYMMETRIC")
                .or(parse(get, "PN_MG_FINE_DEGREE"))
                .unwrap_or(d.fine_degree_nonsymmetric),
            coarse_degree: parse(get, "PN_MG_COARSE_DEGREE").unwrap_or(d.coarse_degree),
            coarse_degree_2d: parse(get, "PN_MG_COARSE_DEGREE_2D").unwrap_or(d.coarse_degree_2d),
            ratio: parse(get, "PN_MG_RATIO").unwrap_or(d.ratio),
            fine_ratio: parse(get, "PN_MG_FINE_RATIO").unwrap_or(d.fine_ratio),
            power_steps: parse(get, "PN_MG_POWER_STEPS").unwrap_or(d.power_steps),
            coarse_max: parse(get, "PN_MG_COARSE_MAX").unwrap_or(d.coarse_max),
            correction_scale: parse(get, "PN_MG_SCALE").or(d.correction_scale),
            fine_cycle: match parse(get, "PN_MG_ADDITIVE").unwrap_or(f64::NAN) {
                w if w > 0.0 && w.is_finite() => FineCycle::Additive { omega: w },
                w if w.is_nan() || w < 0.0 || w.is_infinite() => d.fine_cycle,
                _ => FineCycle::Multiplicative,
            },
            single_fine: parse::<u8>(get, "PN_MG_SINGLE")
                .map(|v| v != 0)
                .or(d.single_fine),
            ..d
        }
    }

    /// The damped interval's ratio for a given degree: degree 1 (damped Jacobi) uses
    /// `[λ_max/2, λ_max]`, i.e. `ω = 4/(3λ_max)`, the classical smoothing weight.
    pub(super) fn ratio_for(&self, degree: usize) -> f64 {
        if degree <= 1 {
            2.0
        } else {
            self.ratio
        }
    }
}
