//! Phase functions: the angular distribution of a scattering event (docs/design.md §2.1).
//!
//! Every phase function here is rotationally symmetric and normalised over the sphere,
//! `∫ p(ω·ω') dω' = 2π ∫_{−1}^{1} p(μ) dμ = 1`, with μ the cosine between the incoming
//! **travel** direction and the outgoing one (μ = 1: forward, no deflection). The P_N
//! equations read it through its Funk–Hecke factors
//!
//! ```text
//! λ_l p_l = 2π ∫_{−1}^{1} p(μ) P_l(μ) dμ        (λ_l p_l = g^l for Henyey–Greenstein),
//! ```
//!
//! which [`Phase::moment`] returns for any l: in closed form for Henyey–Greenstein, its
//! two-lobe blend and the droplet phase (the Draine lobe's factors follow from the HG ones
//! by the Legendre recurrence, below), by Gauss–Legendre quadrature that is exact on each
//! interval of a tabulated phase.
//!
//! [`Phase::delta_m`] gives the delta-M truncation of a phase for a P_N solve of order N
//! (Wiscombe 1977): the forward peak `f = λ_{N+1} p_{N+1}` is split off as a delta in the
//! forward direction, and the rest, renormalised, keeps the factors
//! `(λ_l p_l − f)/(1 − f)` for l ≤ N and none above. With σ_t′ = σ_t − f σ_s and
//! σ_s′ = (1 − f) σ_s the truncated medium has the same per-band extinction
//! σ_t′ − σ_s′ p′_l = σ_t − σ_s p_l for every l ≤ N, so the P_N operator is unchanged;
//! what changes is the light that counts as unscattered (it travels on through the peak),
//! see `pn_render::first_scatter`. As N → ∞, f → 0 and the truncation is the identity.

use pn_stencil::quadrature::{gauss_legendre, henyey_greenstein};
use std::f64::consts::PI;
use std::sync::Arc;

/// Bands of a tabulated phase whose factors are computed once, at construction.
const CACHED_BANDS: usize = 96;

/// Phase function (rotationally symmetric, normalised).
#[derive(Clone, Debug, PartialEq)]
pub enum Phase {
    /// p = 1/(4π): λ_0 p_0 = 1, all other bands 0.
    Isotropic,
    /// Henyey–Greenstein with parameter g: λ_l p_l = g^l (docs/design.md §2.1).
    HenyeyGreenstein(f64),
    /// A blend of two Henyey–Greenstein lobes, `(1 − weight) HG(g1) + weight HG(g2)`
    /// (Mitsuba's `blendphase` of two `hg`: `weight` is the second lobe's share).
    TwoTermHg {
        /// First lobe's g.
        g1: f64,
        /// Second lobe's g.
        g2: f64,
        /// Second lobe's share, in [0, 1].
        weight: f64,
    },
    /// Values over μ = cos θ, linear between the nodes (Mitsuba's `tabphase` on its
    /// regular grid; here the nodes may be irregular).
    Tabulated(Arc<TabulatedPhase>),
    /// The cloud-droplet phase of Jendersie & d'Eon 2023 ("An Approximate Mie Scattering
    /// Function for Fog and Cloud Rendering"): a blend of a Henyey–Greenstein and a Draine
    /// lobe whose parameters are fitted functions of the droplet diameter.
    Droplet(DropletPhase),
    /// The delta-M truncation of another phase for a P_N solve of order `order`
    /// ([`Phase::delta_m`]); it has factors up to `order` only.
    DeltaM(Arc<DeltaMPhase>),
}

/// Why a phase function cannot be built; the message names the offending parameter.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
#[error("{0}")]
pub struct PhaseError(pub String);

fn err<T>(msg: String) -> Result<T, PhaseError> {
    Err(PhaseError(msg))
}

/// The Draine phase value (Draine 2003), normalised over the sphere:
/// `HG(g; μ) (1 + α μ²) / (1 + α (1 + 2g²)/3)`.
pub fn draine(g: f64, alpha: f64, mu: f64) -> f64 {
    henyey_greenstein(g, mu) * (1.0 + alpha * mu * mu) / (1.0 + alpha * (1.0 + 2.0 * g * g) / 3.0)
}

