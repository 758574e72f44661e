//! Semi-analytic P_N solution for an isotropic point source in an infinite homogeneous medium.
//!
//! Method (`tests/data/pointsource/README.md`, docs/design.md §7). P_N is rotationally
//! invariant, so the 3D point-source fluence is `φ(r) = −(1/(2πr)) dφ_slab/dx |_{x=r}` of the
//! plane-source (slab) solution. All quantities are in mean free paths (σ_t = 1, σ_s = α).
//!
//! **Slab P_N.** With Legendre moments `u_l(x) = 2π ∫ L(x,μ) P_l(μ) dμ` (so `u_0` is the
//! fluence) and a unit-power isotropic plane source, projecting the slab RTE on `P_l` with
//! `μ P_l = ((l+1) P_{l+1} + l P_{l−1})/(2l+1)` gives
//!
//! ```text
//!     A u' + Σ u = δ(x) e_0,   A(l,l+1) = (l+1)/(2l+1),  A(l,l−1) = l/(2l+1),
//!                              Σ = diag(σ_l),  σ_l = 1 − α g^l  (Henyey–Greenstein),
//! ```
//! for l = 0…N, moments above N dropped.
//!
//! **Modes.** For x > 0 the bounded solution is `u(x) = Σ_j a_j v_j e^{−x/ν_j}` over the
//! generalized eigenpairs `A v = ν Σ v` with ν > 0. With `D = diag(2l+1)`, `S = D A` is
//! symmetric (`S(l,l+1) = l+1`) and `M = D Σ` is diagonal and positive, so with
//! `w = M^{1/2} v` the problem is the symmetric eigenproblem `B w = ν w`,
//! `B = M^{−1/2} S M^{−1/2}`. B only couples even l to odd l: with K the even-row/odd-column
//! block, `B = [[0, K], [Kᵀ, 0]]` and its eigenpairs are `±s_j`, `(u_j, ±v'_j)/√2` from the
//! singular value decomposition `K = U diag(s) Vᵀ`. So the decaying modes are exactly the
//! singular triplets of K: ν_j = s_j (all > 0, K is bidiagonal with non-zero entries), no
//! threshold on "ν > 0" is needed. K has ⌊N/2⌋+1 rows and ⌈N/2⌉ columns.
//!
//! **Jump conditions.** Parity `u_l(−x) = (−1)^l u_l(x)` makes the even moments continuous;
//! the odd moments jump by `d_l = 2 u_l(0⁺)`. The source gives `A (u⁺ − u⁻) = e_0`, whose odd
//! rows hold trivially and whose even rows fix d. For odd N that is a square system. For even N
//! A is singular with the even-parity null vector `n_l = P_l(0)` (from the odd rows of `A n = 0`:
//! `n_{l+1} = −l/(l+1) n_{l−1}`), and the solution carries a term `c n δ(x)`: it adds `c Σ n`
//! to the even rows, making the system square again with unknowns (d, c). Then
//! `Σ_j a_j v_{l,j} = d_l/2` for odd l; V is orthogonal, so `a = Vᵀ M_odd^{1/2} d / 2`.
//!
//! **3D.** `φ(r) = Σ_j a_j v_{0,j} e^{−r/ν_j}/(2π ν_j r)`, hence in normalised form
//! `4πφ = Σ_j C_j e^{−κ_j τ}/τ` with `κ_j = 1/ν_j`, `C_j = 2 a_j v_{0,j}/ν_j`. The slab
//! δ-term `c n_0 δ(x)` is the plane integral of the 3D term `c n_0 δ³(x)`, so the δ weight in
//! normalised form is `W = 4π c n_0` (`4πφ/σ_t² ⊃ W δ³(τ)`).
//!
//! **Energy.** In an infinite medium every photon is absorbed: `σ_a ∫φ d³x = 1`, i.e.
//! `Σ_j C_j/κ_j² + W/(4π) = 1/(1−α)` (a check the tests use; it holds for every g).

use anyhow::{bail, ensure, Result};
use nalgebra::{DMatrix, DVector};
use std::f64::consts::PI;

use super::gaussian::{gaussian_3d, yukawa_gaussian};

/// Largest P_N order [`pn_point_source`] accepts (the decomposition is O(N³); beyond a few
/// dozen the modes with the largest κ are no longer resolved by any practical grid).
pub const MAX_ORDER: usize = 199;

/// The P_N point-source solution as a sum of modes, in normalised form:
///
/// ```text
///     4πφ/σ_t² = Σ_j coeff[j] · e^{−kappa[j] τ} / τ   +   delta_weight · δ³(τ),   τ = σ_t r.
/// ```
///
/// `delta_weight` is zero for odd N; for even N it is the weight of the δ the P_N solution
/// carries at the source (in world units the fluence contains `delta_weight/(4π σ_t) δ³(x)`).
#[derive(Debug, Clone, PartialEq)]
pub struct PointSourceModes {
    /// The P_N order N the modes belong to (1 for [`PointSourceModes::cda`]).
    pub order: usize,
    /// Single-scattering albedo α = σ_s/σ_t.
    pub albedo: f64,
    /// Henyey–Greenstein anisotropy g.
    pub g: f64,
    /// Decay rates κ_j (in units of σ_t), ascending.
    pub kappa: Vec<f64>,
    /// Mode coefficients C_j, in the same order as `kappa`.
    pub coeff: Vec<f64>,
    /// Weight W of the δ at the source (even N; 0 for odd N).
    pub delta_weight: f64,
}

