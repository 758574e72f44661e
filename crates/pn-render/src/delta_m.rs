//! Delta-M truncation of a forward-peaked phase function for the solve (Wiscombe 1977), with
//! the single scattering seen by the camera kept exact (the TMS idea of Nakajima & Tanaka
//! 1988). docs/design.md §6 and `pn_runtime::phase` give the relations.
//!
//! A P_N solve of order N carries the phase's factors λ_l p_l for l ≤ N only. For a
//! forward-peaked phase (HG g = 0.877: g^6 ≈ 0.45) the first-scatter source
//! `σ_s T E λ_l p_l Y_l^m(d)` is then a truncated series of a sharp peak around the light's
//! direction d, which rings, and most of the light it carries is light that scattering
//! barely deflected. Delta-M splits the share `f = λ_{N+1} p_{N+1}` of every scattering
//! event off as a delta in the forward direction: that light travels on as if unscattered,
//! and the rest scatters with the truncated phase `p′_l = (λ_l p_l − f)/(1 − f)`, l ≤ N:
//!
//! ```text
//! σ_t′ = σ_t − f σ_s,   σ_s′ = (1 − f) σ_s,   T′ = exp(−∫ σ_t′)   (the light leg),
//! Q_l^m = σ_s′ T′ E p′_l Y_l^m(d) = σ_s (λ_l p_l − f) T′ E Y_l^m(d).
//! ```
//!
//! The P_N operator is unchanged (σ_t′ − σ_s′ p′_l = σ_t − σ_s p_l for l ≤ N); the
//! transport sweeps solve the truncated transport equation (σ_t′, σ_s′, p′). The radiance is
//! then `L ≈ T′ E δ(ω − d) + L′`, with L′ the solution, and the camera's last scattering
//! event is computed with the full phase on both parts:
//!
//! ```text
//! σ_s ∫ p(ω·ω′) L(ω′) dω′ ≈ σ_s p(d·ω) T′ E + σ_s Σ_{l ≤ N} λ_l p_l L′_l^m Y_l^m(ω),
//! ```
//!
//! with the camera ray's own attenuation σ_t. So the renderer reads the transmittance to the
//! lights from σ_t′ (this module's [`LightLeg`]) and the solution with the full phase's
//! factors; with f = 0 (isotropic scattering, g = 0, or delta-M switched off) everything is
//! exactly as without it. As N → ∞, f → 0: the truncation converges to transport.

use super::medium::DensityGrid;
use super::scene::{Albedo, RenderScene};
use super::shadow::Extinction;
use pn_runtime::problem::Phase;

/// The P_N order N and the forward-peak share f = λ_{N+1} p_{N+1} of the delta-M truncation
/// that a method carrying order `method_order` (`MultipleScattering::delta_m_order`) uses
/// for `scene`: None when the method has none, `[solve] delta_m = false`, or f = 0.
///
/// With `[solve] similarity = true` the truncation is at order 0 whatever the method's order:
/// f = λ_1 p_1 = g, the solve carries σ_s′ = (1 − g) σ_s and an isotropic phase — the
/// similarity relation σ_s′ (1 − g′) = σ_s (1 − g) with g′ = 0. For l ≥ 1 the P_N operator
/// then reads σ_t − g σ_s instead of σ_t − σ_s λ_l p_l, so unlike delta-M it does not
/// converge to transport as N grows (an ablation arm, off by default).
pub fn truncation(scene: &RenderScene, method_order: Option<u32>) -> Option<(u32, f64)> {
    let n = method_order.filter(|_| scene.solve.delta_m || scene.solve.similarity)?;
    let n = if scene.solve.similarity { 0 } else { n };
    let f = scene.phase.delta_m_fraction(n);
    (f > 0.0).then_some((n, f))
}

/// The extinction light travels through on its way from the lights to a scattering point:
/// σ_t′ = σ_t − f σ_s = σ_t (1 − f α) (σ_t without a truncation).
#[derive(Clone, Debug)]
pub struct LightLeg {
    /// The density times (1 − f α) per voxel, for a medium whose albedo varies per voxel
    /// (None: the scene's density, with the factor in `scale`).
    density: Option<DensityGrid>,
    /// σ_t′ per unit of the density read.
    scale: f64,
    /// The truncation's order N and share f ([`truncation`]; None: σ_t itself).
    truncation: Option<(u32, f64)>,
}

impl LightLeg {
    /// The light leg of `scene` without delta-M: σ_t itself.
    pub fn none(scene: &RenderScene) -> Self {
        Self {
            density: None,
            scale: scene.medium.sigma_t_scale,
            truncation: None,
        }
    }

