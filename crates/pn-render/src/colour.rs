//! Coloured media and lights: values given per channel (R, G, B), as Mitsuba's `rgb` values.
//!
//! A coloured scene is rendered as three grey scenes, one per channel
//! ([`super::RenderScene::channel`]): radiative transfer does not couple wavelengths, so each
//! channel is the grey problem with that channel's σ_t scale, albedo and light strengths.
//! Channels with equal values are solved and rendered once; a channel that differs from an
//! earlier one only by a common factor on all light strengths is that channel scaled.

use serde::de::{self, Deserializer, SeqAccess, Visitor};
use serde::Deserialize;

/// The channel names, in order.
pub const CHANNELS: [&str; 3] = ["R", "G", "B"];

/// A scene value that is either one number for every channel or one per channel.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum GreyOrRgb {
    /// The same value in R, G and B.
    Grey(f64),
    /// `[r, g, b]`.
    Rgb([f64; 3]),
}

impl GreyOrRgb {
    /// The three channel values.
    pub fn channels(self) -> [f64; 3] {
        match self {
            GreyOrRgb::Grey(v) => [v; 3],
            GreyOrRgb::Rgb(c) => c,
        }
    }

    /// Whether the value was given per channel (`[r, g, b]`, even with equal entries).
    pub fn is_rgb(self) -> bool {
        matches!(self, GreyOrRgb::Rgb(_))
    }
}

impl<'de> Deserialize<'de> for GreyOrRgb {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        struct V;
        impl<'de> Visitor<'de> for V {
            type Value = GreyOrRgb;
            fn expecting(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
                f.write_str("a number or an [r, g, b] array of three numbers")
            }
            fn visit_f64<E: de::Error>(self, v: f64) -> Result<GreyOrRgb, E> {
                Ok(GreyOrRgb::Grey(v))
            }
            fn visit_i64<E: de::Error>(self, v: i64) -> Result<GreyOrRgb, E> {
                Ok(GreyOrRgb::Grey(v as f64))
            }
            fn visit_u64<E: de::Error>(self, v: u64) -> Result<GreyOrRgb, E> {
                Ok(GreyOrRgb::Grey(v as f64))
            }
            fn visit_seq<A: SeqAccess<'de>>(self, mut seq: A) -> Result<GreyOrRgb, A::Error> {
                let mut c = [0.0; 3];
                for (i, slot) in c.iter_mut().enumerate() {
                    *slot = seq
                        .next_element::<f64>()?
                        .ok_or_else(|| de::Error::invalid_length(i, &self))?;
                }
                if seq.next_element::<de::IgnoredAny>()?.is_some() {
                    return Err(de::Error::invalid_length(4, &self));
                }
                Ok(GreyOrRgb::Rgb(c))
            }
        }
        d.deserialize_any(V)
    }
}

/// The per-channel values of a coloured scene (what [`super::RenderScene::channel`] puts into
/// each grey channel scene).
#[derive(Clone, Debug, PartialEq)]
pub struct Colours {
    /// σ_t scale per channel (σ_t = scale · density).
    pub sigma_t_scale: [f64; 3],
    /// A constant albedo per channel; `None`: the medium's grey albedo (a constant or a grid)
    /// in every channel.
    pub albedo: Option<[f64; 3]>,
    /// Per light, in scene order: its irradiance (directional) or power (point) per channel.
    pub light_strength: Vec<[f64; 3]>,
}

impl Colours {
    /// The factor k with channel `c` = k × channel `p`, when the two have the same medium
    /// (σ_t scale and albedo) and every light's strength in `c` is k times its strength in
    /// `p` (transport is linear in the sources: the solution and the image scale by k).
    /// `None` otherwise, or when `p` has no light (k undefined).
    pub fn light_scale(&self, p: usize, c: usize) -> Option<f64> {
        if self.sigma_t_scale[p] != self.sigma_t_scale[c]
            || self.albedo.map(|a| a[p]) != self.albedo.map(|a| a[c])
        {
            return None;
        }
        let first = self.light_strength.iter().find(|l| l[p] != 0.0)?;
        let k = first[c] / first[p];
        self.light_strength
            .iter()
            .all(|l| l[c] == k * l[p])
            .then_some(k)
    }

    /// Whether σ_t is the same in every channel (then transmittance is achromatic).
    pub fn achromatic_sigma_t(&self) -> bool {
        let s = self.sigma_t_scale;
        s[0] == s[1] && s[1] == s[2]
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[derive(Deserialize, Debug)]
    struct T {
        v: GreyOrRgb,
    }

    fn parse(s: &str) -> Result<GreyOrRgb, String> {
        toml::from_str::<T>(s)
            .map(|t| t.v)
            .map_err(|e| e.to_string())
    }

    #[test]
    fn numbers_and_triples_parse_and_others_are_refused() {
        assert_eq!(parse("v = 2").unwrap(), GreyOrRgb::Grey(2.0));
        assert_eq!(parse("v = 0.5").unwrap(), GreyOrRgb::Grey(0.5));
        assert_eq!(
            parse("v = [1, 0.5, 0.25]").unwrap(),
            GreyOrRgb::Rgb([1.0, 0.5, 0.25])
        );
        for bad in [
            "v = [1, 2]",
            "v = [1, 2, 3, 4]",
            "v = \"red\"",
            "v = [1, \"x\", 2]",
        ] {
            let e = parse(bad).unwrap_err();
            assert!(
                e.contains("three numbers") || e.contains("invalid type"),
                "{bad}: {e}"
            );
        }
        assert_eq!(GreyOrRgb::Grey(0.3).channels(), [0.3; 3]);
        assert!(GreyOrRgb::Rgb([0.3; 3]).is_rgb() && !GreyOrRgb::Grey(0.3).is_rgb());
    }

    #[test]
    fn light_scale_needs_one_medium_and_proportional_lights() {
        let c = Colours {
            sigma_t_scale: [2.0, 2.0, 3.0],
            albedo: Some([0.9, 0.9, 0.9]),
            light_strength: vec![[1.0, 0.5, 0.25], [4.0, 2.0, 1.0]],
        };
        assert_eq!(c.light_scale(0, 1), Some(0.5));
        assert_eq!(c.light_scale(0, 0), Some(1.0));
        assert_eq!(c.light_scale(0, 2), None, "σ_t differs");
        let mixed = Colours {
            light_strength: vec![[1.0, 0.5, 0.25], [4.0, 4.0, 1.0]],
            ..c.clone()
        };
        assert_eq!(mixed.light_scale(0, 1), None, "the lights' colours differ");
        let dark = Colours {
            light_strength: vec![[0.0, 1.0, 1.0]],
            ..c
        };
        assert_eq!(dark.light_scale(0, 1), None);
        assert_eq!(dark.light_scale(1, 0), Some(0.0));
    }
}
