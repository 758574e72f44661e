//! The Monte Carlo renderer (`--renderer montecarlo`; the default is the deterministic
//! [`super::march`]): camera rays, free-flight sampling by **delta tracking with the global
//! majorant** (unbiased; the majorant is `sigma_t_scale × max density`, which bounds the
//! trilinear field too: a trilinear value is a convex combination of voxel values), σ_t and
//! the albedo read at the point with the grid's filter ([`DensityGrid::density_at`],
//! [`super::scene::MediumSpec::coefficients_at`]), and at the first real collision the
//! collision estimate
//!
//! ```text
//! albedo(x) · [ Σ_lights p(d·ω_o) T(x, light) E(x)            (single scattering, NEE)
//!             + Σ_{l,m} λ_l p_l L_l^m(x) Y_l^m(ω_o) ]          (multiple scattering)
//! ```
//!
//! after which the path terminates: the solution L_ms (docs/design.md §6) carries all higher
//! orders. ω_o is the direction towards the camera (minus the ray direction), d the light's
//! travel direction at x; T is exact (voxel traversal, [`super::shadow`]); L_l^m is the
//! un-staggered solution, trilinear between solve-cell centres (clamped at the outermost
//! centres, 0 outside the solve grid). FLD and CDA give L_0^0 only (the isotropic part).
//! Without a solution (method "none") the image is single scattering only.
//!
//! Why this estimates the radiance: L(cam, ω_o) = ∫ T(cam,x) σ_s(x) S(x) dt with S the
//! in-scattered radiance per unit σ_s; delta tracking samples x with density T σ_t, so the
//! weight is σ_s/σ_t · S = albedo · S.
//!
//! Deterministic: each pixel has its own random stream seeded from (seed, pixel index), so
//! the image does not depend on the number of threads.

use super::lights::phase_value;
use super::medium::DensityGrid;
use super::scene::{MsLookup, RenderScene};
use super::shadow::Extinction;
use crate::progress::{ProgressCallback, RowCounter};
use pn_runtime::field::trilinear_corners;
use pn_runtime::problem::{Grid, Phase};
use pn_runtime::CellMoments;
use pn_stencil::quadrature::real_sh;
use rayon::prelude::*;

/// A single-channel image with per-pixel standard errors.
#[derive(Clone, Debug, PartialEq)]
pub struct Image {
    /// Width in pixels.
    pub width: usize,
    /// Height in pixels.
    pub height: usize,
    /// Radiance per pixel, row-major from the top-left pixel.
    pub data: Vec<f32>,
    /// Standard error of each pixel mean (sample standard deviation / √spp; 0 for spp = 1).
    pub std_err: Vec<f32>,
}

/// The multiple-scattering solution prepared for lookups.
#[derive(Clone, Debug)]
pub struct MsField {
    /// Solve grid.
    pub grid: Grid,
    /// Moments at the cell centres (`per_cell = (lmax+1)²`).
    pub moments: CellMoments,
    /// Phase function (for λ_l p_l).
    pub phase: Phase,
    /// How values between the cell centres are read.
    pub lookup: MsLookup,
}

impl MsField {
    /// Wraps a solution; checks that the moment array fits the grid.
    pub fn new(grid: Grid, moments: CellMoments, phase: Phase) -> anyhow::Result<Self> {
        anyhow::ensure!(
            moments.res == grid.res && moments.data.len() == grid.cells() * moments.per_cell,
            "solution of {:?} cells × {} moments does not fit the grid {:?}",
            moments.res,
            moments.per_cell,
            grid.res
        );
        Ok(Self {
            grid,
            moments,
            phase,
            lookup: MsLookup::Trilinear,
        })
    }

    /// Highest band carried.
    pub fn lmax(&self) -> usize {
        (self.moments.per_cell as f64).sqrt().round() as usize - 1
    }