/// Checks α ∈ [0,1) and g ∈ (−1,1): the infinite-medium solution needs absorption, and the
/// collision coefficients `1 − α g^l` must stay positive.
pub(crate) fn check_medium(albedo: f64, g: f64) -> Result<()> {
    ensure!(
        albedo.is_finite() && (0.0..1.0).contains(&albedo),
        "albedo must lie in [0, 1) for a point source in an infinite medium (got {albedo})"
    );
    ensure!(
        g.is_finite() && g > -1.0 && g < 1.0,
        "Henyey-Greenstein g must lie in (-1, 1) (got {g})"
    );
    Ok(())
}

/// Computes the modes of the P_N point-source solution for order `order` (0 ≤ N ≤
/// [`MAX_ORDER`]), albedo α ∈ [0,1) and Henyey–Greenstein g ∈ (−1,1). See the module
/// documentation for the method.
///
/// ```
/// let m = pn_runtime::reference::pn_point_source(1, 0.9, 0.0).unwrap();
/// assert!((m.kappa[0] - 0.3f64.sqrt()).abs() < 1e-12 && (m.coeff[0] - 3.0).abs() < 1e-12);
/// ```
pub fn pn_point_source(order: usize, albedo: f64, g: f64) -> Result<PointSourceModes> {
    if order > MAX_ORDER {
        bail!("P_N order {order} is too large for the reference solution (at most {MAX_ORDER})");
    }
    check_medium(albedo, g)?;
    let n = order;
    // Collision coefficients σ_l = 1 − α g^l (g^0 = 1) and M = diag((2l+1) σ_l).
    let sigma: Vec<f64> = (0..=n).map(|l| 1.0 - albedo * g.powi(l as i32)).collect();
    let m: Vec<f64> = (0..=n).map(|l| (2 * l + 1) as f64 * sigma[l]).collect();
    // A(l,l±1).
    let a_up = |l: usize| (l + 1) as f64 / (2 * l + 1) as f64; // A(l, l+1)
    let a_down = |l: usize| l as f64 / (2 * l + 1) as f64; // A(l, l-1)

    let n_even = n / 2 + 1;
    let n_odd = n.div_ceil(2);

    // Jump system on the even rows: Σ_k A(2i, 2k+1) d_{2k+1} (+ c σ_{2i} n_{2i}) = δ_{i0}.
    let mut jump = DMatrix::<f64>::zeros(n_even, n_even);
    for i in 0..n_even {
        let l = 2 * i;
        if l < n {
            jump[(i, i)] = a_up(l); // column k = i  ↔  odd index l+1
        }
        if l > 0 {
            jump[(i, i - 1)] = a_down(l); // column k = i−1  ↔  odd index l−1
        }
    }
    if n.is_multiple_of(2) {
        // Null vector of A (even parity): n_0 = 1, n_{l+1} = −l/(l+1) n_{l−1}, i.e. P_l(0).
        let mut null = 1.0;
        for i in 0..n_even {
            if i > 0 {
                let l = 2 * i - 1; // the odd row that links n_{l−1} and n_{l+1}
                null *= -(l as f64) / (l + 1) as f64;
            }
            jump[(i, n_odd)] = sigma[2 * i] * null;
        }
    }
    let mut rhs = DVector::<f64>::zeros(n_even);
    rhs[0] = 1.0;
    let sol = jump
        .lu()
        .solve(&rhs)
        .ok_or_else(|| anyhow::anyhow!("P_N jump conditions are singular (N = {n})"))?;
    // Slab δ coefficient c (n_0 = 1), in normalised 3D form W = 4π c.
    let delta_weight = if n.is_multiple_of(2) {
        4.0 * PI * sol[n_odd]
    } else {
        0.0
    };

    let mut modes: Vec<(f64, f64)> = Vec::with_capacity(n_odd);
    if n_odd > 0 {
        // K = even-row / odd-column block of B = M^{-1/2} S M^{-1/2}, S(l,l+1) = l+1.
        let mut k = DMatrix::<f64>::zeros(n_even, n_odd);
        for i in 0..n_even {
            let l = 2 * i;
            if l < n {
                k[(i, i)] = (l + 1) as f64 / (m[l] * m[l + 1]).sqrt();
            }
            if l > 0 {
                k[(i, i - 1)] = l as f64 / (m[l] * m[l - 1]).sqrt();
            }
        }
        let svd = k.svd(true, true);
        let (u, v_t) = match (svd.u, svd.v_t) {
            (Some(u), Some(v_t)) => (u, v_t),
            _ => bail!("SVD of the P_N transport block failed (N = {n})"),
        };
        for j in 0..n_odd {
            let nu = svd.singular_values[j];
            ensure!(
                nu > 0.0 && nu.is_finite(),
                "P_N eigenvalue {nu} is not positive (N = {n})"
            );
            // a_j = Σ_k V[k,j] sqrt(m_{2k+1}) d_{2k+1} / 2   (V orthogonal)
            let a: f64 = (0..n_odd)
                .map(|kk| v_t[(j, kk)] * m[2 * kk + 1].sqrt() * sol[kk])
                .sum::<f64>()
                / 2.0;
            // v_{0,j} = U[0,j] / sqrt(m_0)
            let v0 = u[(0, j)] / m[0].sqrt();
            modes.push((1.0 / nu, 2.0 * a * v0 / nu));
        }
    }
    modes.sort_by(|x, y| x.0.total_cmp(&y.0));
    Ok(PointSourceModes {
        order: n,
        albedo,
        g,
        kappa: modes.iter().map(|x| x.0).collect(),
        coeff: modes.iter().map(|x| x.1).collect(),
        delta_weight,
    })
}

