//! Sky lights (issue 50, docs/design.md §6.1): a uniform sky (`constant`) and a
//! latitude–longitude environment map (`envmap`), in Mitsuba 3's conventions, and how the
//! renderer turns either into a deterministic set of directional lights.
//!
//! **Convention** (Mitsuba's `envmap`, checked direction by direction against Mitsuba
//! 3.9.1's `eval`, python/tests/test_mitsuba_sky.py: 1.4e-5 relative with float32 texels, a
//! scale and a rotation; tests/mitsuba_sky.rs renders a one-patch map against Mitsuba): a
//! map of W × H texels, row 0 at the top. A
//! direction v in the map's frame (the *looking* direction, from the medium towards the
//! sky) has u = atan2(v_x, −v_z)/2π (mod 1) and v = acos(v_y)/π, i.e. v = (sin θ sin φ,
//! cos θ, −sin θ cos φ). The radiance is bilinear in the texels: horizontally between
//! texel centres (u = (i + ½)/W, periodic), vertically between rows placed at
//! θ = jπ/(H − 1) (row 0 at +Y, row H − 1 at −Y). `to_world` rotates the map's frame into
//! the world (world = R · local); `scale` multiplies the radiance.
//!
//! **Sky → directional lights** ([`Sky::lights`]). The sphere is cut into K regions of
//! about equal power by median cut (Debevec 2005) on a latitude–longitude grid of cells
//! (twice the map's resolution, at least 256 × 128, at most 1024 × 512), each cell's radiance
//! taken at its centre: a region is split across its longer angular side where its
//! power is halved, the region of largest power first. Each region becomes a directional
//! light whose irradiance is the region's ∫ L dω (per channel) and whose travel direction
//! is minus the power-weighted mean looking direction. So the sky's first-scatter source,
//! its shadows and its multiple scattering go through the same exact machinery as a sun;
//! nothing is sampled at random. The error is that of a K-point quadrature of
//! ∫ p(ω·ω_o) L(ω) T(x, ω) dω: it vanishes where L·T is constant over each region and
//! shrinks as K grows (measured in docs/sky.md).
//!
//! **Averages over each region.** The first-scatter source reads, for a sky light, the
//! spherical harmonics averaged over its region with the sky's radiance as weight
//! ([`SkyLights::sh_average`], over [`BLOCKS_PER_SIDE`]² blocks): exact where L·T is constant
//! on the region. A forward-peaked phase function varies faster than a region is wide, so
//! the camera's single scattering reads, for a sky light, the phase function averaged over
//! a cone of the region's solid angle about its direction ([`CapPhase`]). (Averaging p over
//! the region itself was measured and rejected: where the forward peak looks through the
//! medium, T at the region's direction is larger than along the peak, and a K = 32 cut of a
//! sky under an HG g = 0.8 medium came out 27 % too bright, against −7.5 % with the cone and
//! −0.7 % / +0.1 % with the cone at K = 64 / 256; docs/sky.md.) Both tend to p and Y_l^m(d)
//! as the regions shrink.

use crate::camera::norm;
use anyhow::{bail, ensure, Context};
use pn_runtime::problem::Phase;
use std::f64::consts::PI;
use std::path::PathBuf;
use std::sync::Arc;

/// Largest environment map accepted (texels): 4096 × 2048, 100 MB as f32 RGB.
pub const MAX_ENVMAP_TEXELS: usize = 4096 * 2048;
/// Default number of directional lights a sky is cut into ([`Sky::lights`]).
pub const DEFAULT_SKY_DIRECTIONS: usize = 64;
/// Most directional lights a sky may be cut into.
pub const MAX_SKY_DIRECTIONS: usize = 4096;

/// A latitude–longitude environment map (module docs), linear RGB.
#[derive(Clone, Debug, PartialEq)]
pub struct EnvMap {
    width: usize,
    height: usize,
    /// Row-major from the top-left texel.
    texels: Vec<[f32; 3]>,
}

