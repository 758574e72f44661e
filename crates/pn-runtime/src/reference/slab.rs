//! The 1D P_N–Marshak references of `tests/data/marshak/README.md`: a slab with a normally
//! incident beam (reflection and transmission of the collided light) and the Milne problem
//! (extrapolation length), solved exactly for the 1D P_N equations by eigen-decomposition.
//!
//! Setting (plane geometry, σ_t = 1, isotropic scattering with albedo c): the angular flux
//! in Legendre form `ψ(x, μ) = Σ_l (2l+1)/2 φ_l(x) P_l(μ)` obeys the P_N equations
//! `A φ' + B φ = s e^{−x}` with `(Aφ')_l = ((l+1)φ'_{l+1} + l φ'_{l−1})/(2l+1)`,
//! `B = diag(1−c, 1, …, 1)` and `s = c e_0` (the scattered uncollided beam,
//! `S(x) = c e^{−x}/2` per unit μ). Scaling row l by (2l+1) makes the coupling symmetric,
//! `A'_{l,l+1} = A'_{l+1,l} = l+1`, `B' = diag((2l+1) B_ll)`. The modes `v e^{−λx}` solve
//! `B'v = λA'v`; with `B'` positive definite, `B'^{1/2} A'^{−1} B'^{1/2}` is symmetric, so
//! the λ are real (in ± pairs) and the eigenvectors come from a symmetric eigen-solver. The
//! general solution is the particular `p e^{−x}`, `(B' − A')p = s'`, plus the N+1 modes,
//! each normalised to 1 on the face it decays from; the N+1 constants are fixed by the
//! (N+1)/2 Marshak rows `∫_0^1 P_{2i−1} ψ(0, μ) dμ = 0` at x = 0 and their mirror
//! `∫_{−1}^0 P_{2i−1} ψ(τ, μ) dμ = 0` at x = τ.
//!
//! The Milne problem (half-space, c = 1) has the linear solution `φ_0 = x + z_0`,
//! `φ_1 = −1/3` (constant current out through x = 0) plus the (N−1)/2 modes decaying into
//! the medium; the (N+1)/2 Marshak rows at x = 0 fix their constants and z_0. The modes of
//! c = 1 are taken at `1 − c = 1e−12` (the two diffusion modes, λ ≈ ±√(3(1−c)), are then
//! far below the others and are left out; the others move by O(1e−12)).

use anyhow::{ensure, Context, Result};
use nalgebra::{DMatrix, DVector, SymmetricEigen};

use pn_stencil::quadrature::{gauss_legendre, legendre};

/// Collided reflection and transmission of a slab (per unit incident flux).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SlabReference {
    /// Collided flux leaving through x = 0, `∫_{−1}^0 |μ| ψ(0, μ) dμ`.
    pub reflection: f64,
    /// Collided flux leaving through x = τ, `∫_0^1 μ ψ(τ, μ) dμ` (the uncollided `e^{−τ}`
    /// not included).
    pub transmission: f64,
}

/// `∫_0^1 P_a(μ) P_b(μ) dμ` for a, b ≤ `n` (exact Gauss–Legendre on [0, 1]).
fn half_range_legendre(n: usize) -> Vec<Vec<f64>> {
    let (x, w) = gauss_legendre(n + 2);
    let mut out = vec![vec![0.0; n + 2]; n + 2];
    for (a, row) in out.iter_mut().enumerate() {
        for (b, v) in row.iter_mut().enumerate() {
            *v = x
                .iter()
                .zip(&w)
                .map(|(t, wt)| {
                    let mu = 0.5 * (t + 1.0);
                    0.5 * wt * legendre(a, mu) * legendre(b, mu)
                })
                .sum();
        }
    }
    out
}

/// The symmetric coupling `A'` and `B'` (rows scaled by 2l+1) for albedo `c`.
fn matrices(order: usize, c: f64) -> (DMatrix<f64>, DVector<f64>) {
    let n = order + 1;
    let mut a = DMatrix::zeros(n, n);
    for l in 0..order {
        a[(l, l + 1)] = (l + 1) as f64;
        a[(l + 1, l)] = (l + 1) as f64;
    }
    let b = DVector::from_iterator(
        n,
        (0..n).map(|l| (2 * l + 1) as f64 * if l == 0 { 1.0 - c } else { 1.0 }),
    );
    (a, b)
}

