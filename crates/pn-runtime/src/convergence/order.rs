//! Norms, observed orders of convergence and Richardson error estimates.
//!
//! Error model: a solution at cell size h is `u_h = u + C h^p` (per cell, on a common grid).
//! Then the difference of two levels is `u_a − u_b = C (h_a^p − h_b^p)`, and ratios of such
//! differences depend on p only; [`solve_order`] inverts that relation.

use serde::Serialize;

/// `‖a − b‖₂ / ‖b‖₂` over all entries (uniform cells: the discrete L2 norm is a plain sum).
/// Returns the absolute norm of `a − b` when `b` is zero.
pub fn rel_l2_diff(a: &[f64], b: &[f64]) -> f64 {
    assert_eq!(a.len(), b.len(), "rel_l2_diff: length mismatch");
    let d: f64 = a.iter().zip(b).map(|(x, y)| (x - y).powi(2)).sum();
    let n: f64 = b.iter().map(|y| y * y).sum();
    if n > 0.0 {
        (d / n).sqrt()
    } else {
        d.sqrt()
    }
}

/// `‖a − b‖₂`, the absolute discrete L2 norm of the difference (uniform cells). Orders are
/// computed from these: ratios of relative differences normalised by different levels would
/// be biased by the ratio of the levels' norms.
pub fn l2_diff(a: &[f64], b: &[f64]) -> f64 {
    assert_eq!(a.len(), b.len(), "l2_diff: length mismatch");
    a.iter()
        .zip(b)
        .map(|(x, y)| (x - y).powi(2))
        .sum::<f64>()
        .sqrt()
}

/// The p that solves `(h_a^p − h_b^p)/(h_c^p − h_d^p) = ratio` on [0.05, 12], by bisection
/// (the left side is monotone in p for `h_a > h_b`, `h_c > h_d`, `h_a ≥ h_c`, `h_b ≥ h_d`).
/// `None` when the ratio is not finite and positive or when no p in the range matches: the
/// order is then not measurable from these levels (e.g. not yet asymptotic, or the
/// differences are at round-off / solver-tolerance level).
pub fn solve_order(h: [f64; 4], ratio: f64) -> Option<f64> {
    if !(ratio.is_finite() && ratio > 0.0) {
        return None;
    }
    let f = |p: f64| {
        let num = h[0].powf(p) - h[1].powf(p);
        let den = h[2].powf(p) - h[3].powf(p);
        (num / den).ln() - ratio.ln()
    };
    let (mut lo, mut hi) = (0.05, 12.0);
    let (flo, fhi) = (f(lo), f(hi));
    if !(flo.is_finite() && fhi.is_finite()) || flo.signum() == fhi.signum() {
        return None;
    }
    for _ in 0..200 {
        let mid = 0.5 * (lo + hi);
        if f(mid).signum() == flo.signum() {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    Some(0.5 * (lo + hi))
}

/// The observed order from three levels `h1 > h2 > h3` and the norms of the successive
/// differences `d12 = ‖u1 − u2‖`, `d23 = ‖u2 − u3‖`; for a constant refinement ratio r
/// this is `log(d12/d23)/log r`.
pub fn observed_order(h: [f64; 3], d12: f64, d23: f64) -> Option<f64> {
    solve_order([h[0], h[1], h[1], h[2]], d12 / d23)
}

/// The Richardson estimate of the discretization error of a fine solution.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct RichardsonEstimate {
    /// The order p used.
    pub order: f64,
    /// Where p comes from (`observed (three levels)` or `assumed 2 ...`).
    pub order_source: String,
    /// Refinement ratio r = h_coarse/h_fine.
    pub ratio: f64,
    /// `‖E‖₂/‖u_fine‖₂` on the coarse grid.
    pub rel_l2: f64,
    /// `max |E|`.
    pub max_abs: f64,
    /// `max |E| / max |u_fine|`.
    pub rel_max: f64,
    /// Per coarse cell `E = (u_fine − u_coarse)/(r^p − 1) ≈ u − u_fine`: minus the estimated
    /// error of the fine solution, i.e. the correction that extrapolates it
    /// (`u ≈ u_fine + E`; C order, coarse grid).
    #[serde(skip)]
    pub per_cell: Vec<f64>,
}

/// Richardson: with `u_h = u + C h^p`, `u_fine − u_coarse = C h_fine^p (1 − r^p)`, so
/// `u − u_fine = (u_fine − u_coarse)/(r^p − 1)`.
/// `fine_restricted` is the fine solution restricted to the coarse grid.
pub fn richardson(
    fine_restricted: &[f64],
    coarse: &[f64],
    ratio: f64,
    order: f64,
    order_source: &str,
) -> RichardsonEstimate {
    assert_eq!(
        fine_restricted.len(),
        coarse.len(),
        "richardson: length mismatch"
    );
    let denom = ratio.powf(order) - 1.0;
    let per_cell: Vec<f64> = fine_restricted
        .iter()
        .zip(coarse)
        .map(|(f, c)| (f - c) / denom)
        .collect();
    let zero = vec![0.0; per_cell.len()];
    let norm_e = rel_l2_diff(&per_cell, &zero);
    let norm_u = rel_l2_diff(fine_restricted, &zero);
    let max_abs = per_cell.iter().fold(0.0f64, |m, e| m.max(e.abs()));
    let max_u = fine_restricted.iter().fold(0.0f64, |m, e| m.max(e.abs()));
    RichardsonEstimate {
        order,
        order_source: order_source.into(),
        ratio,
        rel_l2: if norm_u > 0.0 {
            norm_e / norm_u
        } else {
            norm_e
        },
        max_abs,
        rel_max: if max_u > 0.0 {
            max_abs / max_u
        } else {
            max_abs
        },
        per_cell,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn constant_ratio_order_is_a_logarithm() {
        // d12/d23 = 2^p for halving: p = 2 exactly (bisection to ~1e-15).
        let p = observed_order([0.4, 0.2, 0.1], 8.0, 2.0).unwrap();
        assert!((p - 2.0).abs() < 1e-12, "{p}");
        // Differences that grow under refinement: no order.
        assert!(observed_order([0.4, 0.2, 0.1], 1.0, 2.0).is_none());
        assert!(observed_order([0.4, 0.2, 0.1], 0.0, 2.0).is_none());
    }

    #[test]
    fn richardson_of_exact_model_is_exact() {
        // u_h = 1 + 3h²: fine h = 0.1, coarse 0.2, r = 2, p = 2 → E = 1 − u_fine = −0.03.
        let e = richardson(&[1.03], &[1.12], 2.0, 2.0, "test");
        assert!((e.per_cell[0] + 0.03).abs() < 1e-14);
    }
}