impl EnvMap {
    /// A map of `width` × `height` texels (row-major from the top left). Refuses maps that
    /// are not 2:1, smaller than 4 × 2 (Mitsuba needs 3 rows: 6 × 3 is the least), larger
    /// than [`MAX_ENVMAP_TEXELS`], or with a NaN, infinite or negative texel (naming it).
    pub fn new(width: usize, height: usize, texels: Vec<[f32; 3]>) -> anyhow::Result<Self> {
        ensure!(
            width == 2 * height,
            "an environment map must be twice as wide as high (latitude–longitude), got \
             {width} × {height}"
        );
        ensure!(
            height >= 3,
            "an environment map needs at least 3 rows (6 × 3 texels), got {width} × {height}"
        );
        check_envmap_size(width, height)?;
        ensure!(
            texels.len() == width * height,
            "an environment map of {width} × {height} needs {} texels, got {}",
            width * height,
            texels.len()
        );
        if let Some(i) = texels
            .iter()
            .position(|t| t.iter().any(|c| !c.is_finite() || *c < 0.0))
        {
            bail!(
                "texel (row {}, column {}) is {:?}: radiance must be finite and non-negative",
                i / width,
                i % width,
                texels[i]
            );
        }
        Ok(Self {
            width,
            height,
            texels,
        })
    }

    /// Width and height in texels.
    pub fn size(&self) -> (usize, usize) {
        (self.width, self.height)
    }

    /// The texels, row-major from the top left.
    pub fn texels(&self) -> &[[f32; 3]] {
        &self.texels
    }

    /// The radiance towards the looking direction `v` of the map's frame (unit; module
    /// docs: Mitsuba's bilinear lookup).
    pub fn eval(&self, v: [f64; 3]) -> [f64; 3] {
        let (w, h) = (self.width, self.height);
        let mut u = v[0].atan2(-v[2]) / (2.0 * PI) - 0.5 / w as f64;
        u -= u.floor();
        let t = v[1].clamp(-1.0, 1.0).acos() / PI;
        let x = u * w as f64;
        let y = t * (h - 1) as f64;
        let (i0, j0) = ((x as usize).min(w - 1), (y as usize).min(h - 2));
        let (fx, fy) = (x - i0 as f64, y - j0 as f64);
        let i1 = (i0 + 1) % w;
        let at = |i: usize, j: usize| self.texels[j * w + i];
        let mut out = [0.0; 3];
        for (c, o) in out.iter_mut().enumerate() {
            let top = at(i0, j0)[c] as f64 * (1.0 - fx) + at(i1, j0)[c] as f64 * fx;
            let bottom = at(i0, j0 + 1)[c] as f64 * (1.0 - fx) + at(i1, j0 + 1)[c] as f64 * fx;
            *o = top * (1.0 - fy) + bottom * fy;
        }
        out
    }
}

/// What a sky radiates, before `scale`.
#[derive(Clone, Debug, PartialEq)]
pub enum SkyRadiance {
    /// The same radiance from every direction (RGB; equal channels for grey).
    Constant([f64; 3]),
    /// An environment map.
    Map(Arc<EnvMap>),
}

/// A sky: light arriving from every direction at infinity (module docs).
#[derive(Clone, Debug, PartialEq)]
pub struct Sky {
    /// The radiance.
    pub radiance: SkyRadiance,
    /// Multiplies the radiance.
    pub scale: f64,
    /// Rotation from the map's frame into the world (`world = to_world · local`, rows).
    pub to_world: [[f64; 3]; 3],
    /// How many directional lights the renderer cuts it into ([`Sky::lights`]).
    pub directions: usize,
    /// The file the map came from (for messages and the Mitsuba export's name).
    pub file: Option<PathBuf>,
    /// The channel a channel scene reads ([`Sky::channel`]); `None`: the mean of R, G, B.
    pub channel: Option<usize>,
}

/// One of the directional lights a sky is cut into.
#[derive(Clone, Debug, PartialEq)]
pub struct SkyLight {
    /// Travel direction (unit): minus the region's mean looking direction.
    pub travel: [f64; 3],
    /// ∫ L dω over the region, per channel (scale applied).
    pub irradiance: [f64; 3],
    /// The region's solid angle (sr).
    pub solid_angle: f64,
    /// The region in at most [`BLOCKS_PER_SIDE`]² blocks of cells: each block's
    /// power-weighted mean travel direction (unit, world) and its share of the region's grey
    /// power (the shares sum to 1). The renderer averages the phase function and the
    /// spherical harmonics over them ([`SkyLights::sh_average`]).
    pub blocks: Vec<([f64; 3], f64)>,
}

/// Blocks per side a sky light's region is summarised by ([`SkyLight::blocks`]).
pub const BLOCKS_PER_SIDE: usize = 8;

/// The identity rotation.
pub const IDENTITY: [[f64; 3]; 3] = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];

