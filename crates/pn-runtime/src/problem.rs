//! The problem description: domain, grid, coefficients, phase function, sources and boundary.

use crate::field::{Field, Point};
use pn_stencil::Dim;

/// An axis-aligned box tiled by `res` cells per axis.
#[derive(Clone, Debug, PartialEq)]
pub struct Grid {
    /// 2D (z-independent, one cell in z) or 3D.
    pub dim: Dim,
    /// Lower corner.
    pub min: Point,
    /// Upper corner.
    pub max: Point,
    /// Cells per axis; `res[2] == 1` in 2D.
    pub res: [usize; 3],
}

impl Grid {
    /// Cell size along `axis`.
    pub fn h(&self, axis: usize) -> f64 {
        (self.max[axis] - self.min[axis]) / self.res[axis] as f64
    }

    /// World coordinate of an absolute half-cell coordinate along `axis`
    /// (`2i+1` is the centre of cell i, `2s` is face s; see `pn_stencil`).
    pub fn coord(&self, axis: usize, half: i64) -> f64 {
        self.min[axis] + 0.5 * half as f64 * self.h(axis)
    }

    /// Volume (area in 2D, per unit length in z) of one cell.
    pub fn cell_volume(&self) -> f64 {
        (0..self.dim.axes()).map(|d| self.h(d)).product()
    }

    /// Number of cells.
    pub fn cells(&self) -> usize {
        self.res.iter().product()
    }

    /// Checks resolution and extents.
    pub fn validate(&self) -> anyhow::Result<()> {
        for d in 0..3 {
            anyhow::ensure!(
                self.res[d] > 0,
                "resolution must be positive on every axis, got {:?}",
                self.res
            );
            anyhow::ensure!(
                self.min[d].is_finite() && self.max[d].is_finite() && self.max[d] > self.min[d],
                "domain must have max > min on every axis, got min {:?} max {:?}",
                self.min,
                self.max
            );
        }
        if self.dim == Dim::Two {
            anyhow::ensure!(
                self.res[2] == 1,
                "a 2D grid has one cell in z, got {}",
                self.res[2]
            );
        }
        Ok(())
    }
}

pub use crate::phase::Phase;

/// How the scattering coefficient is given.
#[derive(Clone, Debug)]
pub enum Scattering {
    /// σ_s directly.
    SigmaS(Field),
    /// Single-scattering albedo α, σ_s = α σ_t.
    Albedo(Field),
}

/// The closure of one domain face (docs/design.md §3, "Domain and boundary").
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum BoundaryKind {
    /// Extrapolation / zero gradient: a reference outside maps to the same moment at the
    /// nearest inside position (reflecting: no net flux through the face).
    Neumann,
    /// Dirichlet zero: the reference is dropped.
    Dirichlet,
    /// Marshak's vacuum condition: the half-range moments of the incoming radiance vanish
    /// for the harmonics odd under reflection in the face plane (staggered P_N with odd N
    /// only; [`crate::marshak`]).
    Marshak,
}

impl BoundaryKind {
    /// Every kind, in the order of the help texts.
    pub const ALL: [BoundaryKind; 3] = [
        BoundaryKind::Neumann,
        BoundaryKind::Dirichlet,
        BoundaryKind::Marshak,
    ];

    /// Lower-case name (`neumann`, `dirichlet`, `marshak`).
    pub fn name(self) -> &'static str {
        match self {
            BoundaryKind::Neumann => "neumann",
            BoundaryKind::Dirichlet => "dirichlet",
            BoundaryKind::Marshak => "marshak",
        }
    }
}

impl std::str::FromStr for BoundaryKind {
    type Err = anyhow::Error;
    fn from_str(s: &str) -> anyhow::Result<Self> {
        BoundaryKind::ALL
            .into_iter()
            .find(|k| k.name() == s)
            .ok_or_else(|| {
                anyhow::anyhow!(
                    "unknown boundary condition {s:?} (expected neumann, dirichlet or marshak)"
                )
            })
    }
}

