//! The Marshak vacuum closure of the staggered P_N system, derived from half-range moments
//! (docs/design.md §3, "Domain and boundary").
//!
//! On a domain face with outward normal `n = ∓e_d` (the min / max face of axis `d`) no
//! radiance comes in: Marshak's condition asks that the half-range moments of the incoming
//! radiance vanish for every real harmonic `Y_o` (l ≤ N) that is odd under the reflection
//! `ω_d → −ω_d`,
//!
//! ```text
//!     ∫_{n·ω<0} Y_o(ω) L(x,ω) dω = 0 .
//! ```
//!
//! With the truncated expansion `L = Σ_k L_k Y_k` this is one linear relation per odd
//! harmonic. The half-range Gram matrix `G⁺_{ij} = ∫_{ω_d>0} Y_i Y_j dω` is what it needs:
//! a product of two harmonics of the same d-parity is even in ω_d, so its half-range integral
//! is half the full one, `G⁺_{oo'} = δ_{oo'}/2`; for an odd `Y_o` and an even `Y_e` the
//! product is odd and `∫_{ω_d<0} = −G⁺_{oe}`. The condition on the min face (incoming
//! `ω_d > 0`) and on the max face (incoming `ω_d < 0`) is therefore
//!
//! ```text
//!     L_o ± 2 Σ_e G⁺_{oe} L_e = 0          (+ on the min face, − on the max face):
//! ```
//!
//! the odd moments on the face in terms of the even ones — N(N+1)/2 conditions per face in
//! 3D for odd N, as many as there are odd moments, i.e. incoming characteristics. Only
//! harmonics with the same parity in the two tangential axes couple (the half-range over
//! `ω_d` keeps the reflections of the other axes), so on the staggered grid (docs/design.md
//! §3) every `L_e` a condition needs lives on the same tangential position as `L_o`, half a
//! cell inside the face along `d`; and since the total parity of `Y_l^m` is `(−1)^l`, each
//! condition couples moments of opposite l-parity, as the transport terms do.
//!
//! [`marshak_closure`] computes `2 G⁺_{oe}` by quadrature for the moments of a stencil and
//! checks that their placement is the staggered one; the runtime turns each face row into
//! the condition (`pn_runtime::marshak`). Nothing here is typed in: the coefficients come
//! from [`crate::quadrature::real_sh`] and Gauss–Legendre nodes, and the tests compare them
//! with the closed forms of P_1 (`L_1 = ∓(√3/2) L_0`, the zero incoming partial current).

use crate::ir::{MomentPlacement, StencilError};
use crate::quadrature::{gauss_legendre, real_sh};
use std::f64::consts::PI;

/// Coefficients below this magnitude (relative to 1) are quadrature rounding and dropped.
const DROP: f64 = 1e-13;

/// The Marshak condition of one odd moment on the **min** face of an axis:
/// `L_o + Σ (coefficient × L_e) = 0` with `L_e` the even moments on the face. On the max
/// face every coefficient changes sign.
#[derive(Clone, Debug, PartialEq)]
pub struct MarshakCondition {
    /// Index of the odd moment (into the stencil's moment list).
    pub moment: usize,
    /// `(even moment index, 2 G⁺_{oe})`, non-zero coefficients only, by moment index.
    pub terms: Vec<(usize, f64)>,
}

/// The Marshak closure of a stencil's moments on the faces of one axis.
#[derive(Clone, Debug, PartialEq)]
pub struct MarshakClosure {
    /// The axis (0 = x, 1 = y, 2 = z) whose faces the closure is for.
    pub axis: usize,
    /// For each moment of the stencil: its condition if the moment is odd under
    /// `ω_axis → −ω_axis` (it then sits on the faces of `axis`), `None` if it is even.
    pub conditions: Vec<Option<MarshakCondition>>,
}

impl MarshakClosure {
    /// Number of conditions per face position set (the odd moments).
    pub fn count(&self) -> usize {
        self.conditions.iter().filter(|c| c.is_some()).count()
    }
}

/// A direction from its Cartesian components, as (μ = ω_z, φ) for [`real_sh`].
fn angles(w: [f64; 3]) -> (f64, f64) {
    (w[2], w[1].atan2(w[0]))
}

/// Quadrature on the half sphere `ω_axis > 0` exact for polynomials in ω of degree
/// ≤ `degree`: Gauss–Legendre in `t = ω_axis ∈ (0, 1)` times uniform in the azimuth about
/// the axis. Returns (direction, weight); the weights sum to 2π.
pub fn half_sphere_quadrature(axis: usize, degree: usize) -> Vec<([f64; 3], f64)> {
    // A polynomial of degree ≤ d in ω is, on the half sphere, a polynomial of degree ≤ d
    // in t times trigonometric terms of order ≤ d in the azimuth (with √(1−t²) factors
    // paired with the trigonometric ones, so the t part stays polynomial for each order).
    let (ts, tw) = gauss_legendre(degree / 2 + 2);
    let n_az = degree + 2;
    let (a, b) = ((axis + 1) % 3, (axis + 2) % 3);
    let mut out = Vec::with_capacity(ts.len() * n_az);
    for (t, w) in ts.iter().zip(&tw) {
        let t = 0.5 * (t + 1.0);
        let w = 0.5 * w;
        let s = (1.0 - t * t).max(0.0).sqrt();
        for j in 0..n_az {
            let az = 2.0 * PI * (j as f64 + 0.5) / n_az as f64;
            let mut dir = [0.0; 3];
            dir[axis] = t;
            dir[a] = s * az.cos();
            dir[b] = s * az.sin();
            out.push((dir, w * 2.0 * PI / n_az as f64));
        }
    }
    out
}