/// The modes `(λ, v)` of `B'v = λA'v` (φ = v e^{−λx}).
fn modes(order: usize, c: f64) -> Result<Vec<(f64, DVector<f64>)>> {
    let (a, b) = matrices(order, c);
    let a_inv = a
        .clone()
        .try_inverse()
        .context("the P_N coupling matrix is singular (even order?)")?;
    let n = order + 1;
    let sq = b.map(f64::sqrt);
    let mut k = DMatrix::zeros(n, n);
    for i in 0..n {
        for j in 0..n {
            k[(i, j)] = sq[i] * a_inv[(i, j)] * sq[j];
        }
    }
    let k = 0.5 * (&k + k.transpose());
    let eig = SymmetricEigen::new(k);
    Ok((0..n)
        .map(|i| {
            let w = eig.eigenvectors.column(i);
            let v = DVector::from_iterator(n, (0..n).map(|r| w[r] / sq[r]));
            (eig.eigenvalues[i], v)
        })
        .collect())
}

/// The Marshak row i (for `P_{2i−1}`) on the face with incoming μ of sign `sign`
/// (+1 at x = 0, −1 at x = τ), as coefficients of φ_0 … φ_N.
fn marshak_row(order: usize, i: usize, sign: f64, half: &[Vec<f64>]) -> Vec<f64> {
    let a = 2 * i - 1;
    (0..=order)
        .map(|l| {
            // ∫ over the incoming half: ∫_{−1}^0 P_a P_l = (−1)^{a+l} ∫_0^1 P_a P_l.
            let s = if sign > 0.0 || (a + l).is_multiple_of(2) {
                1.0
            } else {
                -1.0
            };
            (2 * l + 1) as f64 / 2.0 * s * half[a][l]
        })
        .collect()
}

fn check_order(order: usize) -> Result<()> {
    ensure!(
        order % 2 == 1 && order <= 41,
        "the P_N–Marshak reference needs an odd order N ≤ 41, got {order}"
    );
    Ok(())
}

/// Reflection and transmission of the collided light of a slab of optical thickness `tau`
/// (σ_t = 1), albedo `albedo` < 1, unit beam normally incident at x = 0, in P_N with
/// Marshak's vacuum condition on both faces.
pub fn pn_marshak_slab(order: usize, tau: f64, albedo: f64) -> Result<SlabReference> {
    check_order(order)?;
    ensure!(
        tau.is_finite() && tau > 0.0,
        "the slab thickness τ must be positive, got {tau}"
    );
    ensure!(
        (0.0..1.0).contains(&albedo),
        "the slab reference needs an albedo in [0, 1), got {albedo}"
    );
    let n = order + 1;
    let (a, b) = matrices(order, albedo);
    let mut s = DVector::zeros(n);
    s[0] = albedo;
    let p = (DMatrix::from_diagonal(&b) - &a)
        .lu()
        .solve(&s)
        .context("the particular solution is singular (a mode has λ = 1)")?;
    let modes = modes(order, albedo)?;
    let half = half_range_legendre(order);
    // Unknowns: one constant per mode; basis v_k e^{−λ_k (x − x_k)}, x_k the face it decays from.
    let origin: Vec<f64> = modes
        .iter()
        .map(|(l, _)| if *l > 0.0 { 0.0 } else { tau })
        .collect();
    let phi_mode = |k: usize, x: f64| -> DVector<f64> {
        let (lam, v) = &modes[k];
        v * (-lam * (x - origin[k])).exp()
    };
    let mut m = DMatrix::zeros(n, n);
    let mut rhs = DVector::zeros(n);
    for (face, (x, sign)) in [(0.0, 1.0), (tau, -1.0)].into_iter().enumerate() {
        for i in 1..=n / 2 {
            let row = marshak_row(order, i, sign, &half);
            let r = face * (n / 2) + i - 1;
            for k in 0..n {
                let pm = phi_mode(k, x);
                m[(r, k)] = (0..n).map(|l| row[l] * pm[l]).sum();
            }
            rhs[r] = -(0..n).map(|l| row[l] * p[l] * (-x).exp()).sum::<f64>();
        }
    }
    let coef = m
        .lu()
        .solve(&rhs)
        .context("the Marshak boundary system is singular")?;
    let phi = |x: f64| -> DVector<f64> {
        let mut f = &p * (-x).exp();
        for k in 0..n {
            f += phi_mode(k, x) * coef[k];
        }
        f
    };
    // ∫_0^1 μ P_l dμ = half[1][l]; over the other half (−1)^{1+l} times that.
    let out_flux = |phi: &DVector<f64>, sign: f64| -> f64 {
        (0..n)
            .map(|l| {
                let s = if sign > 0.0 || (1 + l).is_multiple_of(2) {
                    1.0
                } else {
                    -1.0
                };
                (2 * l + 1) as f64 / 2.0 * phi[l] * s * half[1][l]
            })
            .sum()
    };
    let reflection = out_flux(&phi(0.0), -1.0);
    let transmission = out_flux(&phi(tau), 1.0);
    Ok(SlabReference {
        // ∫_{−1}^0 μ ψ is negative for light leaving through x = 0.
        reflection: -reflection,
        transmission,
    })
}