/// Boundary closure for stencil references outside the domain (docs/design.md §3): one
/// [`BoundaryKind`] for every face, or one per face ([`Boundary::Faces`]).
///
/// With extrapolation the face rows on the domain faces see a zero difference across the
/// boundary, which makes the boundary reflecting: the net flux through it vanishes and all
/// emitted power is absorbed (the energy balance reports a zero outflow). Dirichlet zero
/// treats everything outside as 0, so light leaves the domain (a crude vacuum boundary,
/// not the Marshak condition); its answer is lower near the boundary and has a positive
/// outflow. Marshak is the vacuum condition proper: the rows of the face unknowns become
/// the half-range conditions of [`pn_stencil::marshak`].
///
/// Text form (`--bc`, a scene file's `boundary`): a kind for all faces (`neumann`,
/// `dirichlet`, `marshak`), or a comma-separated list of `FACES=KIND` items with FACES one of
/// `x`, `y`, `z` (both faces of the axis) or `xmin`, `xmax`, `ymin`, `ymax`, `zmin`, `zmax`,
/// optionally with one bare kind for the faces not named (default `neumann`): e.g.
/// `x=marshak` (a slab: vacuum on the x faces, reflecting elsewhere) or
/// `marshak,z=neumann`. Later items override earlier ones.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Boundary {
    /// Extrapolation / zero gradient on every face.
    Neumann,
    /// Dirichlet zero on every face.
    Dirichlet,
    /// Marshak vacuum condition on every face.
    Marshak,
    /// One closure per face, `[axis][0 = min face, 1 = max face]`; never all equal (the
    /// parser and [`Boundary::from_faces`] give the uniform variants then).
    Faces([[BoundaryKind; 2]; 3]),
}

impl std::str::FromStr for Boundary {
    type Err = anyhow::Error;
    fn from_str(s: &str) -> anyhow::Result<Self> {
        let s = s.trim();
        anyhow::ensure!(
            !s.is_empty(),
            "empty boundary condition (expected neumann, dirichlet, marshak or a per-face list \
             such as x=marshak,y=neumann)"
        );
        let mut default = BoundaryKind::Neumann;
        let mut set: Vec<(usize, usize, BoundaryKind)> = Vec::new();
        for item in s.split(',').map(str::trim) {
            match item.split_once('=') {
                None => default = item.parse()?,
                Some((faces, kind)) => {
                    let kind: BoundaryKind = kind.trim().parse()?;
                    let faces = faces.trim();
                    let axis = match faces.chars().next() {
                        Some('x') => 0,
                        Some('y') => 1,
                        Some('z') => 2,
                        _ => anyhow::bail!(
                            "unknown face {faces:?} in boundary {s:?} (expected x, y, z, xmin, \
                             xmax, ymin, ymax, zmin or zmax)"
                        ),
                    };
                    let sides: &[usize] = match &faces[1..] {
                        "" => &[0, 1],
                        "min" => &[0],
                        "max" => &[1],
                        _ => anyhow::bail!(
                            "unknown face {faces:?} in boundary {s:?} (expected x, y, z, xmin, \
                             xmax, ymin, ymax, zmin or zmax)"
                        ),
                    };
                    set.extend(sides.iter().map(|&side| (axis, side, kind)));
                }
            }
        }
        let mut faces = [[default; 2]; 3];
        for (axis, side, kind) in set {
            faces[axis][side] = kind;
        }
        Ok(Boundary::from_faces(faces))
    }
}

impl Boundary {
    /// The boundary with these per-face kinds (a uniform variant when all six agree).
    pub fn from_faces(faces: [[BoundaryKind; 2]; 3]) -> Self {
        let first = faces[0][0];
        if faces.iter().flatten().all(|&k| k == first) {
            Boundary::uniform(first)
        } else {
            Boundary::Faces(faces)
        }
    }

    /// The same kind on every face.
    pub fn uniform(kind: BoundaryKind) -> Self {
        match kind {
            BoundaryKind::Neumann => Boundary::Neumann,
            BoundaryKind::Dirichlet => Boundary::Dirichlet,
            BoundaryKind::Marshak => Boundary::Marshak,
        }
    }

    /// The kind of every face, `[axis][0 = min, 1 = max]`.
    pub fn faces(&self) -> [[BoundaryKind; 2]; 3] {
        match self {
            Boundary::Neumann => [[BoundaryKind::Neumann; 2]; 3],
            Boundary::Dirichlet => [[BoundaryKind::Dirichlet; 2]; 3],
            Boundary::Marshak => [[BoundaryKind::Marshak; 2]; 3],
            Boundary::Faces(f) => *f,
        }
    }

    /// The kind of the min (`side` 0) or max (`side` 1) face of `axis`.
    pub fn face(&self, axis: usize, side: usize) -> BoundaryKind {
        self.faces()[axis][side]
    }