/// The rotation taking +Y to the unit vector `up` by the shortest arc (Rodrigues), for a
/// sky's `up` key.
pub fn rotation_to_up(up: [f64; 3]) -> anyhow::Result<[[f64; 3]; 3]> {
    let n = norm(up);
    ensure!(
        n.is_finite() && n > 0.0,
        "up must be a finite non-zero vector, got {up:?}"
    );
    let b = up.map(|c| c / n);
    let c = b[1]; // cos of the angle between +Y and b
    if c > 1.0 - 1e-15 {
        return Ok(IDENTITY);
    }
    if c < -1.0 + 1e-15 {
        // Half a turn about +X.
        return Ok([[1.0, 0.0, 0.0], [0.0, -1.0, 0.0], [0.0, 0.0, -1.0]]);
    }
    // Axis k = (Y × b)/|Y × b|, angle acos(c): R = I + [v]× + [v]×²/(1 + c) with v = Y × b.
    let v = [b[2], 0.0, -b[0]];
    let k = 1.0 / (1.0 + c);
    let vx = [[0.0, -v[2], v[1]], [v[2], 0.0, -v[0]], [-v[1], v[0], 0.0]];
    let mut r = IDENTITY;
    for (i, row) in r.iter_mut().enumerate() {
        for (j, e) in row.iter_mut().enumerate() {
            let sq: f64 = (0..3).map(|m| vx[i][m] * vx[m][j]).sum();
            *e += vx[i][j] + k * sq;
        }
    }
    Ok(r)
}

/// Checks that `m` is orthonormal (rows of unit length, mutually orthogonal, to 1e-6).
pub fn check_rotation(m: &[[f64; 3]; 3]) -> anyhow::Result<()> {
    for (i, row) in m.iter().enumerate() {
        ensure!(
            row.iter().all(|c| c.is_finite()),
            "to_world row {i} is not finite: {row:?}"
        );
        for (j, other) in m.iter().enumerate() {
            let d: f64 = (0..3).map(|k| row[k] * other[k]).sum();
            let want = if i == j { 1.0 } else { 0.0 };
            ensure!(
                (d - want).abs() < 1e-6,
                "to_world must be a rotation (orthonormal rows); rows {i} and {j} have dot \
                 product {d}"
            );
        }
    }
    Ok(())
}

fn mat_vec(m: &[[f64; 3]; 3], v: [f64; 3]) -> [f64; 3] {
    m.map(|r| r[0] * v[0] + r[1] * v[1] + r[2] * v[2])
}

fn mat_t_vec(m: &[[f64; 3]; 3], v: [f64; 3]) -> [f64; 3] {
    [0, 1, 2].map(|j| m[0][j] * v[0] + m[1][j] * v[1] + m[2][j] * v[2])
}

impl Sky {
    /// A uniform sky of radiance `rgb`.
    pub fn constant(rgb: [f64; 3]) -> Self {
        Sky {
            radiance: SkyRadiance::Constant(rgb),
            scale: 1.0,
            to_world: IDENTITY,
            directions: DEFAULT_SKY_DIRECTIONS,
            file: None,
            channel: None,
        }
    }

    /// Checks the scale, the rotation, the number of directions and that the sky is not
    /// black.
    pub fn validate(&self) -> anyhow::Result<()> {
        ensure!(
            self.scale.is_finite() && self.scale > 0.0,
            "scale must be finite and positive, got {}",
            self.scale
        );
        check_rotation(&self.to_world)?;
        ensure!(
            (1..=MAX_SKY_DIRECTIONS).contains(&self.directions),
            "directions must be 1..={MAX_SKY_DIRECTIONS}, got {}",
            self.directions
        );
        let peak = match &self.radiance {
            SkyRadiance::Constant(c) => {
                for v in c {
                    ensure!(
                        v.is_finite() && *v >= 0.0,
                        "radiance must be finite and non-negative, got {c:?}"
                    );
                }
                c.iter().fold(0.0f64, |m, v| m.max(*v))
            }
            SkyRadiance::Map(m) => m
                .texels
                .iter()
                .flatten()
                .fold(0.0f64, |a, v| a.max(*v as f64)),
        };
        ensure!(
            peak > 0.0,
            "the sky is black (all radiance 0): leave the light out instead"
        );
        Ok(())
    }

    /// Whether the channels differ anywhere (a coloured scene).
    pub fn is_rgb(&self) -> bool {
        match &self.radiance {
            SkyRadiance::Constant(c) => c[0] != c[1] || c[1] != c[2],
            SkyRadiance::Map(m) => m.texels.iter().any(|t| t[0] != t[1] || t[1] != t[2]),
        }
    }

    /// The same sky read as channel `c` (0 = R, 1 = G, 2 = B) by [`Sky::radiance`].
    pub fn channel(&self, c: usize) -> Sky {
        Sky {
            channel: Some(c),
            ..self.clone()
        }
    }