/// λ_l p_l of the Draine phase: with h_k = g^k (the HG factors) and the recurrence
/// `μ P_k = ((k+1) P_{k+1} + k P_{k−1})/(2k+1)`, `2π∫ HG μ P_k dμ = ((k+1) g^{k+1} + k g^{k−1})/(2k+1)`
/// and `2π∫ HG μ² P_l dμ` follows by applying the recurrence once more.
pub fn draine_moment(g: f64, alpha: f64, l: u32) -> f64 {
    let h = |k: i64| if k < 0 { 0.0 } else { g.powi(k as i32) };
    let mu_moment = |k: i64| {
        if k < 0 {
            return 0.0;
        }
        let kf = k as f64;
        ((kf + 1.0) * h(k + 1) + kf * h(k - 1)) / (2.0 * kf + 1.0)
    };
    let l = l as i64;
    let lf = l as f64;
    let mu2 = ((lf + 1.0) * mu_moment(l + 1) + lf * mu_moment(l - 1)) / (2.0 * lf + 1.0);
    (h(l) + alpha * mu2) / (1.0 + alpha * (1.0 + 2.0 * g * g) / 3.0)
}

/// Legendre polynomials P_0..=P_lmax at μ.
fn legendre(lmax: usize, mu: f64, out: &mut Vec<f64>) {
    out.clear();
    out.push(1.0);
    if lmax >= 1 {
        out.push(mu);
    }
    for l in 2..=lmax {
        let lf = l as f64;
        let p = ((2.0 * lf - 1.0) * mu * out[l - 1] - (lf - 1.0) * out[l - 2]) / lf;
        out.push(p);
    }
}

/// A phase function tabulated over μ = cos θ (θ = 0: forward), linear between the nodes.
#[derive(Clone, Debug, PartialEq)]
pub struct TabulatedPhase {
    mu: Vec<f64>,
    values: Vec<f64>,
    /// The factor the given values were multiplied by to normalise them (1: they were).
    normalisation: f64,
    /// λ_l p_l for l < [`CACHED_BANDS`].
    moments: Vec<f64>,
}

impl TabulatedPhase {
    /// A table of `values` at the cosines `mu` (strictly increasing from −1 to 1), or on a
    /// regular grid over [−1, 1] when `mu` is `None` (Mitsuba's `tabphase`). Values must be
    /// finite and non-negative, at least two, not all zero; they are normalised
    /// ([`TabulatedPhase::normalisation`] says by what).
    pub fn new(mu: Option<Vec<f64>>, values: Vec<f64>) -> Result<Self, PhaseError> {
        if values.len() < 2 {
            return err(format!(
                "a tabulated phase needs at least two values, got {}",
                values.len()
            ));
        }
        if let Some((i, v)) = values
            .iter()
            .enumerate()
            .find(|(_, v)| !v.is_finite() || **v < 0.0)
        {
            return err(format!(
                "tabulated phase: values[{i}] = {v} (values must be finite and non-negative)"
            ));
        }
        let n = values.len();
        let mu = match mu {
            None => (0..n)
                .map(|i| -1.0 + 2.0 * i as f64 / (n - 1) as f64)
                .collect(),
            Some(mu) => {
                if mu.len() != n {
                    return err(format!(
                        "tabulated phase: {} cosines for {} values",
                        mu.len(),
                        n
                    ));
                }
                if let Some((i, m)) = mu.iter().enumerate().find(|(_, m)| !m.is_finite()) {
                    return err(format!("tabulated phase: cos_theta[{i}] = {m}"));
                }
                if let Some(i) = (1..n).find(|&i| mu[i] <= mu[i - 1]) {
                    return err(format!(
                        "tabulated phase: the angles must be sorted, cos_theta strictly increasing \
                         from -1 to 1, but cos_theta[{}] = {} follows {}",
                        i,
                        mu[i],
                        mu[i - 1]
                    ));
                }
                if (mu[0] + 1.0).abs() > 1e-9 || (mu[n - 1] - 1.0).abs() > 1e-9 {
                    return err(format!(
                        "tabulated phase: cos_theta must run from -1 to 1 (the whole sphere), got \
                         {} to {}",
                        mu[0],
                        mu[n - 1]
                    ));
                }
                let mut mu = mu;
                mu[0] = -1.0;
                mu[n - 1] = 1.0;
                mu
            }
        };
        // 2π ∫ p dμ with the trapezoid rule, exact for the piecewise-linear table.
        let integral: f64 = 2.0
            * PI
            * (1..n)
                .map(|i| 0.5 * (values[i] + values[i - 1]) * (mu[i] - mu[i - 1]))
                .sum::<f64>();
        if integral <= 0.0 {
            return err("tabulated phase: all values are zero".to_string());
        }
        let normalisation = 1.0 / integral;
        let values = values.iter().map(|v| v * normalisation).collect();
        let mut t = Self {
            mu,
            values,
            normalisation,
            moments: Vec::new(),
        };
        t.moments = t.compute_moments(CACHED_BANDS - 1);
        Ok(t)
    }