    /// Whether some face of the first `axes` axes has the Marshak condition.
    pub fn has_marshak(&self, axes: usize) -> bool {
        self.faces()[..axes.min(3)]
            .iter()
            .flatten()
            .any(|&k| k == BoundaryKind::Marshak)
    }

    /// Whether every face of the first `axes` axes is reflecting (Neumann).
    pub fn all_neumann(&self, axes: usize) -> bool {
        self.faces()[..axes.min(3)]
            .iter()
            .flatten()
            .all(|&k| k == BoundaryKind::Neumann)
    }

    /// Lower-case name: the kind when uniform, else the per-face list in the text form
    /// (`x=marshak,y=neumann,z=neumann`, with `xmin=`/`xmax=` where the two faces differ).
    pub fn name(&self) -> String {
        match self {
            Boundary::Faces(f) => {
                let axes = ["x", "y", "z"];
                let mut items = Vec::new();
                for (a, sides) in f.iter().enumerate() {
                    if sides[0] == sides[1] {
                        items.push(format!("{}={}", axes[a], sides[0].name()));
                    } else {
                        items.push(format!("{}min={}", axes[a], sides[0].name()));
                        items.push(format!("{}max={}", axes[a], sides[1].name()));
                    }
                }
                items.join(",")
            }
            _ => self.face(0, 0).name().to_string(),
        }
    }
}

impl serde::Serialize for Boundary {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        s.serialize_str(&self.name())
    }
}

impl<'de> serde::Deserialize<'de> for Boundary {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        let text = String::deserialize(d)?;
        text.parse()
            .map_err(|e: anyhow::Error| serde::de::Error::custom(e.to_string()))
    }
}

/// One source moment Q_l^m.
#[derive(Clone, Debug)]
pub struct SourceTerm {
    /// Band.
    pub l: u32,
    /// Order.
    pub m: i32,
    /// Its value as a field.
    pub field: Field,
}

/// Everything the runtime needs to assemble a system, independent of the method.
#[derive(Clone, Debug)]
pub struct Problem {
    /// Domain and resolution.
    pub grid: Grid,
    /// Extinction coefficient σ_t.
    pub sigma_t: Field,
    /// Scattering coefficient or albedo.
    pub scattering: Scattering,
    /// Phase function.
    pub phase: Phase,
    /// Source moments (terms with the same (l, m) add up).
    pub sources: Vec<SourceTerm>,
    /// Boundary closure.
    pub boundary: Boundary,
    /// σ_t is raised to at least this value (needed where σ_t reaches 0, docs/design.md §5).
    pub sigma_t_min: Option<f64>,
}

/// The automatic σ_t threshold is this fraction of the largest σ_t
/// (see [`Problem::auto_sigma_t_min`]).
pub const AUTO_SIGMA_T_MIN_FRACTION: f64 = 1e-3;

/// Coefficients at one point after the σ_t threshold.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Coefficients {
    /// σ_t (after the threshold).
    pub sigma_t: f64,
    /// σ_s.
    pub sigma_s: f64,
}

/// The transport coefficient `σ_tr = σ_t − σ_s λ_1 p_1` (docs/design.md §2.2; `λ_1 p_1 = g` for
/// Henyey–Greenstein, see [`Phase::moment`]), whose inverse gives the classical diffusion
/// coefficient `D = 1/(3σ_tr)`.
///
/// The one place the runtime, the FLD set-up and the closed-form references form it; with
/// `sigma_t = 1` and `sigma_s = α` it is the normalised `σ_tr/σ_t = 1 − αg`.
pub fn sigma_tr(sigma_t: f64, sigma_s: f64, phase_moment_1: f64) -> f64 {
    sigma_t - sigma_s * phase_moment_1
}

impl Coefficients {
    /// [`sigma_tr`] of these coefficients under `phase`.
    pub fn sigma_tr(&self, phase: &Phase) -> f64 {
        sigma_tr(self.sigma_t, self.sigma_s, phase.moment(1))
    }

    /// The classical diffusion coefficient `D = 1/(3σ_tr)` under `phase`.
    pub fn diffusion(&self, phase: &Phase) -> f64 {
        1.0 / (3.0 * self.sigma_tr(phase))
    }
}