    /// The radiance (per channel, scale applied) arriving from the world looking direction
    /// `look` (unit, from the medium towards the sky).
    pub fn radiance_rgb(&self, look: [f64; 3]) -> [f64; 3] {
        let v = match &self.radiance {
            SkyRadiance::Constant(c) => *c,
            SkyRadiance::Map(m) => m.eval(mat_t_vec(&self.to_world, look)),
        };
        v.map(|c| c * self.scale)
    }

    /// The grey radiance towards `look`: the scene's channel, or the mean of the channels.
    pub fn radiance(&self, look: [f64; 3]) -> f64 {
        self.grey(self.radiance_rgb(look))
    }

    /// The grey value of an RGB triple as this sky reads it.
    pub fn grey(&self, rgb: [f64; 3]) -> f64 {
        match self.channel {
            Some(c) => rgb[c],
            None => (rgb[0] + rgb[1] + rgb[2]) / 3.0,
        }
    }

    /// The sky cut into [`Sky::directions`] directional lights of about equal power by
    /// median cut (module docs). Regions without power are left out, so fewer lights may
    /// come back.
    pub fn lights(&self) -> Vec<SkyLight> {
        let grid = SkyGrid::new(self);
        let mut regions = vec![grid.region(0, grid.nphi, 0, grid.ntheta)];
        while regions.len() < self.directions {
            // The region of largest power that can still be split.
            let Some((at, _)) = regions
                .iter()
                .enumerate()
                .filter(|(_, r)| r.cells() > 1 && r.power > 0.0)
                .max_by(|a, b| a.1.power.total_cmp(&b.1.power))
            else {
                break;
            };
            let r = regions.swap_remove(at);
            let (a, b) = grid.split(&r);
            regions.push(a);
            regions.push(b);
        }
        regions.sort_by_key(|r| (r.j0, r.i0));
        regions
            .iter()
            .filter(|r| r.power > 0.0)
            .map(|r| grid.light(r, self))
            .collect()
    }
}

/// The latitude–longitude cells the median cut works on (in the map's frame).
struct SkyGrid {
    nphi: usize,
    ntheta: usize,
    /// Per cell (row-major, θ slowest): radiance × solid angle per channel.
    power_rgb: Vec<[f64; 3]>,
    /// Per cell: the grey power (mean of the channels) that the cut balances.
    power: Vec<f64>,
    /// Per cell: solid angle.
    omega: Vec<f64>,
    /// Per cell: the unit looking direction at the centre (map frame).
    dir: Vec<[f64; 3]>,
}

/// A rectangle of cells [i0, i1) × [j0, j1) and its grey power.
#[derive(Clone, Debug)]
struct Region {
    i0: usize,
    i1: usize,
    j0: usize,
    j1: usize,
    power: f64,
}

impl Region {
    fn cells(&self) -> usize {
        (self.i1 - self.i0) * (self.j1 - self.j0)
    }
}

impl SkyGrid {
    fn new(sky: &Sky) -> Self {
        let nphi = match &sky.radiance {
            SkyRadiance::Constant(_) => 256,
            SkyRadiance::Map(m) => (2 * m.width).clamp(256, 1024),
        };
        let ntheta = nphi / 2;
        let n = nphi * ntheta;
        let (mut power_rgb, mut power, mut omega, mut dir) = (
            Vec::with_capacity(n),
            Vec::with_capacity(n),
            Vec::with_capacity(n),
            Vec::with_capacity(n),
        );
        let (dphi, dtheta) = (2.0 * PI / nphi as f64, PI / ntheta as f64);
        for j in 0..ntheta {
            let (t0, t1) = (j as f64 * dtheta, (j + 1) as f64 * dtheta);
            let w = dphi * (t0.cos() - t1.cos());
            let t = (j as f64 + 0.5) * dtheta;
            for i in 0..nphi {
                let p = (i as f64 + 0.5) * dphi;
                let v = [t.sin() * p.sin(), t.cos(), -t.sin() * p.cos()];
                let l = match &sky.radiance {
                    SkyRadiance::Constant(c) => *c,
                    SkyRadiance::Map(m) => m.eval(v),
                };
                let rgb = l.map(|c| c * sky.scale * w);
                power_rgb.push(rgb);
                power.push((rgb[0] + rgb[1] + rgb[2]) / 3.0);
                omega.push(w);
                dir.push(v);
            }
        }
        SkyGrid {
            nphi,
            ntheta,
            power_rgb,
            power,
            omega,
            dir,
        }
    }