    /// The cosines of the nodes (−1 to 1).
    pub fn cos_theta(&self) -> &[f64] {
        &self.mu
    }

    /// The normalised values at the nodes.
    pub fn values(&self) -> &[f64] {
        &self.values
    }

    /// What the given values were multiplied by to normalise them (1 if they were).
    pub fn normalisation(&self) -> f64 {
        self.normalisation
    }

    /// Whether the nodes lie on a regular grid (Mitsuba's `tabphase` takes such a table).
    pub fn is_regular(&self) -> bool {
        let n = self.mu.len();
        let h = 2.0 / (n - 1) as f64;
        self.mu
            .iter()
            .enumerate()
            .all(|(i, m)| (m - (-1.0 + h * i as f64)).abs() < 1e-9)
    }

    /// The normalised value at μ (linear between the nodes).
    pub fn value(&self, mu: f64) -> f64 {
        let mu = mu.clamp(-1.0, 1.0);
        let i = self
            .mu
            .partition_point(|m| *m <= mu)
            .clamp(1, self.mu.len() - 1);
        let (a, b) = (self.mu[i - 1], self.mu[i]);
        let t = (mu - a) / (b - a);
        self.values[i - 1] * (1.0 - t) + self.values[i] * t
    }

    /// λ_l p_l.
    pub fn moment(&self, l: u32) -> f64 {
        match self.moments.get(l as usize) {
            Some(m) => *m,
            None => self.compute_moments(l as usize)[l as usize],
        }
    }

    /// λ_l p_l for l ≤ lmax: Gauss–Legendre on every interval with enough nodes to be
    /// exact for the polynomial (linear × P_l) of degree lmax + 1.
    fn compute_moments(&self, lmax: usize) -> Vec<f64> {
        let nodes = lmax / 2 + 2;
        let (x, w) = gauss_legendre(nodes);
        let mut out = vec![0.0; lmax + 1];
        let mut p = Vec::with_capacity(lmax + 1);
        for i in 1..self.mu.len() {
            let (a, b) = (self.mu[i - 1], self.mu[i]);
            let (va, vb) = (self.values[i - 1], self.values[i]);
            for (xk, wk) in x.iter().zip(&w) {
                let t = 0.5 * (xk + 1.0);
                let mu = a + t * (b - a);
                let v = va + t * (vb - va);
                legendre(lmax, mu, &mut p);
                let weight = 2.0 * PI * wk * 0.5 * (b - a) * v;
                for (o, pl) in out.iter_mut().zip(&p) {
                    *o += weight * pl;
                }
            }
        }
        out
    }
}

/// Droplet diameters (µm) over which Jendersie & d'Eon's fit for large droplets holds.
pub const DROPLET_DIAMETER_RANGE: (f64, f64) = (5.0, 50.0);

/// The HG + Draine cloud-droplet phase of Jendersie & d'Eon 2023 for droplets of diameter
/// d ∈ [5, 50] µm: `(1 − w_D) HG(g_HG) + w_D Draine(g_D, α)` with (their eq. for
/// 5 µm ≤ d ≤ 50 µm)
///
/// ```text
/// g_HG = exp(−0.0990567/(d − 1.67154)),   g_D = exp(−2.20679/(d + 3.91029) − 0.428934),
/// α = exp(3.62489 − 8.29288/(d + 5.52825)), w_D = exp(−0.599085/(d − 0.641583) − 0.665888).
/// ```
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DropletPhase {
    /// Droplet diameter in µm.
    pub diameter: f64,
    /// The HG lobe's g.
    pub g_hg: f64,
    /// The Draine lobe's g.
    pub g_draine: f64,
    /// The Draine lobe's α.
    pub alpha: f64,
    /// The Draine lobe's share.
    pub w_draine: f64,
}