/// Whether the real harmonic `Y_l^m` is odd under the reflection `ω_axis → −ω_axis`,
/// decided numerically (`Y(Rω) = ±Y(ω)` at a few generic directions).
pub fn is_odd_under_reflection(l: usize, m: i64, axis: usize) -> Result<bool, StencilError> {
    let probes = [[0.3, 0.5, 0.81], [-0.7, 0.2, 0.4], [0.25, -0.6, -0.3]];
    let (mut even, mut odd) = (true, true);
    let mut scale = 0.0f64;
    for p in probes {
        let n: f64 = p[0] * p[0] + p[1] * p[1] + p[2] * p[2];
        let w = p.map(|c: f64| c / n.sqrt());
        let mut r = w;
        r[axis] = -r[axis];
        let (mu, phi) = angles(w);
        let (mu_r, phi_r) = angles(r);
        let y = real_sh(l, m, mu, phi);
        let yr = real_sh(l, m, mu_r, phi_r);
        scale = scale.max(y.abs());
        even &= (y - yr).abs() <= 1e-12 * (1.0 + y.abs());
        odd &= (y + yr).abs() <= 1e-12 * (1.0 + y.abs());
    }
    match (even, odd) {
        (true, false) => Ok(false),
        (false, true) => Ok(true),
        _ => Err(StencilError::Malformed(format!(
            "Y_{l}^{m} has no definite parity under reflection of axis {axis} (scale {scale:e})"
        ))),
    }
}

/// The half-range Gram matrix `G⁺_{ij} = ∫_{ω_axis>0} Y_i Y_j dω` of the harmonics
/// `(l, m)` listed, by quadrature exact for their degree.
pub fn half_range_gram(harmonics: &[(usize, i64)], axis: usize) -> Vec<Vec<f64>> {
    let lmax = harmonics.iter().map(|h| h.0).max().unwrap_or(0);
    let quad = half_sphere_quadrature(axis, 2 * lmax);
    let values: Vec<Vec<f64>> = harmonics
        .iter()
        .map(|&(l, m)| {
            quad.iter()
                .map(|(w, _)| {
                    let (mu, phi) = angles(*w);
                    real_sh(l, m, mu, phi)
                })
                .collect()
        })
        .collect();
    let n = harmonics.len();
    let mut g = vec![vec![0.0; n]; n];
    for i in 0..n {
        for j in i..n {
            let s: f64 = quad
                .iter()
                .enumerate()
                .map(|(k, (_, wt))| wt * values[i][k] * values[j][k])
                .sum();
            g[i][j] = s;
            g[j][i] = s;
        }
    }
    g
}