    fn region(&self, i0: usize, i1: usize, j0: usize, j1: usize) -> Region {
        let mut power = 0.0;
        for j in j0..j1 {
            power += self.power[j * self.nphi + i0..j * self.nphi + i1]
                .iter()
                .sum::<f64>();
        }
        Region {
            i0,
            i1,
            j0,
            j1,
            power,
        }
    }

    /// Splits `r` across its longer angular side where the power is halved.
    fn split(&self, r: &Region) -> (Region, Region) {
        let dphi = 2.0 * PI / self.nphi as f64;
        let dtheta = PI / self.ntheta as f64;
        let theta_mid = 0.5 * (r.j0 + r.j1) as f64 * dtheta;
        let width = (r.i1 - r.i0) as f64 * dphi * theta_mid.sin();
        let height = (r.j1 - r.j0) as f64 * dtheta;
        let along_phi = (width >= height && r.i1 - r.i0 > 1) || r.j1 - r.j0 == 1;
        // Power per column (along φ) or per row (along θ).
        let slices: Vec<f64> = if along_phi {
            (r.i0..r.i1)
                .map(|i| (r.j0..r.j1).map(|j| self.power[j * self.nphi + i]).sum())
                .collect()
        } else {
            (r.j0..r.j1)
                .map(|j| {
                    self.power[j * self.nphi + r.i0..j * self.nphi + r.i1]
                        .iter()
                        .sum()
                })
                .collect()
        };
        let total: f64 = slices.iter().sum();
        let mut acc = 0.0;
        let mut cut = 1;
        for (k, s) in slices.iter().enumerate() {
            acc += s;
            if acc >= 0.5 * total {
                // Cut before or after this slice, whichever is closer to half.
                cut = if acc - 0.5 * total > 0.5 * total - (acc - s) && k > 0 {
                    k
                } else {
                    k + 1
                };
                break;
            }
        }
        let cut = cut.clamp(1, slices.len() - 1);
        if along_phi {
            let m = r.i0 + cut;
            (
                self.region(r.i0, m, r.j0, r.j1),
                self.region(m, r.i1, r.j0, r.j1),
            )
        } else {
            let m = r.j0 + cut;
            (
                self.region(r.i0, r.i1, r.j0, m),
                self.region(r.i0, r.i1, m, r.j1),
            )
        }
    }

    fn light(&self, r: &Region, sky: &Sky) -> SkyLight {
        let (mut rgb, mut omega, mut mean) = ([0.0; 3], 0.0, [0.0; 3]);
        for j in r.j0..r.j1 {
            for i in r.i0..r.i1 {
                let c = j * self.nphi + i;
                for (a, b) in rgb.iter_mut().zip(&self.power_rgb[c]) {
                    *a += b;
                }
                omega += self.omega[c];
                for (a, b) in mean.iter_mut().zip(&self.dir[c]) {
                    *a += self.power[c] * b;
                }
            }
        }
        let n = norm(mean);
        let look = if n > 0.0 {
            mean.map(|c| c / n)
        } else {
            self.dir[r.j0 * self.nphi + r.i0]
        };
        let world = mat_vec(&sky.to_world, look);
        SkyLight {
            travel: world.map(|c| -c),
            irradiance: rgb,
            solid_angle: omega,
            blocks: self.blocks(r, sky),
        }
    }

    /// The region cut into at most BLOCKS_PER_SIDE² blocks: per block the power-weighted
    /// mean travel direction (world) and its share of the region's power.
    fn blocks(&self, r: &Region, sky: &Sky) -> Vec<([f64; 3], f64)> {
        let edges = |a: usize, b: usize| -> Vec<usize> {
            let n = (b - a).min(BLOCKS_PER_SIDE);
            (0..=n).map(|q| a + q * (b - a) / n).collect()
        };
        let (ei, ej) = (edges(r.i0, r.i1), edges(r.j0, r.j1));
        let mut out = Vec::new();
        for jj in ej.windows(2) {
            for ii in ei.windows(2) {
                let (mut p, mut mean) = (0.0, [0.0; 3]);
                for j in jj[0]..jj[1] {
                    for i in ii[0]..ii[1] {
                        let c = j * self.nphi + i;
                        p += self.power[c];
                        for (a, b) in mean.iter_mut().zip(&self.dir[c]) {
                            *a += self.power[c] * b;
                        }
                    }
                }
                let n = norm(mean);
                if p > 0.0 && n > 0.0 {
                    let look = mat_vec(&sky.to_world, mean.map(|c| c / n));
                    out.push((look.map(|c| -c), p / r.power));
                }
            }
        }
        out
    }
}

