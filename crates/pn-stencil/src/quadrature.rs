//! Numerical quadrature on the sphere and real spherical harmonics — the independent
//! check of the derivation (docs/design.md §2.3).
//!
//! * [`gauss_legendre`]: nodes and weights on [−1, 1] (exact for polynomials of degree
//!   ≤ 2n−1);
//! * [`real_sh`]: the real basis of docs/design.md §2 (no Condon–Shortley phase left over);
//! * [`SphereQuadrature`]: Gauss–Legendre in cos θ × uniform in φ; with `n_mu > d/2` and
//!   `n_phi > d` nodes it integrates every polynomial of degree ≤ d in ω exactly;
//! * [`transport_matrices`]: `M^d_{(l,m),(l',m')} = ∫ ω_d Y_l^m Y_{l'}^{m'} dω`;
//! * [`phase_moments`]: `λ_l p_l = 2π ∫ p(μ) P_l(μ) dμ` of a phase function, and the
//!   [`henyey_greenstein`] phase function.

use std::f64::consts::PI;

/// Gauss–Legendre nodes and weights on [−1, 1] (Newton iteration on P_n).
pub fn gauss_legendre(n: usize) -> (Vec<f64>, Vec<f64>) {
    let mut x = vec![0.0; n];
    let mut w = vec![0.0; n];
    for i in 0..n {
        let mut z = (PI * (i as f64 + 0.75) / (n as f64 + 0.5)).cos();
        let mut dp = 0.0;
        for _ in 0..100 {
            let (p, d) = legendre_and_derivative(n, z);
            dp = d;
            let dz = p / d;
            z -= dz;
            if dz.abs() < 1e-16 {
                break;
            }
        }
        let (_, d) = legendre_and_derivative(n, z);
        dp = if d != 0.0 { d } else { dp };
        x[i] = z;
        w[i] = 2.0 / ((1.0 - z * z) * dp * dp);
    }
    (x, w)
}

fn legendre_and_derivative(n: usize, z: f64) -> (f64, f64) {
    let (mut p0, mut p1) = (1.0, z);
    if n == 0 {
        return (1.0, 0.0);
    }
    for k in 2..=n {
        let p2 = ((2 * k - 1) as f64 * z * p1 - (k - 1) as f64 * p0) / k as f64;
        p0 = p1;
        p1 = p2;
    }
    let d = n as f64 * (z * p1 - p0) / (z * z - 1.0);
    (p1, d)
}

/// Legendre polynomial P_l(μ).
pub fn legendre(l: usize, mu: f64) -> f64 {
    legendre_and_derivative(l, mu).0
}

/// Associated Legendre function P_l^m(μ), m ≥ 0, **without** the Condon–Shortley phase.
pub fn assoc_legendre(l: usize, m: usize, mu: f64) -> f64 {
    if m > l {
        return 0.0;
    }
    let s = (1.0 - mu * mu).max(0.0).sqrt();
    let mut pmm = 1.0;
    for k in 1..=m {
        pmm *= (2 * k - 1) as f64 * s;
    }
    if l == m {
        return pmm;
    }
    let mut pm1 = mu * (2 * m + 1) as f64 * pmm;
    if l == m + 1 {
        return pm1;
    }
    let mut pm0 = pmm;
    for ll in (m + 2)..=l {
        let p = ((2 * ll - 1) as f64 * mu * pm1 - (ll + m - 1) as f64 * pm0) / (ll - m) as f64;
        pm0 = pm1;
        pm1 = p;
    }
    pm1
}

/// Real spherical harmonic `Y_l^m` of docs/design.md §2 at direction (cos θ = `mu`, φ = `phi`).
pub fn real_sh(l: usize, m: i64, mu: f64, phi: f64) -> f64 {
    let am = m.unsigned_abs() as usize;
    // (l−|m|)!/(l+|m|)! as a product, no overflow
    let mut ratio = 1.0;
    for k in (l - am + 1)..=(l + am) {
        ratio /= k as f64;
    }
    let k = ((2 * l + 1) as f64 / (4.0 * PI) * ratio).sqrt();
    let p = assoc_legendre(l, am, mu);
    match m {
        0 => k * p,
        m if m > 0 => 2f64.sqrt() * k * p * (am as f64 * phi).cos(),
        _ => 2f64.sqrt() * k * p * (am as f64 * phi).sin(),
    }
}

/// A product quadrature on the unit sphere.
pub struct SphereQuadrature {
    /// Directions (ω_x, ω_y, ω_z) with their (μ, φ).
    pub points: Vec<([f64; 3], f64, f64)>,
    /// Weights (sum 4π).
    pub weights: Vec<f64>,
}