/// The P_N–Marshak extrapolation length z_0 of the Milne problem (half-space, c = 1).
pub fn pn_marshak_milne(order: usize) -> Result<f64> {
    check_order(order)?;
    let n = order + 1;
    let decaying: Vec<(f64, DVector<f64>)> = modes(order, 1.0 - 1e-12)?
        .into_iter()
        .filter(|(l, _)| *l > 1e-3)
        .collect();
    ensure!(
        decaying.len() == (order - 1) / 2,
        "internal error: {} decaying Milne modes for P_{order}",
        decaying.len()
    );
    let half = half_range_legendre(order);
    // Unknowns: z_0, then the decaying modes' constants; φ(0) = z_0 e_0 − e_1/3 + Σ a_k v_k.
    let k = n / 2;
    let mut m = DMatrix::zeros(k, k);
    let mut rhs = DVector::zeros(k);
    for i in 1..=k {
        let row = marshak_row(order, i, 1.0, &half);
        m[(i - 1, 0)] = row[0];
        rhs[i - 1] = row[1] / 3.0;
        for (j, (_, v)) in decaying.iter().enumerate() {
            m[(i - 1, j + 1)] = (0..n).map(|l| row[l] * v[l]).sum();
        }
    }
    let sol = m
        .lu()
        .solve(&rhs)
        .context("the Milne boundary system is singular")?;
    Ok(sol[0])
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The tables of tests/data/marshak/README.md (5 digits).
    #[test]
    fn readme_tables() {
        let milne = [(1, 0.66667), (3, 0.70509), (5, 0.70821), (7, 0.70920)];
        for (n, z0) in milne {
            let got = pn_marshak_milne(n).unwrap();
            assert!((got - z0).abs() < 6e-6, "P{n} z0 {got} vs {z0}");
        }
        let slab = [
            (1, 0.27259, 0.23337),
            (3, 0.26935, 0.22541),
            (5, 0.26838, 0.22398),
            (7, 0.26797, 0.22374),
        ];
        for (n, r, t) in slab {
            let got = pn_marshak_slab(n, 1.0, 0.9).unwrap();
            assert!(
                (got.reflection - r).abs() < 6e-6 && (got.transmission - t).abs() < 6e-6,
                "P{n}: {got:?} vs R {r} T {t}"
            );
        }
    }

    #[test]
    fn bad_input_is_refused() {
        assert!(pn_marshak_slab(2, 1.0, 0.9).is_err());
        assert!(pn_marshak_slab(3, -1.0, 0.9).is_err());
        assert!(pn_marshak_slab(3, 1.0, 1.0).is_err());
        assert!(pn_marshak_milne(4).is_err());
    }
}