/// A phase function averaged over a cone (module docs): `value(μ)` is the mean of
/// p(ω·ω_o) over the directions ω of a cone of solid angle Ω about an axis at cosine μ
/// from ω_o. Tabulated on [`CAP_NODES`] angles, linear between them.
#[derive(Clone, Debug, PartialEq)]
pub struct CapPhase {
    table: Vec<f64>,
}

/// Angles the [`CapPhase`] table holds between 0 and π.
pub const CAP_NODES: usize = 512;

impl CapPhase {
    /// `phase` averaged over a cone of solid angle `solid_angle` (sr, ≤ 4π): the cone's
    /// polar angle by Gauss–Legendre in cos ρ, its azimuth by the midpoint rule.
    pub fn new(phase: &Phase, solid_angle: f64) -> Self {
        let cos_alpha = (1.0 - solid_angle / (2.0 * PI)).clamp(-1.0, 1.0);
        let (nodes, weights) = pn_stencil::quadrature::gauss_legendre(12);
        let npsi = 24;
        let table = (0..CAP_NODES)
            .map(|k| {
                let theta = PI * k as f64 / (CAP_NODES - 1) as f64;
                let (st, ct) = theta.sin_cos();
                let mut sum = 0.0;
                for (x, w) in nodes.iter().zip(&weights) {
                    // cos ρ from cos α to 1.
                    let cr = cos_alpha + (1.0 - cos_alpha) * 0.5 * (x + 1.0);
                    let sr = (1.0 - cr * cr).max(0.0).sqrt();
                    let mut ring = 0.0;
                    for q in 0..npsi {
                        let psi = PI * (q as f64 + 0.5) / npsi as f64;
                        ring += phase.value(ct * cr + st * sr * psi.cos());
                    }
                    sum += 0.5 * w * ring / npsi as f64;
                }
                sum
            })
            .collect();
        CapPhase { table }
    }

    /// The averaged phase function at the cosine `mu` between the cone's axis (a travel
    /// direction) and the outgoing direction.
    pub fn value(&self, mu: f64) -> f64 {
        let x = mu.clamp(-1.0, 1.0).acos() / PI * (CAP_NODES - 1) as f64;
        let i = (x as usize).min(CAP_NODES - 2);
        let f = x - i as f64;
        self.table[i] * (1.0 - f) + self.table[i + 1] * f
    }
}

/// The sky lights' averaged phase functions, one per distinct solid angle (to 0.1 %), for
/// [`SkyLights`].
fn cap_phases(phase: &Phase, lights: &[SkyLight]) -> Vec<Arc<CapPhase>> {
    let mut made: Vec<(f64, Arc<CapPhase>)> = Vec::new();
    lights
        .iter()
        .map(|l| {
            if let Some((_, c)) = made
                .iter()
                .find(|(o, _)| (o - l.solid_angle).abs() <= 1e-3 * l.solid_angle)
            {
                return c.clone();
            }
            let c = Arc::new(CapPhase::new(phase, l.solid_angle));
            made.push((l.solid_angle, c.clone()));
            c
        })
        .collect()
}

/// A scene's sky as lights: where in the scene's light list they start and, per sky light,
/// the phase function the camera's single scattering reads ([`CapPhase`]; `None` for an
/// isotropic phase, whose average is itself).
#[derive(Clone, Debug, PartialEq)]
pub struct SkyLights {
    /// Index of the first sky light in the scene's lights (they run to the end).
    pub first: usize,
    /// The sky lights.
    pub lights: Vec<SkyLight>,
    /// Per sky light: the phase averaged over a cone of its region's solid angle.
    pub phases: Option<Vec<Arc<CapPhase>>>,
}

impl SkyLights {
    /// The sky lights of `sky` for a scene whose own lights number `first`.
    pub fn new(sky: &Sky, phase: &Phase, first: usize) -> Self {
        let lights = sky.lights();
        let phases = (!matches!(phase, Phase::Isotropic)).then(|| cap_phases(phase, &lights));
        SkyLights {
            first,
            lights,
            phases,
        }
    }

    /// The phase value for light `index` of the scene at the cosine `mu` between its travel
    /// direction and the outgoing direction (a sky light: its cone average).
    pub fn phase_value(&self, phase: &Phase, index: usize, mu: f64) -> f64 {
        match (&self.phases, index.checked_sub(self.first)) {
            (Some(p), Some(k)) if k < p.len() => p[k].value(mu),
            _ => phase.value(mu),
        }
    }