impl DropletPhase {
    /// The fit's parameters for droplets of `diameter` µm.
    pub fn new(diameter: f64) -> Result<Self, PhaseError> {
        let (lo, hi) = DROPLET_DIAMETER_RANGE;
        if !(diameter.is_finite() && (lo..=hi).contains(&diameter)) {
            return err(format!(
                "droplet diameter must lie in [{lo}, {hi}] µm (the range of Jendersie & d'Eon's \
                 fit), got {diameter}"
            ));
        }
        let d = diameter;
        Ok(Self {
            diameter,
            g_hg: (-0.0990567 / (d - 1.67154)).exp(),
            g_draine: (-2.20679 / (d + 3.91029) - 0.428934).exp(),
            alpha: (3.62489 - 8.29288 / (d + 5.52825)).exp(),
            w_draine: (-0.599085 / (d - 0.641583) - 0.665888).exp(),
        })
    }

    /// The normalised value at μ.
    pub fn value(&self, mu: f64) -> f64 {
        (1.0 - self.w_draine) * henyey_greenstein(self.g_hg, mu)
            + self.w_draine * draine(self.g_draine, self.alpha, mu)
    }

    /// λ_l p_l.
    pub fn moment(&self, l: u32) -> f64 {
        (1.0 - self.w_draine) * self.g_hg.powi(l as i32)
            + self.w_draine * draine_moment(self.g_draine, self.alpha, l)
    }
}

/// The delta-M truncation of a phase function ([`Phase::delta_m`]).
#[derive(Clone, Debug, PartialEq)]
pub struct DeltaMPhase {
    /// The phase that was truncated.
    pub full: Phase,
    /// The forward peak's share f = λ_{N+1} p_{N+1} of the full phase.
    pub f: f64,
    /// The P_N order N: the truncated phase has factors l ≤ N.
    pub order: u32,
}

impl Phase {
    /// A Henyey–Greenstein phase, checked.
    pub fn hg(g: f64) -> Result<Self, PhaseError> {
        check_g("g", g)?;
        Ok(Phase::HenyeyGreenstein(g))
    }

    /// A two-lobe Henyey–Greenstein blend, checked.
    pub fn two_term_hg(g1: f64, g2: f64, weight: f64) -> Result<Self, PhaseError> {
        check_g("g1", g1)?;
        check_g("g2", g2)?;
        if !(weight.is_finite() && (0.0..=1.0).contains(&weight)) {
            return err(format!(
                "two-term HG: weight must lie in [0, 1], got {weight}"
            ));
        }
        Ok(Phase::TwoTermHg { g1, g2, weight })
    }

    /// The Funk–Hecke factor λ_l p_l.
    pub fn moment(&self, l: u32) -> f64 {
        match self {
            Phase::Isotropic => {
                if l == 0 {
                    1.0
                } else {
                    0.0
                }
            }
            Phase::HenyeyGreenstein(g) => g.powi(l as i32),
            Phase::TwoTermHg { g1, g2, weight } => {
                (1.0 - weight) * g1.powi(l as i32) + weight * g2.powi(l as i32)
            }
            Phase::Tabulated(t) => t.moment(l),
            Phase::Droplet(d) => d.moment(l),
            Phase::DeltaM(t) => {
                if l > t.order {
                    0.0
                } else {
                    (t.full.moment(l) - t.f) / (1.0 - t.f)
                }
            }
        }
    }

