//! The joint bilateral upsampling of POP's coarse result (paper §4.4, after Kopf et al.,
//! "Joint bilateral upsampling", 2007), guided by the scattering coefficient σ_s.
//!
//! At a fine point x (a solve-cell centre) the value is `Σ_q w_q r_q A_q / Σ_q w_q r_q` over
//! the eight coarse cells q around x: `w_q` the trilinear weight (the spatial kernel: a tent
//! one coarse cell wide, as the plain resampling), `r_q = exp(−(σ_s(x) − σ_s(x_q))² / (2 σ_r²))`
//! the range kernel on the guidance, σ_s of the full-resolution medium read at x and at the
//! coarse cell's centre x_q (point samples, as Kopf et al. read the high-resolution guide at
//! both). σ_r is `pop_upsample_sigma` times the largest σ_s at the coarse centres, so the
//! filter does not depend on the medium's scale. Where every range weight underflows (no
//! coarse centre with a σ_s near σ_s(x)) the trilinear weights are kept.
//!
//! Properties (unit tests): a constant field is reproduced to rounding, whatever the guide;
//! at an edge of σ_s between two coarse centres the value on each side is its own side's,
//! where the trilinear resampling blurs it across the coarse cell.

/// The range kernel of the joint bilateral upsampling ([module docs](self)).
pub struct Bilateral<'a> {
    /// σ_s at each coarse cell's centre (storage index).
    pub coarse: Vec<f64>,
    /// σ_s of the full-resolution medium at a world point.
    pub guide: &'a (dyn Fn([f64; 3]) -> f64 + Sync),
    /// The range kernel's width σ_r (σ_s units).
    pub sigma: f64,
}

impl<'a> Bilateral<'a> {
    /// The kernel for a coarse grid of `cells` cells whose centres `centre` gives: σ_s read
    /// at every coarse centre, σ_r = `relative_sigma` × the largest of them. `None` where
    /// that is not a positive width (an empty medium: nothing to guide).
    pub fn new(
        cells: usize,
        centre: impl Fn(usize) -> [f64; 3],
        guide: &'a (dyn Fn([f64; 3]) -> f64 + Sync),
        relative_sigma: f64,
    ) -> Option<Bilateral<'a>> {
        let coarse: Vec<f64> = (0..cells).map(|c| guide(centre(c))).collect();
        let max = coarse.iter().fold(0.0f64, |m, v| m.max(*v));
        let sigma = relative_sigma * max;
        (sigma.is_finite() && sigma > 0.0).then_some(Bilateral {
            coarse,
            guide,
            sigma,
        })
    }

    /// Multiplies the trilinear `corners` around `x` by the range kernel and renormalises
    /// them (weights sum to 1); leaves them as they are where every product is 0.
    pub fn reweight(&self, x: [f64; 3], corners: &mut [(usize, f64); 8]) {
        let gx = (self.guide)(x);
        let inv = 1.0 / (2.0 * self.sigma * self.sigma);
        let mut next = *corners;
        let mut total = 0.0;
        for (c, w) in next.iter_mut() {
            let d = gx - self.coarse[*c];
            *w *= (-d * d * inv).exp();
            total += *w;
        }
        if total > 0.0 && total.is_finite() {
            for (_, w) in next.iter_mut() {
                *w /= total;
            }
            *corners = next;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Eight coarse cells 0..8 at x = 0 (cells 0..4, σ_s = 2) and x = 1 (cells 4..8,
    /// σ_s = 0); the guide is an edge at x = ½.
    fn edge_kernel(guide: &(dyn Fn([f64; 3]) -> f64 + Sync)) -> Bilateral<'_> {
        Bilateral::new(8, |c| [if c < 4 { 0.0 } else { 1.0 }, 0.0, 0.0], guide, 0.1).unwrap()
    }

    /// Trilinear weights of a point at x: 1 − x on the four cells at 0, x on those at 1.
    fn corners(x: f64) -> [(usize, f64); 8] {
        std::array::from_fn(|c| (c, if c < 4 { (1.0 - x) / 4.0 } else { x / 4.0 }))
    }

    /// At x = 0.3 (σ_s = 2) the trilinear weights put 0.3 on the cells across the edge;
    /// the range kernel (Δσ_s = 2, σ_r = 0.2: e^{−50}) moves all of it to the near side
    /// (1e−12), and at x = 0.7 to the other side.
    #[test]
    fn the_range_kernel_keeps_an_edge() {
        let guide = |x: [f64; 3]| if x[0] < 0.5 { 2.0 } else { 0.0 };
        let b = edge_kernel(&guide);
        assert!((b.sigma - 0.2).abs() < 1e-15);
        for (x, near) in [(0.3, 0..4), (0.7, 4..8)] {
            let mut c = corners(x);
            b.reweight([x, 0.0, 0.0], &mut c);
            let w: f64 = c[near].iter().map(|(_, w)| w).sum();
            assert!((w - 1.0).abs() < 1e-12, "x {x}: {c:?}");
        }
    }

    /// The weights stay normalised (1e−14) for a guide that varies wildly, so a constant
    /// field is reproduced; an empty medium has nothing to guide.
    #[test]
    fn weights_stay_normalised() {
        let wild = |x: [f64; 3]| (17.0 * x[0]).sin().abs() * 3.0 + (9.0 * x[0]).cos().powi(2);
        let b = edge_kernel(&wild);
        for x in [0.0, 0.13, 0.5, 0.77, 1.0] {
            let mut c = corners(x);
            b.reweight([x, 0.0, 0.0], &mut c);
            let total: f64 = c.iter().map(|(_, w)| w).sum();
            assert!((total - 1.0).abs() < 1e-14, "x {x}: {total}");
        }
        let zero = |_: [f64; 3]| 0.0;
        assert!(Bilateral::new(8, |_| [0.0; 3], &zero, 0.1).is_none());
    }
}
