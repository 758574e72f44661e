//! The sky's single scattering towards one eye point, tabulated on a grid (docs/sky.md, "The
//! camera's single scattering").
//!
//! A sky cut into K directional lights ([`crate::sky`]) costs the camera K optical-depth
//! lookups at every step of every ray: `S_sky(x, ω_o) = Σ_k p̄_k(d_k·ω_o) E_k T_k(x)`. For a
//! pinhole camera the outgoing direction at a point is a function of the point alone,
//! `ω_o(x) = (eye − x)/|eye − x|`, so for one view `S_sky` is a scalar field of x. It is
//! tabulated per view at the nodes of a regular grid over the medium's support (K lookups
//! per node, each node computed when the march first reads it) and read by the march (one
//! lookup per step, whatever K).
//!
//! **Interpolation of ln S.** Inside a cloud S falls off like the transmittance to the sky,
//! `e^{−τ}`, on the scale of a mean free path — a voxel or two in a dense cloud — so
//! interpolating S itself between nodes outside and inside the lit surface overestimates it
//! (measured: +3.5 % single scattering at a 2-voxel spacing on `scenes/sky-constant.toml`).
//! The grid holds ln S and the march reads `exp` of its trilinear interpolation: exact where
//! S is one exponential of a linear function (one sky direction through a homogeneous
//! medium), and O(h²·|∂²ln S|) otherwise (+0.1 % at 2 voxels on the same scene). The
//! spacing h (a multiple of the voxel side) sets the error, not K; docs/sky.md gives the
//! measured error against Mitsuba and against the per-step evaluation.

use std::sync::atomic::{AtomicU32, Ordering};

/// Largest number of grid nodes of a [`SkyView`] (2^22: 16 MB of `f32`); a finer medium gets
/// a proportionally coarser grid.
pub const MAX_SKY_VIEW_NODES: usize = 1 << 22;

/// `s(x, ω_o)`: the sky's single scattering at x towards ω_o, what a [`SkyView`] tabulates.
pub trait SkySource: Fn([f64; 3], [f64; 3]) -> f64 + Sync {}

impl<F: Fn([f64; 3], [f64; 3]) -> f64 + Sync> SkySource for F {}

/// A node not computed yet (a NaN pattern that `f32::ln` of a positive value never gives).
const UNSET: u32 = u32::MAX;

/// `S_sky` of one eye point at the nodes of a regular grid (module docs), each node computed
/// the first time a lookup reads it: the march reaches only the nodes near what the camera
/// sees (a ray stops where its transmittance falls below the cutoff), so a fine grid costs
/// only the nodes it uses. A node's value does not depend on which thread computes it or
/// when, so the image does not depend on the number of threads.
pub struct SkyView<F> {
    min: [f64; 3],
    /// Node spacing per axis.
    h: [f64; 3],
    /// Nodes per axis (≥ 2).
    n: [usize; 3],
    eye: [f64; 3],
    /// `s(x, ω_o)`: the sky's single scattering at x towards ω_o.
    s: F,
    /// ln S at the nodes (S floored at 1e-30) as `f32` bits, [`UNSET`] until computed; x
    /// fastest.
    log_values: Vec<AtomicU32>,
}

impl<F: SkySource> SkyView<F> {
    /// The grid over the box `[min, max]` at a spacing of at most `spacing` (coarsened so
    /// that it has at most [`MAX_SKY_VIEW_NODES`] nodes) for `s(x, ω_o(x))` with
    /// `ω_o(x) = (eye − x)/|eye − x|`; nothing is computed yet.
    pub fn new(min: [f64; 3], max: [f64; 3], spacing: f64, eye: [f64; 3], s: F) -> Self {
        let extent: [f64; 3] = std::array::from_fn(|d| (max[d] - min[d]).max(0.0));
        let nodes_at = |h: f64| extent.map(|e| ((e / h).ceil() as usize + 1).max(2));
        let mut h = spacing.max(1e-12);
        while nodes_at(h).iter().product::<usize>() > MAX_SKY_VIEW_NODES {
            h *= 1.25;
        }
        let n = nodes_at(h);
        SkyView {
            min,
            h: std::array::from_fn(|d| extent[d] / (n[d] - 1) as f64),
            n,
            eye,
            s,
            log_values: (0..n.iter().product::<usize>())
                .map(|_| AtomicU32::new(UNSET))
                .collect(),
        }
    }

    /// Nodes per axis.
    #[cfg(test)]
    pub fn nodes(&self) -> [usize; 3] {
        self.n
    }

    /// Nodes computed so far.
    #[cfg(test)]
    pub fn computed(&self) -> usize {
        self.log_values
            .iter()
            .filter(|v| v.load(Ordering::Relaxed) != UNSET)
            .count()
    }

    /// ln S at node (i, j, k), computed on first use.
    #[inline]
    fn log_at(&self, i: usize, j: usize, k: usize) -> f64 {
        let cell = &self.log_values[(k * self.n[1] + j) * self.n[0] + i];
        let bits = cell.load(Ordering::Relaxed);
        if bits != UNSET {
            return f64::from(f32::from_bits(bits));
        }
        let x = [
            self.min[0] + i as f64 * self.h[0],
            self.min[1] + j as f64 * self.h[1],
            self.min[2] + k as f64 * self.h[2],
        ];
        let to_eye = [0, 1, 2].map(|d| self.eye[d] - x[d]);
        let r = to_eye.iter().map(|c| c * c).sum::<f64>().sqrt();
        let wo = if r > 0.0 {
            to_eye.map(|c| c / r)
        } else {
            [0.0, 0.0, 1.0]
        };
        let v = (self.s)(x, wo).max(1e-30).ln() as f32;
        cell.store(v.to_bits(), Ordering::Relaxed);
        f64::from(v)
    }