    /// The normalised value p(μ) for the cosine μ between the incoming travel direction and
    /// the outgoing direction. For a [`Phase::DeltaM`] truncation: its Legendre series.
    pub fn value(&self, mu: f64) -> f64 {
        let mu = mu.clamp(-1.0, 1.0);
        match self {
            Phase::Isotropic => 1.0 / (4.0 * PI),
            Phase::HenyeyGreenstein(g) => henyey_greenstein(*g, mu),
            Phase::TwoTermHg { g1, g2, weight } => {
                (1.0 - weight) * henyey_greenstein(*g1, mu) + weight * henyey_greenstein(*g2, mu)
            }
            Phase::Tabulated(t) => t.value(mu),
            Phase::Droplet(d) => d.value(mu),
            Phase::DeltaM(t) => {
                let mut p = Vec::new();
                legendre(t.order as usize, mu, &mut p);
                p.iter()
                    .enumerate()
                    .map(|(l, pl)| (2 * l + 1) as f64 / (4.0 * PI) * self.moment(l as u32) * pl)
                    .sum()
            }
        }
    }

    /// The mean cosine g = λ_1 p_1.
    pub fn mean_cosine(&self) -> f64 {
        self.moment(1)
    }

    /// Whether every band above 0 vanishes.
    pub fn is_isotropic(&self) -> bool {
        match self {
            Phase::Isotropic => true,
            Phase::HenyeyGreenstein(g) => *g == 0.0,
            Phase::TwoTermHg { g1, g2, .. } => *g1 == 0.0 && *g2 == 0.0,
            _ => (1..8).all(|l| self.moment(l) == 0.0),
        }
    }

    /// The forward-peak share `f = λ_{N+1} p_{N+1}` that delta-M truncation for a P_N solve
    /// of order N splits off, clamped to [0, 1) (a negative factor, as a back-scattering
    /// phase has at odd l, splits off nothing).
    pub fn delta_m_fraction(&self, order: u32) -> f64 {
        self.moment(order + 1).clamp(0.0, 1.0 - 1e-9)
    }

    /// The delta-M truncation for a P_N solve of order `order` and its forward-peak share f;
    /// `(self, 0)` when f = 0 (isotropic scattering: the identity).
    pub fn delta_m(&self, order: u32) -> (Phase, f64) {
        let f = self.delta_m_fraction(order);
        if f == 0.0 {
            return (self.clone(), 0.0);
        }
        (
            Phase::DeltaM(Arc::new(DeltaMPhase {
                full: self.clone(),
                f,
                order,
            })),
            f,
        )
    }

    /// Checks the parameters (for phases built directly rather than through the checked
    /// constructors).
    pub fn validate(&self) -> Result<(), PhaseError> {
        match self {
            Phase::Isotropic | Phase::Tabulated(_) | Phase::DeltaM(_) => Ok(()),
            Phase::HenyeyGreenstein(g) => check_g("g", *g),
            Phase::TwoTermHg { g1, g2, weight } => {
                Phase::two_term_hg(*g1, *g2, *weight).map(|_| ())
            }
            Phase::Droplet(d) => DropletPhase::new(d.diameter).map(|_| ()),
        }
    }

    /// A short description for reports: `isotropic`, `hg(g=0.8)`, ….
    pub fn describe(&self) -> String {
        match self {
            Phase::Isotropic => "isotropic".into(),
            Phase::HenyeyGreenstein(g) => format!("hg(g={g})"),
            Phase::TwoTermHg { g1, g2, weight } => {
                format!("two-term hg(g1={g1}, g2={g2}, weight={weight})")
            }
            Phase::Tabulated(t) => {
                format!("tabulated({} values, g={:.4})", t.mu.len(), t.moment(1))
            }
            Phase::Droplet(d) => format!(
                "droplet(d={} µm: g_HG={:.4}, g_D={:.4}, α={:.2}, w_D={:.4}; g={:.4})",
                d.diameter,
                d.g_hg,
                d.g_draine,
                d.alpha,
                d.w_draine,
                self.mean_cosine()
            ),
            Phase::DeltaM(t) => format!(
                "delta-M(f={:.4}, N={}) of {}",
                t.f,
                t.order,
                t.full.describe()
            ),
        }
    }
}