impl SphereQuadrature {
    /// Gauss–Legendre with `n_mu` nodes in μ = cos θ times `n_phi` uniform nodes in φ.
    pub fn new(n_mu: usize, n_phi: usize) -> SphereQuadrature {
        let (mus, ws) = gauss_legendre(n_mu);
        let mut points = Vec::with_capacity(n_mu * n_phi);
        let mut weights = Vec::with_capacity(n_mu * n_phi);
        for (mu, w) in mus.iter().zip(&ws) {
            let s = (1.0 - mu * mu).sqrt();
            for j in 0..n_phi {
                let phi = 2.0 * PI * (j as f64 + 0.5) / n_phi as f64;
                points.push(([s * phi.cos(), s * phi.sin(), *mu], *mu, phi));
                weights.push(w * 2.0 * PI / n_phi as f64);
            }
        }
        SphereQuadrature { points, weights }
    }

    /// A rule exact for polynomials in ω of degree ≤ `degree`.
    pub fn exact_for_degree(degree: usize) -> SphereQuadrature {
        SphereQuadrature::new(degree / 2 + 1, degree + 1)
    }
}

/// Number of real moments up to order N.
pub fn moment_count(order: usize) -> usize {
    (order + 1) * (order + 1)
}

/// `M^d_{(l,m),(l',m')} = ∫ ω_d Y_l^m Y_{l'}^{m'} dω` for d = x, y, z, indexed by the
/// moment index l(l+1)+m (dense, `moment_count(order)²` each).
pub fn transport_matrices(order: usize) -> [Vec<Vec<f64>>; 3] {
    let n = moment_count(order);
    let quad = SphereQuadrature::exact_for_degree(2 * order + 1);
    let mut y = vec![vec![0.0; quad.points.len()]; n];
    for l in 0..=order {
        for m in -(l as i64)..=(l as i64) {
            let row = &mut y[(l as i64 * (l as i64 + 1) + m) as usize];
            for (q, (_, mu, phi)) in quad.points.iter().enumerate() {
                row[q] = real_sh(l, m, *mu, *phi);
            }
        }
    }
    let mut out: [Vec<Vec<f64>>; 3] = std::array::from_fn(|_| vec![vec![0.0; n]; n]);
    for (d, mat) in out.iter_mut().enumerate() {
        for i in 0..n {
            for j in 0..n {
                let mut s = 0.0;
                for (q, (dir, _, _)) in quad.points.iter().enumerate() {
                    s += quad.weights[q] * dir[d] * y[i][q] * y[j][q];
                }
                mat[i][j] = s;
            }
        }
    }
    out
}

/// `λ_l p_l = 2π ∫_{−1}^{1} p(μ) P_l(μ) dμ` for l = 0..=lmax, by Gauss–Legendre with `n`
/// nodes (exact when p is a polynomial of degree ≤ 2n−1−lmax).
pub fn phase_moments(p: &dyn Fn(f64) -> f64, lmax: usize, n: usize) -> Vec<f64> {
    let (x, w) = gauss_legendre(n);
    (0..=lmax)
        .map(|l| {
            2.0 * PI
                * x.iter()
                    .zip(&w)
                    .map(|(mu, wi)| wi * p(*mu) * legendre(l, *mu))
                    .sum::<f64>()
        })
        .collect()
}

/// The Henyey–Greenstein phase function `(1−g²)/(4π (1+g²−2gμ)^{3/2})`, normalised to 1
/// over the sphere.
pub fn henyey_greenstein(g: f64, mu: f64) -> f64 {
    (1.0 - g * g) / (4.0 * PI * (1.0 + g * g - 2.0 * g * mu).powf(1.5))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn real_basis_is_orthonormal_and_matches_design() {
        let q = SphereQuadrature::exact_for_degree(8);
        for l in 0..=4usize {
            for m in -(l as i64)..=(l as i64) {
                for l2 in 0..=4usize {
                    for m2 in -(l2 as i64)..=(l2 as i64) {
                        let s: f64 = q
                            .points
                            .iter()
                            .zip(&q.weights)
                            .map(|((_, mu, phi), w)| {
                                w * real_sh(l, m, *mu, *phi) * real_sh(l2, m2, *mu, *phi)
                            })
                            .sum();
                        let want = if (l, m) == (l2, m2) { 1.0 } else { 0.0 };
                        assert!((s - want).abs() < 1e-13, "({l},{m}),({l2},{m2}): {s}");
                    }
                }
            }
        }
        // Y_1^{-1} = √(3/4π) ω_y, Y_1^0 = √(3/4π) ω_z, Y_1^1 = √(3/4π) ω_x
        let c = (3.0 / (4.0 * PI)).sqrt();
        let (mu, phi) = (0.3f64, 1.1f64);
        let s = (1.0 - mu * mu).sqrt();
        assert!((real_sh(1, -1, mu, phi) - c * s * phi.sin()).abs() < 1e-15);
        assert!((real_sh(1, 0, mu, phi) - c * mu).abs() < 1e-15);
        assert!((real_sh(1, 1, mu, phi) - c * s * phi.cos()).abs() < 1e-15);
    }

    #[test]
    fn isotropic_phase_moments() {
        let m = phase_moments(&|_| 1.0 / (4.0 * PI), 4, 8);
        assert!((m[0] - 1.0).abs() < 1e-14);
        for v in &m[1..] {
            assert!(v.abs() < 1e-14);
        }
    }
}