/// Invalid coefficient values found while evaluating fields.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum CoefficientError {
    /// NaN or infinite.
    #[error("{name} is not finite ({value}) at ({x:.6}, {y:.6}, {z:.6})")]
    NotFinite {
        /// The field's name (σ_t, σ_s, albedo or source).
        name: &'static str,
        /// The value found.
        value: f64,
        /// The point's x coordinate.
        x: f64,
        /// The point's y coordinate.
        y: f64,
        /// The point's z coordinate.
        z: f64,
    },
    /// Negative.
    #[error("{name} is negative ({value}) at ({x:.6}, {y:.6}, {z:.6})")]
    Negative {
        /// The field's name (σ_t, σ_s, albedo or source).
        name: &'static str,
        /// The value found.
        value: f64,
        /// The point's x coordinate.
        x: f64,
        /// The point's y coordinate.
        y: f64,
        /// The point's z coordinate.
        z: f64,
    },
    /// σ_s > σ_t.
    #[error("σ_s = {sigma_s} exceeds σ_t = {sigma_t} at ({x:.6}, {y:.6}, {z:.6}) (albedo > 1)")]
    ScatteringExceedsExtinction {
        /// σ_s at the point (α σ_t for an albedo field).
        sigma_s: f64,
        /// σ_t at the point, before the threshold.
        sigma_t: f64,
        /// The point's x coordinate.
        x: f64,
        /// The point's y coordinate.
        y: f64,
        /// The point's z coordinate.
        z: f64,
    },
    /// σ_t = 0 without a threshold.
    #[error(
        "σ_t = 0 at ({x:.6}, {y:.6}, {z:.6}): the system is singular in vacuum; \
         set a minimum extinction with --sigma-t-min (e.g. --sigma-t-min 1e-3)"
    )]
    Vacuum {
        /// The point's x coordinate.
        x: f64,
        /// The point's y coordinate.
        y: f64,
        /// The point's z coordinate.
        z: f64,
    },
}

impl Problem {
    /// σ_t and σ_s at `p`, with the threshold applied and the values checked.
    pub fn coefficients(&self, p: Point) -> Result<Coefficients, CoefficientError> {
        let scattering = match &self.scattering {
            Scattering::SigmaS(f) | Scattering::Albedo(f) => f.eval(p),
        };
        self.coefficients_from(self.sigma_t.eval(p), scattering, p)
    }

    /// [`Self::coefficients`] from values already read at `p`: `raw_t` of [`Self::sigma_t`]
    /// and `scattering` of the [`Self::scattering`] field (σ_s or the albedo, as that says).
    pub fn coefficients_from(
        &self,
        raw_t: f64,
        scattering: f64,
        p: Point,
    ) -> Result<Coefficients, CoefficientError> {
        let [x, y, z] = p;
        check("σ_t", raw_t, p)?;
        let sigma_s = match &self.scattering {
            Scattering::SigmaS(_) => {
                let s = scattering;
                check("σ_s", s, p)?;
                s
            }
            Scattering::Albedo(_) => {
                let a = scattering;
                check("albedo", a, p)?;
                if a > 1.0 + 1e-12 {
                    return Err(CoefficientError::ScatteringExceedsExtinction {
                        sigma_s: a * raw_t,
                        sigma_t: raw_t,
                        x,
                        y,
                        z,
                    });
                }
                a * raw_t
            }
        };
        // Tolerate rounding in σ_s = σ_t (pure scatterers given as two fields).
        if sigma_s > raw_t * (1.0 + 1e-12) {
            return Err(CoefficientError::ScatteringExceedsExtinction {
                sigma_s,
                sigma_t: raw_t,
                x,
                y,
                z,
            });
        }
        let sigma_t = match self.sigma_t_min {
            Some(min) => raw_t.max(min),
            None => {
                if raw_t == 0.0 {
                    return Err(CoefficientError::Vacuum { x, y, z });
                }
                raw_t
            }
        };
        Ok(Coefficients { sigma_t, sigma_s })
    }

    /// Q_l^m at `p` (sum of all source terms with this (l, m)).
    pub fn source(&self, l: u32, m: i32, p: Point) -> Result<f64, CoefficientError> {
        let mut q = 0.0;
        for s in self.sources.iter().filter(|s| s.l == l && s.m == m) {
            let v = s.field.eval(p);
            if !v.is_finite() {
                let [x, y, z] = p;
                return Err(CoefficientError::NotFinite {
                    name: "source",
                    value: v,
                    x,
                    y,
                    z,
                });
            }
            q += v;
        }
        Ok(q)
    }