    /// `λ_l p_l Y_l^m(ω_o)` for every moment index `l(l+1)+m`.
    pub fn coefficients(&self, wo: [f64; 3]) -> Vec<f64> {
        let lmax = self.lmax();
        let mu = wo[2].clamp(-1.0, 1.0);
        let phi = wo[1].atan2(wo[0]);
        let mut c = vec![0.0; self.moments.per_cell];
        for l in 0..=lmax {
            let f = self.phase.moment(l as u32);
            if f == 0.0 {
                continue;
            }
            for m in -(l as i64)..=(l as i64) {
                c[(l as i64 * (l as i64 + 1) + m) as usize] = f * real_sh(l, m, mu, phi);
            }
        }
        c
    }

    /// Reads values between the cell centres with `lookup`.
    pub fn with_lookup(mut self, lookup: MsLookup) -> Self {
        self.lookup = lookup;
        self
    }

    /// `Σ_{l,m} coeffs[l(l+1)+m] · L_l^m(x)`, trilinear between cell centres (clamped), or
    /// the containing cell's value for [`MsLookup::Nearest`]; 0 outside the grid.
    pub fn inscatter(&self, x: [f64; 3], coeffs: &[f64]) -> f64 {
        let g = &self.grid;
        if (0..3).any(|d| !(x[d] >= g.min[d] && x[d] <= g.max[d])) {
            return 0.0;
        }
        let pc = self.moments.per_cell;
        let [_, ny, nz] = g.res;
        if self.lookup == MsLookup::Nearest {
            let idx: [usize; 3] =
                std::array::from_fn(|d| (((x[d] - g.min[d]) / g.h(d)) as usize).min(g.res[d] - 1));
            let base = ((idx[0] * ny + idx[1]) * nz + idx[2]) * pc;
            let cell = &self.moments.data[base..base + pc];
            return cell.iter().zip(coeffs).map(|(a, b)| a * b).sum();
        }
        let h = [0, 1, 2].map(|d| g.h(d));
        let mut sum = 0.0;
        for (idx, w) in trilinear_corners(x, g.min, h, g.res) {
            if w == 0.0 {
                continue;
            }
            let base = ((idx[0] * ny + idx[1]) * nz + idx[2]) * pc;
            let cell = &self.moments.data[base..base + pc];
            sum += w * cell.iter().zip(coeffs).map(|(a, b)| a * b).sum::<f64>();
        }
        sum
    }
}

/// SplitMix64: a small, fast, seedable generator (one stream per pixel).
#[derive(Clone, Debug)]
pub struct Rng(u64);

impl Rng {
    /// A stream for `(seed, index)`.
    pub fn new(seed: u64, index: u64) -> Self {
        let mut r = Rng(seed ^ index.wrapping_mul(0xd1b5_4a32_d192_ed03));
        r.next_u64();
        r
    }

    /// Next 64 random bits.
    pub fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9e37_79b9_7f4a_7c15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        z ^ (z >> 31)
    }

    /// Uniform in [0, 1).
    pub fn uniform(&mut self) -> f64 {
        (self.next_u64() >> 11) as f64 / (1u64 << 53) as f64
    }
}

/// What one render needs.
pub struct Renderer<'a> {
    /// The scene (camera, lights, phase, albedo).
    pub scene: &'a RenderScene,
    /// Its density grid.
    pub density: &'a DensityGrid,
    /// The multiple-scattering solution (None: single scattering only).
    pub ms: Option<&'a MsField>,
    /// The extinction on the way to the lights (delta-M's σ_t′, [`crate::delta_m`]; None:
    /// σ_t).
    pub light_leg: Option<&'a crate::LightLeg>,
}