    /// `S_sky` at `x`: `exp` of ln S interpolated trilinearly between the nodes (clamped to
    /// the grid's box; module docs).
    #[inline]
    pub fn eval(&self, x: [f64; 3]) -> f64 {
        let mut i = [0usize; 3];
        let mut t = [0.0f64; 3];
        for d in 0..3 {
            let top = (self.n[d] - 1) as f64;
            let u = if self.h[d] > 0.0 {
                ((x[d] - self.min[d]) / self.h[d]).clamp(0.0, top)
            } else {
                0.0
            };
            let f = u.floor().min(top - 1.0);
            i[d] = f as usize;
            t[d] = u - f;
        }
        let at = |a: usize, b: usize, c: usize| self.log_at(i[0] + a, i[1] + b, i[2] + c);
        let lerp = |a: f64, b: f64, s: f64| a + s * (b - a);
        let x00 = lerp(at(0, 0, 0), at(1, 0, 0), t[0]);
        let x10 = lerp(at(0, 1, 0), at(1, 1, 0), t[0]);
        let x01 = lerp(at(0, 0, 1), at(1, 0, 1), t[0]);
        let x11 = lerp(at(0, 1, 1), at(1, 1, 1), t[0]);
        lerp(lerp(x00, x10, t[1]), lerp(x01, x11, t[1]), t[2]).exp()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn one_exponential_of_a_linear_function_is_reproduced_exactly() {
        // The transmittance of one direction through a homogeneous medium, e^{a + b·x}
        // (independent of ω_o): ln S is linear, its interpolation exact.
        let f = |x: [f64; 3]| (1.0 + 2.5 * x[0] - 1.25 * x[1] + 0.5 * x[2]).exp();
        let v = SkyView::new([-1.0; 3], [1.0; 3], 0.3, [0.0, 0.0, 5.0], |x, _| f(x));
        for p in [[0.1, -0.7, 0.33], [-1.0, 1.0, 0.999], [0.5, 0.5, -0.2]] {
            assert!((v.eval(p) / f(p) - 1.0).abs() < 1e-5, "{p:?}");
        }
        // Outside the box the value is clamped to the nearest face.
        assert!((v.eval([2.0, 0.0, 0.0]) / f([1.0, 0.0, 0.0]) - 1.0).abs() < 1e-5);
    }

    #[test]
    fn the_outgoing_direction_points_at_the_eye() {
        let eye = [0.0, 3.0, 0.0];
        let v = SkyView::new([-1.0; 3], [1.0; 3], 1.0, eye, |x, wo| {
            let r: f64 = (0..3).map(|d| (eye[d] - x[d]).powi(2)).sum::<f64>().sqrt();
            // 1 exactly when ω_o is the unit vector towards the eye.
            (0..3).map(|d| wo[d] * (eye[d] - x[d]) / r).sum()
        });
        for c in 0..27 {
            let p = [c % 3, c / 3 % 3, c / 9].map(|i| -1.0 + i as f64);
            assert!((v.eval(p) - 1.0).abs() < 1e-6, "{p:?}");
        }
    }

    #[test]
    fn the_node_count_is_bounded() {
        let v = SkyView::new([0.0; 3], [1.0; 3], 1e-4, [0.0, 0.0, 2.0], |_, _| 1.0);
        let [a, b, c] = v.nodes();
        assert!(a * b * c <= MAX_SKY_VIEW_NODES && a > 64, "{:?}", v.nodes());
    }

    #[test]
    fn only_the_nodes_read_are_computed() {
        let calls = std::sync::atomic::AtomicUsize::new(0);
        let v = SkyView::new([-1.0; 3], [1.0; 3], 0.1, [0.0, 0.0, 5.0], |_, _| {
            calls.fetch_add(1, Ordering::Relaxed);
            2.0
        });
        assert_eq!(v.computed(), 0);
        // One lookup reads its cell's 8 corners; a second in the same cell computes nothing.
        assert!((v.eval([0.03, 0.02, 0.01]) - 2.0).abs() < 1e-6);
        assert!((v.eval([0.04, 0.05, 0.06]) - 2.0).abs() < 1e-6);
        assert_eq!((v.computed(), calls.load(Ordering::Relaxed)), (8, 8));
    }

    #[test]
    fn the_error_falls_with_the_spacing_squared() {
        // A smooth field whose logarithm is not linear: halving h divides the worst error
        // by about 4 (the
        // worst error over a lattice of points, which the nodes do not hit).
        let f = |x: [f64; 3]| 2.0 + (1.3 * x[0]).sin() * (0.7 * x[1]).cos() + x[2] * x[2];
        let worst = |h: f64| {
            let v = SkyView::new([-1.0; 3], [1.0; 3], h, [0.0, 0.0, 5.0], |x, _| f(x));
            let mut e = 0.0f64;
            for c in 0..29 * 29 * 29 {
                let p = [c % 29, c / 29 % 29, c / 841].map(|i| -0.98 + 0.07 * i as f64);
                e = e.max((v.eval(p) - f(p)).abs());
            }
            e
        };
        // Over two halvings the observed order is 2.
        let order = (worst(0.4) / worst(0.1)).log2() / 2.0;
        assert!((1.7..2.3).contains(&order), "order {order}");
    }
}