    /// Highest band with a source term.
    pub fn max_source_band(&self) -> u32 {
        self.sources.iter().map(|s| s.l).max().unwrap_or(0)
    }

    /// Whether any field is voxel data (averaged rather than exact at staggered positions).
    pub fn uses_voxels(&self) -> bool {
        let scat = match &self.scattering {
            Scattering::SigmaS(f) | Scattering::Albedo(f) => f.is_voxel(),
        };
        self.sigma_t.is_voxel() || scat || self.sources.iter().any(|s| s.field.is_voxel())
    }

    /// The automatic σ_t threshold `--sigma-t-min` gets when vacuum is detected
    /// (docs/design.md §5: in vacuum A is singular, a threshold is needed and must be reported).
    ///
    /// Rule: when no threshold is set and σ_t is below [`AUTO_SIGMA_T_MIN_FRACTION`] × max σ_t
    /// (vacuum or near-vacuum) at some staggered position (cell centres, faces, edges and
    /// corners, i.e. every half-cell coordinate), the threshold is that fraction of max σ_t.
    /// It is `None` when a threshold is already set, when there is no such near-vacuum, when
    /// σ_t is 0 everywhere (no scale to take a fraction of: the user must choose), or when a
    /// coefficient is invalid (the solve reports that error with its position).
    ///
    /// Evaluates σ_t at (2n_x+1)(2n_y+1)(2n_z+1) points: call it after the memory check.
    pub fn auto_sigma_t_min(&self) -> Option<f64> {
        if self.sigma_t_min.is_some() {
            return None;
        }
        let g = &self.grid;
        let axes = g.dim.axes();
        let count = |d: usize| if d < axes { 2 * g.res[d] as i64 + 1 } else { 1 };
        let mut max = 0.0f64;
        let mut min = f64::INFINITY;
        for i in 0..count(0) {
            for j in 0..count(1) {
                for k in 0..count(2) {
                    let half = [i, j, if axes == 3 { k } else { 1 }];
                    let p = [0, 1, 2].map(|d| g.coord(d, half[d]));
                    let v = self.sigma_t.eval(p);
                    if !v.is_finite() || v < 0.0 {
                        return None;
                    }
                    min = min.min(v);
                    max = max.max(v);
                }
            }
        }
        // Near-vacuum counts as vacuum: σ_t below the threshold anywhere (the weak edge of
        // a render scene's hull absorber, say) makes the parity-reduced system as badly
        // conditioned as σ_t = 0 (parity-CG stagnates there).
        let threshold = AUTO_SIGMA_T_MIN_FRACTION * max;
        (max > 0.0 && min < threshold).then_some(threshold)
    }

    /// Refuses a closed box without absorption: with the reflecting (Neumann) closure and
    /// σ_a = σ_t − σ_s = 0 at every cell centre (albedo exactly 1 everywhere) nothing leaves
    /// the system, so a source has no steady state and A is singular (a constant L_0^0 with
    /// all other moments 0 is in its null space; the energy balance P_Q = P_A + P_B of
    /// [`crate::energy`] cannot hold with P_A = P_B = 0). σ_a counts as zero when it is below 1e-12 σ_t (the rounding
    /// [`Problem::coefficients`] tolerates in σ_s ≤ σ_t). Stops at the first absorbing
    /// cell; coefficient errors are returned as they are.
    pub fn check_not_singular(&self) -> anyhow::Result<()> {
        if !self.boundary.all_neumann(self.grid.dim.axes()) {
            return Ok(());
        }
        let g = &self.grid;
        for i in 0..g.res[0] {
            for j in 0..g.res[1] {
                for k in 0..g.res[2] {
                    let half = [2 * i as i64 + 1, 2 * j as i64 + 1, 2 * k as i64 + 1];
                    let p = [0, 1, 2].map(|d| g.coord(d, half[d]));
                    let c = self.coefficients(p)?;
                    if c.sigma_t - c.sigma_s > 1e-12 * c.sigma_t {
                        return Ok(());
                    }
                }
            }
        }
        anyhow::bail!(
            "the system is singular: nothing is absorbed (albedo 1, σ_a = 0 everywhere) and the \
             neumann boundary reflects everything, so no steady state exists; \
             use --bc marshak (the vacuum condition) or --bc dirichlet (light leaves the domain), or an albedo below 1"
        )
    }

