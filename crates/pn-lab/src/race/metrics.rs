//! The error measures of `pn race` (docs/race.md): relative RMSE (relative L2 norm of the
//! difference), relative bias of the image mean, the noise of a two-halves reference, and
//! the equal-error interpolation on a log–log error-against-time curve.

use anyhow::{ensure, Result};
use pn_render::compare::{check_pair, GrayImage};

/// Error of an image against the reference.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Errors {
    /// ‖a − b‖₂ / ‖b‖₂ over all pixels (the RMSE divided by the reference's RMS value).
    pub rel_rmse: f64,
    /// (mean a − mean b) / mean b.
    pub rel_bias: f64,
    /// Mean of the image.
    pub mean: f64,
}

/// The errors of `a` against the reference `b`. A black reference is an error.
pub fn errors(a: &GrayImage, b: &GrayImage) -> Result<Errors> {
    check_pair(a, b, ["test", "reference"])?;
    let (mut d2, mut b2, mut sa, mut sb) = (0.0, 0.0, 0.0, 0.0);
    for (x, y) in a.data.iter().zip(&b.data) {
        d2 += (x - y) * (x - y);
        b2 += y * y;
        sa += x;
        sb += y;
    }
    ensure!(
        b2 > 0.0 && sb > 0.0,
        "the reference image is black: nothing of the medium is in view"
    );
    let n = a.data.len() as f64;
    Ok(Errors {
        rel_rmse: (d2 / b2).sqrt(),
        rel_bias: (sa - sb) / sb,
        mean: sa / n,
    })
}

/// A reference made of two independent halves A and B (different seeds, same spp).
#[derive(Clone, Debug, PartialEq)]
pub struct TwoHalves {
    /// (A + B)/2.
    pub mean: GrayImage,
    /// Relative RMSE noise of the mean image: ‖A − B‖₂ / 2 / ‖(A+B)/2‖₂. For independent
    /// halves E‖A − B‖² = 2 Σσ²_half, and the mean's per-pixel variance is σ²_half/2, so this
    /// estimates the relative RMSE of the mean against the exact image.
    pub noise_rel_rmse: f64,
    /// Standard deviation of the mean image's pixel mean, relative to it: the pixels are
    /// independent, so σ²(mean) = Σ_p σ²_p / N² with σ²_p ≈ (A_p − B_p)²/4.
    pub noise_rel_mean: f64,
    /// Relative difference of the halves' means, (mean A − mean B)/mean(ref).
    pub halves_rel_diff: f64,
}

/// The mean of two independent halves and its noise.
pub fn two_halves(a: &GrayImage, b: &GrayImage) -> Result<TwoHalves> {
    check_pair(a, b, ["first half", "second half"])?;
    let data: Vec<f64> = a
        .data
        .iter()
        .zip(&b.data)
        .map(|(x, y)| 0.5 * (x + y))
        .collect();
    let mean = GrayImage {
        width: a.width,
        height: a.height,
        data,
    };
    let n = a.data.len() as f64;
    let d2: f64 = a
        .data
        .iter()
        .zip(&b.data)
        .map(|(x, y)| (x - y) * (x - y))
        .sum();
    let m2: f64 = mean.data.iter().map(|v| v * v).sum();
    let m: f64 = mean.data.iter().sum::<f64>() / n;
    ensure!(
        m2 > 0.0 && m > 0.0,
        "the reference image is black: nothing of the medium is in view"
    );
    let (ma, mb) = (
        a.data.iter().sum::<f64>() / n,
        b.data.iter().sum::<f64>() / n,
    );
    Ok(TwoHalves {
        noise_rel_rmse: 0.5 * (d2 / m2).sqrt(),
        noise_rel_mean: 0.5 * d2.sqrt() / n / m,
        halves_rel_diff: (ma - mb) / m,
        mean,
    })
}

/// The error with the reference's own noise removed in quadrature,
/// √max(0, e² − n²): for a test image whose noise is independent of the reference's,
/// E[e²] = e_true² + n².
pub fn excess(rel_rmse: f64, ref_noise: f64) -> f64 {
    (rel_rmse * rel_rmse - ref_noise * ref_noise)
        .max(0.0)
        .sqrt()
}

/// The time a curve (points `(seconds, error)` in order of increasing effort) needs to reach
/// `target`: the first segment whose end lies at or below `target`, interpolated linearly in
/// (log t, log e); `None` when no point reaches it. A first point already below gives that
/// point's time (the curve starts there; nothing is extrapolated backwards).
pub fn time_to_reach(curve: &[(f64, f64)], target: f64) -> Option<f64> {
    let pts: Vec<(f64, f64)> = curve
        .iter()
        .copied()
        .filter(|(t, e)| *t > 0.0 && *e > 0.0 && t.is_finite() && e.is_finite())
        .collect();
    let first = pts.iter().position(|(_, e)| *e <= target)?;
    if first == 0 {
        return Some(pts[0].0);
    }
    let (t0, e0) = pts[first - 1];
    let (t1, e1) = pts[first];
    if e0 <= e1 {
        return Some(t1);
    }
    let s = (e0.ln() - target.ln()) / (e0.ln() - e1.ln());
    Some((t0.ln() + s * (t1.ln() - t0.ln())).exp())
}