    /// For light `index` of the scene: `f` averaged over its region's blocks if it is a sky
    /// light (the first-scatter source's Y_l^m, exact where L·T is constant on each block),
    /// `None` for the scene's own lights.
    pub fn sh_average(&self, index: usize, f: impl Fn([f64; 3]) -> f64) -> Option<f64> {
        let k = index.checked_sub(self.first)?;
        let l = self.lights.get(k)?;
        Some(l.blocks.iter().map(|(d, w)| w * f(*d)).sum())
    }
}

/// Refuses an environment map of `width` × `height` texels larger than
/// [`MAX_ENVMAP_TEXELS`], with the memory it would take (12 bytes a texel): checked from a
/// map file's header before it is decoded, and by the Python binding from a numpy array's
/// shape before it is copied.
pub fn check_envmap_size(width: usize, height: usize) -> anyhow::Result<()> {
    let texels = width as u128 * height as u128;
    ensure!(
        texels <= MAX_ENVMAP_TEXELS as u128,
        "an environment map of {width} × {height} texels would take {:.1} GB; the largest \
         accepted is 4096 × 2048 (downsample it)",
        (texels * 12) as f64 / 1e9
    );
    Ok(())
}

/// Reads an environment map file (OpenEXR, or any image format `pn_formats` reads) into
/// an [`EnvMap`], checking its size before decoding it.
pub fn read_envmap(path: &std::path::Path) -> anyhow::Result<EnvMap> {
    let (w, h) = pn_formats::image_dimensions(path)?;
    check_envmap_size(w, h).map_err(|e| anyhow::anyhow!("{}: {e}", path.display()))?;
    let (w, h, [r, g, b]) = pn_formats::read_exr_rgb(path)?;
    let texels = (0..w * h).map(|i| [r[i], g[i], b[i]]).collect();
    EnvMap::new(w, h, texels).with_context(|| format!("{}", path.display()))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn map(w: usize, h: usize, f: impl Fn(usize, usize) -> [f32; 3]) -> EnvMap {
        let t = (0..h)
            .flat_map(|j| (0..w).map(move |i| (i, j)))
            .map(|(i, j)| f(i, j));
        EnvMap::new(w, h, t.collect()).unwrap()
    }

    fn look(u: f64, v: f64) -> [f64; 3] {
        let (t, p) = (v * PI, u * 2.0 * PI);
        [t.sin() * p.sin(), t.cos(), -t.sin() * p.cos()]
    }

    /// At a texel's centre column and its row's θ the lookup returns the texel, and
    /// halfway between two columns their mean (Mitsuba's placement, module docs).
    #[test]
    fn the_lookup_places_texels_as_mitsuba_does() {
        let m = map(8, 4, |i, j| [(i + 10 * j) as f32, 0.0, 1.0]);
        for (i, j) in [(0, 1), (3, 1), (7, 2), (5, 1)] {
            let v = look((i as f64 + 0.5) / 8.0, j as f64 / 3.0);
            let got = m.eval(v)[0];
            assert!((got - (i + 10 * j) as f64).abs() < 1e-9, "{i} {j}: {got}");
        }
        // Between column 7 and column 0 (periodic): the mean.
        let got = m.eval(look(0.0, 1.0 / 3.0))[0];
        assert!((got - (7.0 + 0.0) / 2.0 - 10.0).abs() < 1e-9, "{got}");
    }

    /// A flipped u or v would move the bright texel: the lookup finds it only where it is.
    #[test]
    fn a_bright_patch_is_seen_only_from_its_side() {
        let m = map(16, 8, |i, j| {
            if (4..6).contains(&i) && (2..4).contains(&j) {
                [10.0; 3]
            } else {
                [0.0; 3]
            }
        });
        // Texel (4.5, 2.5): u = 5/16, v = 2.5/7.
        let at = look(5.0 / 16.0, 2.5 / 7.0);
        assert!(m.eval(at)[0] > 5.0);
        let mirrored_u = look(1.0 - 5.0 / 16.0, 2.5 / 7.0);
        let mirrored_v = look(5.0 / 16.0, 1.0 - 2.5 / 7.0);
        assert_eq!(m.eval(mirrored_u)[0], 0.0);
        assert_eq!(m.eval(mirrored_v)[0], 0.0);
    }

    /// The lights carry the sky's whole power: 4π L for a uniform sky, and the grid's
    /// integral of a map; each light's direction lies in its region's hemisphere.
    #[test]
    fn the_lights_carry_the_skys_power() {
        for k in [1, 7, 64, 256] {
            let mut s = Sky::constant([1.0, 2.0, 3.0]);
            s.directions = k;
            let l = s.lights();
            assert_eq!(l.len(), k);
            for c in 0..3 {
                let e: f64 = l.iter().map(|x| x.irradiance[c]).sum();
                assert!((e - 4.0 * PI * (c + 1) as f64).abs() < 1e-9, "{k} {c}: {e}");
            }
            let omega: f64 = l.iter().map(|x| x.solid_angle).sum();
            assert!((omega - 4.0 * PI).abs() < 1e-9);
            if k == 64 {
                // Equal power: equal solid angles within a grid cell's worth.
                let ratios: Vec<f64> = l
                    .iter()
                    .map(|x| x.solid_angle / (4.0 * PI / 64.0))
                    .collect();
                let worst = ratios.iter().fold(0.0f64, |m, r| m.max((r - 1.0).abs()));
                assert!(worst < 0.1, "{ratios:?}");
            }
        }
        // A sky brighter above: the lights crowd where the power is.
        let m = map(32, 16, |_, j| if j < 8 { [4.0; 3] } else { [1.0; 3] });
        let mut s = Sky::constant([0.0; 3]);
        s.radiance = SkyRadiance::Map(Arc::new(m));
        s.directions = 32;
        let l = s.lights();
        let down = l.iter().filter(|x| x.travel[1] < 0.0).count();
        assert!(down > 20, "{down} of 32 lights come from above");
    }

    /// The rotation of `up` maps +Y onto it and is orthonormal; a sky rotated by it shows
    /// its zenith in the direction `up`.
    #[test]
    fn up_rotates_the_zenith() {
        for up in [
            [0.0, 0.0, 1.0],
            [1.0, 1.0, 0.0],
            [0.0, -1.0, 0.0],
            [0.3, 0.2, -0.9],
        ] {
            let r = rotation_to_up(up).unwrap();
            check_rotation(&r).unwrap();
            let n = norm(up);
            let y = mat_vec(&r, [0.0, 1.0, 0.0]);
            for c in 0..3 {
                assert!((y[c] - up[c] / n).abs() < 1e-12, "{up:?}: {y:?}");
            }
        }
        assert!(check_rotation(&[[1.0, 0.0, 0.0], [0.0, 2.0, 0.0], [0.0, 0.0, 1.0]]).is_err());
    }

    /// The cone average of a phase function integrates to 1 over the sphere, equals p for
    /// a tiny cone, and is flatter than p for a wide one.
    #[test]
    fn cone_averaged_phase_is_normalised_and_tends_to_p() {
        let hg = Phase::HenyeyGreenstein(0.877);
        let (x, w) = pn_stencil::quadrature::gauss_legendre(400);
        for omega in [1e-6, 0.05, 0.2, 1.0] {
            let c = CapPhase::new(&hg, omega);
            let total: f64 = x
                .iter()
                .zip(&w)
                .map(|(mu, w)| 2.0 * PI * w * c.value(*mu))
                .sum();
            assert!((total - 1.0).abs() < 2e-3, "Ω = {omega}: ∫ = {total}");
        }
        let tiny = CapPhase::new(&hg, 1e-6);
        for mu in [-0.5, 0.0, 0.9] {
            assert!((tiny.value(mu) / hg.value(mu) - 1.0).abs() < 1e-3);
        }
        assert!(CapPhase::new(&hg, 1.0).value(1.0) < 0.5 * hg.value(1.0));
    }

    #[test]
    fn bad_maps_and_skies_are_refused() {
        let e = |r: anyhow::Result<EnvMap>| format!("{:#}", r.unwrap_err());
        assert!(e(EnvMap::new(8, 8, vec![[1.0; 3]; 64])).contains("twice as wide"));
        let mut t = vec![[1.0f32; 3]; 32];
        t[9] = [f32::NAN, 0.0, 0.0];
        assert!(e(EnvMap::new(8, 4, t.clone())).contains("row 1, column 1"));
        t[9] = [-1.0, 0.0, 0.0];
        assert!(e(EnvMap::new(8, 4, t)).contains("non-negative"));
        assert!(e(EnvMap::new(16384, 8192, Vec::new())).contains("GB"));
        let mut s = Sky::constant([0.0; 3]);
        assert!(format!("{:#}", s.validate().unwrap_err()).contains("black"));
        s.radiance = SkyRadiance::Constant([1.0; 3]);
        s.directions = 0;
        assert!(s.validate().is_err());
        s.directions = 8;
        s.scale = f64::NAN;
        assert!(s.validate().is_err());
    }
}