    /// Checks the parts that do not need field evaluation.
    pub fn validate(&self) -> anyhow::Result<()> {
        self.grid.validate()?;
        self.phase.validate()?;
        if let Some(min) = self.sigma_t_min {
            anyhow::ensure!(
                min.is_finite() && min > 0.0,
                "--sigma-t-min must be positive, got {min}"
            );
        }
        for s in &self.sources {
            anyhow::ensure!(
                s.m.unsigned_abs() <= s.l,
                "source moment Q_{}^{} has |m| > l",
                s.l,
                s.m
            );
        }
        Ok(())
    }
}

fn check(name: &'static str, value: f64, p: Point) -> Result<(), CoefficientError> {
    let [x, y, z] = p;
    if !value.is_finite() {
        Err(CoefficientError::NotFinite {
            name,
            value,
            x,
            y,
            z,
        })
    } else if value < 0.0 {
        Err(CoefficientError::Negative {
            name,
            value,
            x,
            y,
            z,
        })
    } else {
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use BoundaryKind::{Dirichlet as D, Marshak as M, Neumann as N};

    /// The automatic threshold applies to exact vacuum and to near-vacuum (σ_t below the
    /// fraction of its largest value), not to a medium whose σ_t stays above it.
    #[test]
    fn the_automatic_threshold_covers_near_vacuum() {
        let n = 4;
        let problem = |values: [f64; 2]| {
            let data: Vec<f64> = (0..n * n * n)
                .map(|c| {
                    if c / (n * n) == 0 {
                        values[0]
                    } else {
                        values[1]
                    }
                })
                .collect();
            let grid = Grid {
                dim: pn_stencil::Dim::Three,
                min: [0.0; 3],
                max: [1.0; 3],
                res: [n; 3],
            };
            Problem {
                grid: grid.clone(),
                sigma_t: Field::Voxel(std::sync::Arc::new(
                    crate::field::VoxelGrid::new(grid.res, grid.min, grid.max, data).unwrap(),
                )),
                scattering: Scattering::Albedo(Field::Constant(0.5)),
                phase: Phase::Isotropic,
                sources: vec![],
                boundary: Boundary::Dirichlet,
                sigma_t_min: None,
            }
        };
        let t = AUTO_SIGMA_T_MIN_FRACTION * 10.0;
        assert_eq!(problem([0.0, 10.0]).auto_sigma_t_min(), Some(t));
        assert_eq!(problem([1e-5, 10.0]).auto_sigma_t_min(), Some(t));
        assert_eq!(problem([0.5, 10.0]).auto_sigma_t_min(), None);
        assert_eq!(problem([0.0, 0.0]).auto_sigma_t_min(), None);
    }

    #[test]
    fn boundary_text_form() {
        assert_eq!("neumann".parse::<Boundary>().unwrap(), Boundary::Neumann);
        assert_eq!("marshak".parse::<Boundary>().unwrap(), Boundary::Marshak);
        let slab: Boundary = "x=marshak".parse().unwrap();
        assert_eq!(slab.faces(), [[M, M], [N, N], [N, N]]);
        assert_eq!(slab.name(), "x=marshak,y=neumann,z=neumann");
        assert_eq!(slab.name().parse::<Boundary>().unwrap(), slab);
        let b: Boundary = "marshak, z=neumann, xmax=dirichlet".parse().unwrap();
        assert_eq!(b.faces(), [[M, D], [M, M], [N, N]]);
        assert_eq!(b.name(), "xmin=marshak,xmax=dirichlet,y=marshak,z=neumann");
        assert_eq!(b.name().parse::<Boundary>().unwrap(), b);
        // Six equal faces are the uniform variant.
        assert_eq!(
            "x=dirichlet,y=dirichlet,dirichlet"
                .parse::<Boundary>()
                .unwrap(),
            Boundary::Dirichlet
        );
        assert!(b.has_marshak(3) && !"z=marshak".parse::<Boundary>().unwrap().has_marshak(2));
        assert!("z=marshak".parse::<Boundary>().unwrap().all_neumann(2));
        for bad in [
            "",
            "vacuum",
            "w=marshak",
            "xmid=marshak",
            "x=foo",
            "x=marshak,,",
        ] {
            let e = bad.parse::<Boundary>().unwrap_err().to_string();
            assert!(!e.is_empty(), "{bad}");
        }
        let json = serde_json::to_string(&slab).unwrap();
        assert_eq!(json, "\"x=marshak,y=neumann,z=neumann\"");
        assert_eq!(serde_json::from_str::<Boundary>(&json).unwrap(), slab);
    }
}