/// The samples per pixel at which a Monte Carlo estimator with the measured (spp, excess
/// error) points reaches the excess error `target`: the error falls as spp^(-1/2), so each
/// point predicts spp·(e/target)²; the prediction of the point nearest in error is used.
pub fn spp_for_error(points: &[(usize, f64)], target: f64) -> Option<f64> {
    if target <= 0.0 || !target.is_finite() {
        return None;
    }
    points
        .iter()
        .filter(|(s, e)| *s > 0 && *e > 0.0 && e.is_finite())
        .min_by(|a, b| {
            let da = (a.1 / target).ln().abs();
            let db = (b.1 / target).ln().abs();
            da.total_cmp(&db)
        })
        .map(|(s, e)| *s as f64 * (e / target).powi(2))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn img(data: Vec<f64>) -> GrayImage {
        GrayImage {
            width: data.len(),
            height: 1,
            data,
        }
    }

    #[test]
    fn errors_are_relative_l2_and_mean() {
        let b = img(vec![1.0, 2.0, 0.0, 1.0]);
        let a = img(vec![1.0, 2.0, 0.6, 1.0]);
        let e = errors(&a, &b).unwrap();
        // ‖a−b‖ = 0.6, ‖b‖ = √6.
        assert!((e.rel_rmse - 0.6 / 6f64.sqrt()).abs() < 1e-15);
        assert!((e.rel_bias - 0.15).abs() < 1e-15);
        assert!(errors(&a, &img(vec![0.0; 4])).is_err());
        assert!(errors(&img(vec![1.0; 3]), &b).is_err());
        assert!(errors(&img(vec![f64::NAN, 1.0, 1.0, 1.0]), &b).is_err());
    }

    #[test]
    fn two_halves_noise_matches_the_construction() {
        // A = m + d, B = m − d: mean m exactly, noise ‖2d‖/2/‖m‖ = ‖d‖/‖m‖.
        let m = [1.0, 2.0, 3.0, 4.0];
        let d = [0.1, -0.2, 0.0, 0.3];
        let a = img(m.iter().zip(&d).map(|(x, y)| x + y).collect());
        let b = img(m.iter().zip(&d).map(|(x, y)| x - y).collect());
        let h = two_halves(&a, &b).unwrap();
        assert_eq!(h.mean.data, m.to_vec());
        let dn = d.iter().map(|v| v * v).sum::<f64>().sqrt();
        let mn = m.iter().map(|v| v * v).sum::<f64>().sqrt();
        assert!((h.noise_rel_rmse - dn / mn).abs() < 1e-15);
        assert!((h.noise_rel_mean - dn / 4.0 / 2.5).abs() < 1e-15);
    }

    #[test]
    fn statistical_noise_estimate_is_unbiased() {
        // Two halves of i.i.d. noise of known σ around a constant image: the estimate of the
        // mean's relative noise must be σ/√2 within a few percent (N = 40000 pixels: the
        // relative spread of the estimate is about 1/√(2N) ≈ 0.4 %).
        let n = 40_000;
        let mut state = 12345u64;
        let mut normal = || {
            // Box–Muller on a SplitMix64 stream.
            let mut u = || {
                state = state.wrapping_add(0x9e37_79b9_7f4a_7c15);
                let mut z = state;
                z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
                z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
                ((z ^ (z >> 31)) >> 11) as f64 / (1u64 << 53) as f64
            };
            let (u1, u2) = (u().max(1e-300), u());
            (-2.0 * u1.ln()).sqrt() * (std::f64::consts::TAU * u2).cos()
        };
        let sigma = 0.2;
        let a = img((0..n).map(|_| 1.0 + sigma * normal()).collect());
        let b = img((0..n).map(|_| 1.0 + sigma * normal()).collect());
        let h = two_halves(&a, &b).unwrap();
        let expect = sigma / 2f64.sqrt();
        assert!((h.noise_rel_rmse / expect - 1.0).abs() < 0.03, "{h:?}");
        assert!(
            (h.noise_rel_mean / (expect / (n as f64).sqrt()) - 1.0).abs() < 0.03,
            "{h:?}"
        );
    }

    #[test]
    fn time_to_reach_interpolates_in_log_log() {
        let c = [(1.0, 1.0), (4.0, 0.5), (16.0, 0.25)];
        assert_eq!(time_to_reach(&c, 2.0), Some(1.0));
        assert!((time_to_reach(&c, 0.5).unwrap() - 4.0).abs() < 1e-12);
        // Half way in log e between 0.5 and 0.25 is half way in log t: 8.
        assert!((time_to_reach(&c, 0.5f64.sqrt() * 0.5).unwrap() - 8.0).abs() < 1e-9);
        assert_eq!(time_to_reach(&c, 0.1), None);
    }

    #[test]
    fn spp_for_error_follows_the_square_root_law() {
        let p = [(16, 0.2), (64, 0.1)];
        assert!((spp_for_error(&p, 0.05).unwrap() - 256.0).abs() < 1e-9);
        assert!((spp_for_error(&p, 0.4).unwrap() - 4.0).abs() < 1e-9);
        assert_eq!(spp_for_error(&p, 0.0), None);
    }
}