/// Derives the Marshak closure on the faces of `axis` for a staggered stencil's `moments`
/// (the P_N moments of a 2D or 3D stencil, in storage order).
///
/// Fails when the placement is not the staggered one the closure needs: an odd moment
/// not on the faces of `axis`, an even one not at centres, or a condition coupling moments
/// at different tangential positions (e.g. for the collocated stencil or a scalar PDE).
pub fn marshak_closure(
    moments: &[MomentPlacement],
    axis: usize,
) -> Result<MarshakClosure, StencilError> {
    if axis > 2 {
        return Err(StencilError::Malformed(format!("axis {axis} out of range")));
    }
    let harmonics: Vec<(usize, i64)> = moments
        .iter()
        .map(|mp| {
            if mp.l < 0 || mp.m.unsigned_abs() > mp.l as u32 {
                Err(StencilError::Malformed(format!(
                    "moment ({},{}) is not a spherical harmonic",
                    mp.l, mp.m
                )))
            } else {
                Ok((mp.l as usize, mp.m as i64))
            }
        })
        .collect::<Result<_, _>>()?;
    let odd: Vec<bool> = harmonics
        .iter()
        .map(|&(l, m)| is_odd_under_reflection(l, m, axis))
        .collect::<Result<_, _>>()?;
    for (q, mp) in moments.iter().enumerate() {
        if (mp.shift[axis] == 1) != odd[q] {
            return Err(StencilError::InconsistentPlacement(format!(
                "the Marshak closure needs the staggered placement: moment ({},{}) is {} \
                 under reflection of axis {axis} but has shift {} on it",
                mp.l,
                mp.m,
                if odd[q] { "odd" } else { "even" },
                mp.shift[axis]
            )));
        }
    }
    let g = half_range_gram(&harmonics, axis);
    let mut conditions = vec![None; moments.len()];
    for o in (0..moments.len()).filter(|&o| odd[o]) {
        // Self-check of the quadrature: G⁺_{oo'} = δ/2 for two odd harmonics.
        for o2 in (0..moments.len()).filter(|&k| odd[k]) {
            let want = if o == o2 { 0.5 } else { 0.0 };
            if (g[o][o2] - want).abs() > 1e-12 {
                return Err(StencilError::Derive(format!(
                    "half-range Gram matrix: G⁺ between odd moments {o} and {o2} is {} \
                     instead of {want}",
                    g[o][o2]
                )));
            }
        }
        let mut terms = Vec::new();
        for e in (0..moments.len()).filter(|&k| !odd[k]) {
            let c = 2.0 * g[o][e];
            if c.abs() <= DROP {
                continue;
            }
            let same_tangential = (0..3)
                .filter(|&d| d != axis)
                .all(|d| moments[e].shift[d] == moments[o].shift[d]);
            if !same_tangential {
                return Err(StencilError::InconsistentPlacement(format!(
                    "the Marshak condition of moment ({},{}) on axis {axis} couples moment \
                     ({},{}) at another tangential position",
                    moments[o].l, moments[o].m, moments[e].l, moments[e].m
                )));
            }
            terms.push((e, c));
        }
        conditions[o] = Some(MarshakCondition { moment: o, terms });
    }
    Ok(MarshakClosure { axis, conditions })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The staggered placement of docs/design.md §3 (3D, or 2D without the l+m odd moments).
    fn placement(order: i32, two_d: bool) -> Vec<MomentPlacement> {
        let mut v = Vec::new();
        for l in 0..=order {
            for m in -l..=l {
                if two_d && (l + m) % 2 != 0 {
                    continue;
                }
                let x = (m > 0 && m % 2 == 1) || (m < 0 && m % 2 == 0);
                let y = m < 0;
                let z = (l + m) % 2 != 0;
                v.push(MomentPlacement {
                    l,
                    m,
                    shift: [x as u8, y as u8, z as u8],
                });
            }
        }
        v
    }

    #[test]
    fn p1_is_the_zero_incoming_partial_current() {
        // L_1^{(d)} = −(√3/2) L_0^0 on the min face: J = √(4π/3) L_1 = −φ/2, J⁺ = φ/4 + J/2 = 0.
        let mp = placement(1, false);
        for axis in 0..3 {
            let c = marshak_closure(&mp, axis).unwrap();
            assert_eq!(c.count(), 1);
            let cond = c.conditions.iter().flatten().next().unwrap();
            assert_eq!(cond.terms.len(), 1);
            assert_eq!(cond.terms[0].0, 0);
            assert!(
                (cond.terms[0].1 - 3f64.sqrt() / 2.0).abs() < 1e-14,
                "{cond:?}"
            );
        }
    }

    #[test]
    fn condition_counts_are_n_n_plus_1_over_2() {
        for n in [1, 3, 5, 7] {
            let c = marshak_closure(&placement(n, false), 0).unwrap();
            assert_eq!(c.count() as i32, n * (n + 1) / 2);
            for axis in 0..2 {
                let c2 = marshak_closure(&placement(n, true), axis).unwrap();
                // 2D keeps the l+m even harmonics: the ω_axis-odd ones among them.
                let want = placement(n, true)
                    .iter()
                    .filter(|mp| mp.shift[axis] == 1)
                    .count();
                assert_eq!(c2.count(), want);
            }
        }
    }

    #[test]
    fn gram_matrix_matches_a_brute_force_sum() {
        // Midpoint rule on a fine (θ, φ) grid of the half sphere ω_y > 0.
        let hs = [(0usize, 0i64), (1, -1), (2, -2), (3, 1), (3, -3)];
        let g = half_range_gram(&hs, 1);
        let (nt, np) = (800, 800);
        for i in 0..hs.len() {
            for j in 0..hs.len() {
                let mut s = 0.0;
                for a in 0..nt {
                    let th = PI * (a as f64 + 0.5) / nt as f64;
                    for b in 0..np {
                        let ph = 2.0 * PI * (b as f64 + 0.5) / np as f64;
                        if th.sin() * ph.sin() <= 0.0 {
                            continue;
                        }
                        let w = th.sin() * (PI / nt as f64) * (2.0 * PI / np as f64);
                        s += w
                            * real_sh(hs[i].0, hs[i].1, th.cos(), ph)
                            * real_sh(hs[j].0, hs[j].1, th.cos(), ph);
                    }
                }
                assert!((s - g[i][j]).abs() < 2e-4, "{i} {j}: {s} vs {}", g[i][j]);
            }
        }
    }

    #[test]
    fn collocated_placement_is_refused() {
        let mut mp = placement(3, false);
        mp.iter_mut().for_each(|m| m.shift = [0; 3]);
        assert!(marshak_closure(&mp, 0).is_err());
    }
}