fn check_g(name: &str, g: f64) -> Result<(), PhaseError> {
    if g.is_finite() && g.abs() < 1.0 {
        Ok(())
    } else {
        err(format!(
            "Henyey–Greenstein {name} must satisfy |{name}| < 1, got {g}"
        ))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// λ_l p_l by brute-force quadrature of the value (many Gauss–Legendre nodes on pieces
    /// graded towards the forward peak): the reference for the closed forms.
    fn quadrature_moment(p: &Phase, l: usize) -> f64 {
        let (x, w) = gauss_legendre(64);
        // Pieces [-1, 1 - 2^-k] ... graded so that a peak of width 1 - g ~ 1e-3 is resolved.
        let mut breaks = vec![-1.0, 0.0, 0.5];
        let mut e = 0.5;
        for _ in 0..20 {
            e *= 0.5;
            breaks.push(1.0 - e);
        }
        breaks.push(1.0);
        let mut s = 0.0;
        let mut leg = Vec::new();
        for ab in breaks.windows(2) {
            let (a, b) = (ab[0], ab[1]);
            for (xk, wk) in x.iter().zip(&w) {
                let mu = a + 0.5 * (xk + 1.0) * (b - a);
                legendre(l, mu, &mut leg);
                s += 2.0 * PI * wk * 0.5 * (b - a) * p.value(mu) * leg[l];
            }
        }
        s
    }

    #[test]
    fn closed_form_moments_match_quadrature() {
        let phases = [
            Phase::HenyeyGreenstein(0.877),
            Phase::two_term_hg(0.9, -0.3, 0.2).unwrap(),
            Phase::Droplet(DropletPhase::new(5.0).unwrap()),
            Phase::Droplet(DropletPhase::new(20.0).unwrap()),
            Phase::Droplet(DropletPhase::new(50.0).unwrap()),
        ];
        for p in &phases {
            for l in [0usize, 1, 2, 3, 5, 8, 13, 21] {
                let q = quadrature_moment(p, l);
                let m = p.moment(l as u32);
                assert!(
                    (q - m).abs() < 1e-9 * (1.0 + m.abs()),
                    "{}: l = {l}: closed form {m} vs quadrature {q}",
                    p.describe()
                );
            }
        }
    }

    #[test]
    fn tabulated_moments_are_exact_for_the_linear_table() {
        // A table of HG(0.6) at 801 irregular nodes: its factors are those of the piecewise
        // linear interpolant, which brute-force quadrature of `value` reproduces, and close
        // to g^l (the interpolation error of the table).
        let n = 801;
        let mu: Vec<f64> = (0..n)
            .map(|i| {
                let t = i as f64 / (n - 1) as f64;
                1.0 - 2.0 * (1.0 - t).powi(2)
            })
            .collect();
        let values: Vec<f64> = mu
            .iter()
            .map(|m| 3.0 * henyey_greenstein(0.6, *m))
            .collect();
        let t = TabulatedPhase::new(Some(mu.clone()), values).unwrap();
        assert!(
            (t.normalisation() - 1.0 / 3.0).abs() < 1e-4,
            "{}",
            t.normalisation()
        );
        let p = Phase::Tabulated(Arc::new(t));
        assert!((p.moment(0) - 1.0).abs() < 1e-12);
        // Reference: Simpson's rule on 32 sub-intervals of every table interval, reading
        // `value` (independent of the Gauss–Legendre path).
        let simpson = |l: usize| {
            let mut leg = Vec::new();
            let mut s = 0.0;
            for ab in mu.windows(2) {
                let k = 32;
                let h = (ab[1] - ab[0]) / k as f64;
                for j in 0..=k {
                    let x = ab[0] + h * j as f64;
                    let c = if j == 0 || j == k {
                        1.0
                    } else if j % 2 == 1 {
                        4.0
                    } else {
                        2.0
                    };
                    legendre(l, x, &mut leg);
                    s += 2.0 * PI * c * h / 3.0 * p.value(x) * leg[l];
                }
            }
            s
        };
        if let Phase::Tabulated(t) = &p {
            // Beyond the cached bands: computed on demand, the same as with more nodes.
            assert!((t.moment(100) - t.compute_moments(130)[100]).abs() < 1e-14);
        }
        for l in [1usize, 2, 4, 9, 30, 60] {
            let q = simpson(l);
            assert!(
                (q - p.moment(l as u32)).abs() < 1e-8,
                "l = {l}: {q} vs {}",
                p.moment(l as u32)
            );
        }
        for l in 1..6u32 {
            assert!(
                (p.moment(l) - 0.6f64.powi(l as i32)).abs() < 2e-4,
                "l = {l}"
            );
        }
    }

    #[test]
    fn tabulated_regular_grid_is_mitsubas_tabphase() {
        let t = TabulatedPhase::new(None, vec![1.0, 1.0, 1.0]).unwrap();
        assert!(t.is_regular());
        assert!((t.value(0.3) - 1.0 / (4.0 * PI)).abs() < 1e-15);
        assert!((Phase::Tabulated(Arc::new(t)).moment(1)).abs() < 1e-15);
    }

    #[test]
    fn droplet_fit_values() {
        // Jendersie & d'Eon's fit at d = 10 µm: g_HG ≈ 0.9915, a strongly forward droplet
        // phase whose mean cosine lies near the 0.85-0.88 of cloud droplets.
        let d = DropletPhase::new(10.0).unwrap();
        assert!((d.g_hg - (-0.0990567f64 / (10.0 - 1.67154)).exp()).abs() < 1e-15);
        let g = Phase::Droplet(d).mean_cosine();
        assert!((0.8..0.9).contains(&g), "mean cosine {g}");
        assert!((Phase::Droplet(d).moment(0) - 1.0).abs() < 1e-12);
    }

    #[test]
    fn bad_parameters_are_named() {
        assert!(Phase::hg(1.0).unwrap_err().0.contains("|g| < 1"));
        assert!(Phase::hg(f64::NAN).is_err());
        assert!(Phase::two_term_hg(0.5, 0.2, 1.5)
            .unwrap_err()
            .0
            .contains("weight"));
        assert!(Phase::two_term_hg(0.5, -1.2, 0.5)
            .unwrap_err()
            .0
            .contains("g2"));
        assert!(DropletPhase::new(2.0).unwrap_err().0.contains("diameter"));
        assert!(TabulatedPhase::new(None, vec![1.0])
            .unwrap_err()
            .0
            .contains("two"));
        assert!(TabulatedPhase::new(None, vec![1.0, -1.0])
            .unwrap_err()
            .0
            .contains("values[1]"));
        assert!(TabulatedPhase::new(None, vec![1.0, f64::NAN]).is_err());
        assert!(
            TabulatedPhase::new(Some(vec![-1.0, 0.5, 0.2, 1.0]), vec![1.0; 4])
                .unwrap_err()
                .0
                .contains("sorted")
        );
        assert!(TabulatedPhase::new(None, vec![0.0, 0.0]).is_err());
    }

    #[test]
    fn delta_m_keeps_the_low_bands_per_unit_extinction_and_is_the_identity_for_isotropic() {
        let p = Phase::HenyeyGreenstein(0.85);
        let (t, f) = p.delta_m(5);
        assert!((f - 0.85f64.powi(6)).abs() < 1e-15);
        // σ_t' − σ_s' p'_l = σ_t − σ_s p_l for l ≤ N (σ_t = 1, σ_s = 0.9).
        let (st, ss) = (1.0, 0.9);
        for l in 0..=5 {
            let lhs = (st - f * ss) - (1.0 - f) * ss * t.moment(l);
            let rhs = st - ss * p.moment(l);
            assert!((lhs - rhs).abs() < 1e-14, "l = {l}");
        }
        assert_eq!(t.moment(6), 0.0);
        assert_eq!(Phase::Isotropic.delta_m(3), (Phase::Isotropic, 0.0));
        assert_eq!(Phase::HenyeyGreenstein(0.0).delta_m(3).1, 0.0);
        // A back-scattering lobe has a negative odd factor: nothing is split off.
        assert_eq!(Phase::HenyeyGreenstein(-0.5).delta_m(2).1, 0.0);
    }

    #[test]
    fn values_integrate_to_one() {
        for p in [
            Phase::Isotropic,
            Phase::HenyeyGreenstein(0.9),
            Phase::two_term_hg(0.8, -0.4, 0.3).unwrap(),
            Phase::Droplet(DropletPhase::new(15.0).unwrap()),
        ] {
            assert!(
                (quadrature_moment(&p, 0) - 1.0).abs() < 1e-9,
                "{}",
                p.describe()
            );
        }
    }
}