impl Renderer<'_> {
    /// The global majorant σ_t,max (a pass over every voxel: compute it once per image).
    pub fn majorant(&self) -> f64 {
        Extinction {
            grid: self.density,
            scale: self.scene.medium.sigma_t_scale,
        }
        .majorant()
    }

    /// In-scattered radiance estimate of one camera ray (one sample; finds the majorant
    /// first, see [`Self::sample_with_majorant`] for many samples).
    pub fn sample(&self, origin: [f64; 3], dir: [f64; 3], rng: &mut Rng) -> f64 {
        self.sample_with_majorant(origin, dir, self.majorant(), rng)
    }

    /// [`Self::sample`] with the majorant of [`Self::majorant`] given.
    pub fn sample_with_majorant(
        &self,
        origin: [f64; 3],
        dir: [f64; 3],
        majorant: f64,
        rng: &mut Rng,
    ) -> f64 {
        let ext = Extinction {
            grid: self.density,
            scale: self.scene.medium.sigma_t_scale,
        };
        // The sky seen along the ray (unless hidden): the ray escapes with probability T.
        let background = match (&self.scene.sky, self.scene.render.hide_emitters) {
            (Some(sky), false) => sky.radiance(dir),
            _ => 0.0,
        };
        if majorant <= 0.0 {
            return background;
        }
        let Some((t0, t1)) = ext.clip(origin, dir, f64::INFINITY) else {
            return background;
        };
        let mut t = t0;
        loop {
            t -= (1.0 - rng.uniform()).ln() / majorant;
            if t >= t1 {
                return background;
            }
            let x = [0, 1, 2].map(|d| origin[d] + t * dir[d]);
            let (sigma_t, sigma_s) = self.scene.medium.coefficients_at(self.density, x);
            if rng.uniform() * majorant >= sigma_t {
                continue; // null collision
            }
            if sigma_s == 0.0 {
                return 0.0;
            }
            let albedo = sigma_s / sigma_t;
            let wo = dir.map(|c| -c);
            let light_ext = match self.light_leg {
                Some(leg) => leg.extinction(self.density),
                None => ext.clone(),
            };
            return albedo * (self.single(&light_ext, x, wo) + self.multiple(x, wo));
        }
    }

    /// Σ_lights p(d·ω_o) T(x, light) E(x).
    fn single(&self, ext: &Extinction, x: [f64; 3], wo: [f64; 3]) -> f64 {
        let mut s = 0.0;
        let sky_lights = self.scene.sky_lights.as_deref();
        for (li, light) in self.scene.lights.iter().enumerate() {
            let inc = light.incident(x);
            if inc.irradiance == 0.0 {
                continue;
            }
            let cos = inc.travel[0] * wo[0] + inc.travel[1] * wo[1] + inc.travel[2] * wo[2];
            let p = match sky_lights {
                Some(sky) => sky.phase_value(&self.scene.phase, li, cos),
                None => phase_value(&self.scene.phase, cos),
            };
            s += p * ext.transmittance_to(x, light) * inc.irradiance;
        }
        s
    }

    fn multiple(&self, x: [f64; 3], wo: [f64; 3]) -> f64 {
        match self.ms {
            Some(ms) => ms.inscatter(x, &ms.coefficients(wo)),
            None => 0.0,
        }
    }

    /// Mean and standard error of pixel (px, py) with `spp` samples.
    pub fn pixel(&self, px: usize, py: usize, spp: usize, seed: u64) -> (f64, f64) {
        self.pixel_with_majorant(px, py, spp, seed, self.majorant())
    }

    /// [`Self::pixel`] with the majorant given (the renderer finds it once per image: it
    /// is a pass over every voxel).
    fn pixel_with_majorant(
        &self,
        px: usize,
        py: usize,
        spp: usize,
        seed: u64,
        majorant: f64,
    ) -> (f64, f64) {
        let cam = &self.scene.camera;
        let frame = cam.frame();
        let mut rng = Rng::new(seed, (py * cam.width + px) as u64);
        let (mut sum, mut sum2) = (0.0, 0.0);
        for _ in 0..spp {
            let (sx, sy) = if spp == 1 {
                (0.5, 0.5)
            } else {
                (rng.uniform(), rng.uniform())
            };
            let dir = cam.ray_dir(&frame, px as f64 + sx, py as f64 + sy);
            let v = self.sample_with_majorant(cam.position, dir, majorant, &mut rng);
            sum += v;
            sum2 += v * v;
        }
        let n = spp as f64;
        let mean = sum / n;
        let var = if spp > 1 {
            ((sum2 - n * mean * mean) / (n - 1.0)).max(0.0)
        } else {
            0.0
        };
        (mean, (var / n).sqrt())
    }

    /// Renders the image with `spp` samples per pixel, rows in parallel; `rows` hears of the
    /// finished rows.
    pub fn render(&self, spp: usize, seed: u64, rows: Option<&ProgressCallback>) -> Image {
        let cam = &self.scene.camera;
        let (w, h) = (cam.width, cam.height);
        let majorant = self.majorant();
        let counter = RowCounter::start(rows, h);
        let rows: Vec<Vec<(f64, f64)>> = (0..h)
            .into_par_iter()
            .map(|py| {
                let row = (0..w)
                    .map(|px| self.pixel_with_majorant(px, py, spp, seed, majorant))
                    .collect();
                counter.row_done();
                row
            })
            .collect();
        let (data, std_err) = rows
            .into_iter()
            .flatten()
            .map(|(m, s)| (m as f32, s as f32))
            .unzip();
        Image {
            width: w,
            height: h,
            data,
            std_err,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use pn_stencil::Dim;

    fn field(phase: Phase) -> MsField {
        // 4×3×2 cells on [0,4]×[0,3]×[0,2]; L_0^0 = 1 + x (at the centres), L_1^0 = 2.
        let grid = Grid {
            dim: Dim::Three,
            min: [0.0; 3],
            max: [4.0, 3.0, 2.0],
            res: [4, 3, 2],
        };
        let mut data = vec![0.0; 24 * 4];
        for i in 0..4 {
            for c in 0..6 {
                let base = (i * 6 + c) * 4;
                data[base] = 1.0 + (i as f64 + 0.5);
                data[base + 2] = 2.0;
            }
        }
        let moments = CellMoments {
            res: grid.res,
            per_cell: 4,
            data,
        };
        MsField::new(grid, moments, phase).unwrap()
    }

    #[test]
    fn inscatter_is_the_phase_convolved_expansion() {
        let y00 = 1.0 / (4.0 * std::f64::consts::PI).sqrt();
        let iso = field(Phase::Isotropic);
        let c = iso.coefficients([0.0, 0.0, 1.0]);
        // Isotropic: L_0^0 Y_0^0 = φ/(4π); linear in x, so trilinear is exact inside.
        assert!((iso.inscatter([1.7, 1.2, 0.9], &c) - 2.7 * y00).abs() < 1e-14);
        // Clamped beyond the outermost centres, 0 outside the grid.
        assert!((iso.inscatter([0.1, 1.0, 1.0], &c) - 1.5 * y00).abs() < 1e-14);
        assert_eq!(iso.inscatter([4.5, 1.0, 1.0], &c), 0.0);
        // HG g: the l = 1 term g·L_1^0·Y_1^0(ω_o) with Y_1^0 = √(3/4π) ω_z.
        let hg = field(Phase::HenyeyGreenstein(0.5));
        let wo = [0.6, 0.0, 0.8];
        let c = hg.coefficients(wo);
        let want = 2.7 * y00 + 0.5 * 2.0 * (3.0 / (4.0 * std::f64::consts::PI)).sqrt() * 0.8;
        assert!((hg.inscatter([1.7, 1.2, 0.9], &c) - want).abs() < 1e-14);
    }

    #[test]
    fn pixel_streams_are_deterministic() {
        let mut a = Rng::new(3, 17);
        let mut b = Rng::new(3, 17);
        let mut c = Rng::new(3, 18);
        let (x, y, z) = (a.uniform(), b.uniform(), c.uniform());
        assert_eq!(x, y);
        assert_ne!(x, z);
        assert!((0.0..1.0).contains(&x));
    }
}
