//! Lights (docs/design.md §6): directional (irradiance E on a plane perpendicular to its travel
//! direction) and point (power Φ, radiant intensity Φ/(4π), irradiance Φ/(4π r²)).

/// A light. Lights are not visible to the camera (no surfaces, background 0).
#[derive(Clone, Debug, PartialEq)]
pub enum Light {
    /// Parallel light travelling along `direction` (unit; from the light into the medium).
    Directional {
        /// Travel direction (unit vector).
        direction: [f64; 3],
        /// Irradiance on a plane perpendicular to `direction` (W/m²).
        irradiance: f64,
    },
    /// Isotropic point light.
    Point {
        /// Position.
        position: [f64; 3],
        /// Total emitted power Φ (W).
        power: f64,
    },
}

/// What a light delivers at a point, without attenuation.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Incident {
    /// Unit direction in which the light travels at the point (`d` of docs/design.md §6).
    pub travel: [f64; 3],
    /// Unattenuated irradiance E at the point.
    pub irradiance: f64,
    /// Distance to the light along −`travel` (infinite for a directional light).
    pub distance: f64,
}

impl Light {
    /// The unattenuated light at `x`. A point light at `x` itself (r = 0) delivers nothing
    /// (its irradiance Φ/(4π r²) is singular but integrable; a single point has measure 0).
    pub fn incident(&self, x: [f64; 3]) -> Incident {
        match self {
            Light::Directional {
                direction,
                irradiance,
            } => Incident {
                travel: *direction,
                irradiance: *irradiance,
                distance: f64::INFINITY,
            },
            Light::Point { position, power } => {
                let d = [x[0] - position[0], x[1] - position[1], x[2] - position[2]];
                let r2 = d[0] * d[0] + d[1] * d[1] + d[2] * d[2];
                if r2 == 0.0 {
                    return Incident {
                        travel: [0.0, 0.0, 1.0],
                        irradiance: 0.0,
                        distance: 0.0,
                    };
                }
                let r = r2.sqrt();
                Incident {
                    travel: d.map(|c| c / r),
                    irradiance: power / (4.0 * std::f64::consts::PI * r2),
                    distance: r,
                }
            }
        }
    }
}

impl Light {
    /// Its strength: the irradiance of a directional light, the power of a point light.
    pub fn strength(&self) -> f64 {
        match self {
            Light::Directional { irradiance, .. } => *irradiance,
            Light::Point { power, .. } => *power,
        }
    }

    /// The same light with another strength ([`Light::strength`]).
    pub fn with_strength(&self, strength: f64) -> Light {
        match *self {
            Light::Directional { direction, .. } => Light::Directional {
                direction,
                irradiance: strength,
            },
            Light::Point { position, .. } => Light::Point {
                position,
                power: strength,
            },
        }
    }
}

/// The phase function value p(μ) for the cosine μ between the two **propagation**
/// directions (incoming travel direction and outgoing direction), normalised over the sphere
/// (docs/design.md §2: ∫p = 1; HG with λ_l p_l = g^l).
pub fn phase_value(phase: &pn_runtime::problem::Phase, mu: f64) -> f64 {
    phase.value(mu)
}

#[cfg(test)]
mod tests {
    use super::*;
    use pn_runtime::problem::Phase;

    #[test]
    fn point_light_falls_off_with_inverse_square() {
        let l = Light::Point {
            position: [1.0, 0.0, 0.0],
            power: 4.0 * std::f64::consts::PI,
        };
        let i = l.incident([1.0, 2.0, 0.0]);
        assert!((i.irradiance - 0.25).abs() < 1e-15);
        assert_eq!(i.travel, [0.0, 1.0, 0.0]);
        assert_eq!(i.distance, 2.0);
    }

    #[test]
    fn phase_functions_are_normalised_and_hg_is_forward_for_positive_g() {
        let q = pn_stencil::quadrature::gauss_legendre(64);
        for phase in [Phase::Isotropic, Phase::HenyeyGreenstein(0.6)] {
            let s: f64 =
                q.0.iter()
                    .zip(&q.1)
                    .map(|(mu, w)| w * 2.0 * std::f64::consts::PI * phase_value(&phase, *mu))
                    .sum();
            assert!((s - 1.0).abs() < 1e-6, "{phase:?}: {s}");
        }
        let hg = Phase::HenyeyGreenstein(0.6);
        assert!(phase_value(&hg, 1.0) > phase_value(&hg, -1.0));
    }
}