    /// The light leg of `scene` under `truncation` ([`truncation`]; None: σ_t itself).
    pub fn new(scene: &RenderScene, density: &DensityGrid, truncation: Option<(u32, f64)>) -> Self {
        let Some((_, f)) = truncation else {
            return Self::none(scene);
        };
        let sigma_t_scale = scene.medium.sigma_t_scale;
        match &scene.medium.albedo {
            Albedo::Constant(a) => Self {
                density: None,
                scale: sigma_t_scale * (1.0 - f * a),
                truncation,
            },
            Albedo::Voxels(alpha) => {
                let mut scaled = density.clone();
                for (d, a) in scaled.data.iter_mut().zip(alpha.iter()) {
                    *d *= (1.0 - f * f64::from(*a)) as f32;
                }
                Self {
                    density: Some(scaled),
                    scale: sigma_t_scale,
                    truncation,
                }
            }
        }
    }

    /// The truncation's order N and share f (None without delta-M).
    pub fn truncation(&self) -> Option<(u32, f64)> {
        self.truncation
    }

    /// The phase the solve carries and f: `phase` truncated at N, or itself and 0.
    pub fn solve_phase(&self, phase: &Phase) -> (Phase, f64) {
        match self.truncation {
            Some((n, _)) => phase.delta_m(n),
            None => (phase.clone(), 0.0),
        }
    }

    /// The extinction of the light leg; `density` is the scene's density grid.
    pub fn extinction<'a>(&'a self, density: &'a DensityGrid) -> Extinction<'a> {
        Extinction {
            grid: self.density.as_ref().unwrap_or(density),
            scale: self.scale,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_light_leg_is_sigma_t_minus_f_sigma_s() {
        let mut scene = RenderScene::builtin("cloud").unwrap();
        scene.medium.albedo = Albedo::Constant(0.9);
        let density = scene.density_grid().unwrap();
        let x = [0.0, 0.0, 0.0];
        let (st, ss) = scene.medium.coefficients_at(&density, x);
        assert!(st > 0.0);
        let f = 0.3;
        let leg = LightLeg::new(&scene, &density, Some((5, f)));
        let e = leg.extinction(&density);
        assert!((e.sigma_t(x) - (st - f * ss)).abs() < 1e-9 * st);
        // Per-voxel albedo: the scaled density, the same σ_t′ at the voxel centres.
        let n = density.data.len();
        scene.medium.albedo = Albedo::Voxels(std::sync::Arc::new(vec![0.9f32; n]));
        let leg2 = LightLeg::new(&scene, &density, Some((5, f)));
        let e2 = leg2.extinction(&density);
        assert!((e2.sigma_t(x) - (st - f * ss)).abs() < 1e-6 * st);
        // No truncation: σ_t itself.
        let leg0 = LightLeg::new(&scene, &density, None);
        assert_eq!(leg0.extinction(&density).sigma_t(x), st);
    }

    #[test]
    fn truncation_needs_a_method_order_the_switch_and_a_forward_peak() {
        let mut scene = RenderScene::builtin("cloud").unwrap();
        scene.phase = Phase::HenyeyGreenstein(0.7);
        let (n, f) = truncation(&scene, Some(5)).unwrap();
        assert_eq!(n, 5);
        assert!((f - 0.7f64.powi(6)).abs() < 1e-15, "{f}");
        assert_eq!(truncation(&scene, None), None);
        scene.solve.delta_m = false;
        assert_eq!(truncation(&scene, Some(5)), None);
        scene.solve.delta_m = true;
        scene.phase = Phase::Isotropic;
        assert_eq!(truncation(&scene, Some(5)), None);
    }

    #[test]
    fn the_similarity_relation_is_the_truncation_at_order_zero() {
        let mut scene = RenderScene::builtin("cloud").unwrap();
        let g = 0.85;
        scene.phase = Phase::HenyeyGreenstein(g);
        scene.solve.similarity = true;
        // Whatever the solve's order, and with or without the delta-M switch.
        for delta_m in [true, false] {
            scene.solve.delta_m = delta_m;
            for order in [1, 3, 5] {
                let (n, f) = truncation(&scene, Some(order)).unwrap();
                assert_eq!(n, 0);
                assert!((f - g).abs() < 1e-15, "{f}");
            }
        }
        // The solve's phase is isotropic and σ_s′ (1 − g′) = σ_s (1 − g) with g′ = 0.
        let density = scene.density_grid().unwrap();
        let leg = LightLeg::new(&scene, &density, truncation(&scene, Some(3)));
        let (p, f) = leg.solve_phase(&scene.phase);
        assert!((p.moment(0) - 1.0).abs() < 1e-15);
        for l in 1..=3 {
            assert_eq!(p.moment(l), 0.0, "l = {l}");
        }
        let sigma_s = 2.0;
        assert!(((1.0 - f) * sigma_s - sigma_s * (1.0 - g)).abs() < 1e-15);
    }
}