impl PointSourceModes {
    /// The classical diffusion (CDA) solution as a single mode: `κ = √(3(1−α)(1−αg))`,
    /// `C = 3(1−αg)`. It is identical to [`pn_point_source`] with N = 1 (docs/design.md §2.2:
    /// eliminating the l = 1 moments of P_1 gives CDA with `σ_tr = σ_t(1 − αg)`); see
    /// [`crate::reference::cda_point_source`] for the derivation.
    pub fn cda(albedo: f64, g: f64) -> Result<Self> {
        check_medium(albedo, g)?;
        let s_tr = crate::problem::sigma_tr(1.0, albedo, g);
        Ok(Self {
            order: 1,
            albedo,
            g,
            kappa: vec![(3.0 * (1.0 - albedo) * s_tr).sqrt()],
            coeff: vec![3.0 * s_tr],
            delta_weight: 0.0,
        })
    }

    /// Normalised fluence `4πφ/σ_t²` at optical distance `tau = σ_t r` from the source (the
    /// smooth part: the even-N δ at τ = 0 is not included). Radial: the sign of `tau` is
    /// ignored; it is +∞ at τ = 0.
    pub fn fluence(&self, tau: f64) -> f64 {
        let tau = tau.abs();
        self.kappa
            .iter()
            .zip(&self.coeff)
            .map(|(k, c)| c * (-k * tau).exp())
            .sum::<f64>()
            / tau
    }

    /// Normalised fluence for a unit-power source whose profile is a 3D Gaussian of standard
    /// deviation `s_tau` (per axis, in mean free paths: `s_tau = σ_t s`), at optical distance
    /// `tau` from its centre: every mode `e^{−κτ}/τ` convolved with the Gaussian
    /// ([`yukawa_gaussian`]), and the even-N δ, which becomes the Gaussian itself. Finite
    /// everywhere, including τ = 0. `s_tau` must be > 0 (`s_tau = 0` gives [`Self::fluence`]).
    pub fn fluence_gaussian(&self, tau: f64, s_tau: f64) -> f64 {
        if s_tau == 0.0 {
            return self.fluence(tau);
        }
        let modes: f64 = self
            .kappa
            .iter()
            .zip(&self.coeff)
            .map(|(k, c)| c * yukawa_gaussian(tau, *k, s_tau))
            .sum();
        let delta = if self.delta_weight != 0.0 {
            self.delta_weight * gaussian_3d(tau, s_tau)
        } else {
            0.0
        };
        modes + delta
    }

    /// Fluence φ in world units at distance `r` from a unit-power point source in a medium of
    /// extinction `sigma_t`: `φ = σ_t²/(4π) · fluence(σ_t r)`.
    pub fn fluence_world(&self, r: f64, sigma_t: f64) -> f64 {
        sigma_t * sigma_t / (4.0 * PI) * self.fluence(sigma_t * r)
    }

    /// Fluence φ in world units at distance `r` from the centre of a unit-power source with a
    /// Gaussian profile of standard deviation `s` (world units) in a medium of extinction
    /// `sigma_t`: `φ = σ_t²/(4π) · fluence_gaussian(σ_t r, σ_t s)` (the convolution commutes
    /// with the scaling τ = σ_t x, docs/design.md §7).
    pub fn fluence_gaussian_world(&self, r: f64, s: f64, sigma_t: f64) -> f64 {
        sigma_t * sigma_t / (4.0 * PI) * self.fluence_gaussian(sigma_t * r, sigma_t * s)
    }

    /// The fluence integrated over all space for σ_t = 1, `∫ φ d³τ = Σ_j C_j/κ_j² + W/(4π)`.
    /// Energy conservation in an infinite medium (`σ_a ∫ φ d³x = 1`) makes it `1/(1−α)`.
    pub fn integrated_fluence(&self) -> f64 {
        self.kappa
            .iter()
            .zip(&self.coeff)
            .map(|(k, c)| c / (k * k))
            .sum::<f64>()
            + self.delta_weight / (4.0 * PI)
    }
}
