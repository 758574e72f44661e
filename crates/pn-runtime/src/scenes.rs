//! Built-in solve scenes: `checkerboard`, `checkerboard3d` and `pointsource` (docs/design.md §7),
//! and the vacuum-boundary checks `slab` and `milne` ([`crate::scenes::vacuum`]), built in code; their names and descriptions are in [`crate::scene_registry`], which also
//! knows the render scenes (`pn render`). Scene files for `pn solve` are read by
//! `pn_render::scene_file`.

pub mod vacuum;

use crate::field::{Field, Point};
use crate::problem::{Boundary, Grid, Phase, Problem, Scattering, SourceTerm};
use crate::scene_registry::{self, SceneKind};
use anyhow::{bail, ensure};
use pn_stencil::Dim;

/// A problem with a name, a default P_N order and remarks for the user.
#[derive(Clone, Debug)]
pub struct Scene {
    /// Scene name (built-in name or file stem).
    pub name: String,
    /// The problem.
    pub problem: Problem,
    /// Order used when `--order` is not given.
    pub default_order: usize,
    /// Remarks worth printing (e.g. about resolutions or 2D point sources).
    pub notes: Vec<String>,
}

/// Names of the built-in solve scenes (the [`SceneKind::Solve`] entries of
/// [`crate::scene_registry::BUILTIN_SCENES`]).
pub fn builtin_names() -> Vec<&'static str> {
    scene_registry::names(SceneKind::Solve)
}

/// The source of the `pointsource` scene.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum PointSourceShape {
    /// `Q_0^0 = 1/h^d` in the cell at index n/2 on every axis.
    Cell,
    /// A normalised Gaussian (∫ Q_0^0 dV = 1) with this standard deviation, centred on
    /// the centre of that cell.
    Gaussian(f64),
}

impl std::str::FromStr for PointSourceShape {
    type Err = anyhow::Error;
    fn from_str(s: &str) -> anyhow::Result<Self> {
        if s == "cell" {
            return Ok(PointSourceShape::Cell);
        }
        if let Some(sd) = s.strip_prefix("gaussian:") {
            let v: f64 = sd
                .parse()
                .map_err(|_| anyhow::anyhow!("bad Gaussian width {sd:?} in --source"))?;
            ensure!(
                v.is_finite() && v > 0.0,
                "the Gaussian width in --source must be positive, got {v}"
            );
            return Ok(PointSourceShape::Gaussian(v));
        }
        bail!("unknown source {s:?} (expected cell or gaussian:<std-dev>)")
    }
}

/// Parameters of the `pointsource` scene (the paper's setup by default).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PointSourceParams {
    /// Extinction σ_t.
    pub sigma_t: f64,
    /// Albedo α.
    pub albedo: f64,
    /// Henyey–Greenstein g (0 = isotropic).
    pub g: f64,
    /// The domain is `[0, 2w]` per axis, centred on the source for odd resolutions n. For
    /// even n the source cell n/2 (the paper's cell (40,40,40) of 80³ on [0,2]³) has its
    /// centre h/2 past the domain centre on each axis, so the boundary is h/2 nearer on the
    /// − side; profiles and reference solutions are taken from the source cell centre.
    pub half_width: f64,
    /// Source shape.
    pub source: PointSourceShape,
}

impl Default for PointSourceParams {
    fn default() -> Self {
        Self {
            sigma_t: 8.0,
            albedo: 0.9,
            g: 0.0,
            half_width: 1.0,
            source: PointSourceShape::Cell,
        }
    }
}

/// Options that shape a built-in scene.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct BuiltinOptions {
    /// Dimension (scene default when `None`).
    pub dim: Option<Dim>,
    /// Resolution: one value for all axes, or one per axis.
    pub res: Option<Vec<usize>>,
    /// Parameters of `pointsource`.
    pub pointsource: PointSourceParams,
    /// Parameters of `slab` and `milne`.
    pub slab: crate::scenes::vacuum::SlabParams,
}

/// Builds the built-in scene `name`. A render scene's name (`cloud`, …) is refused with a
/// message naming `pn render`; other unknown names with the list of built-in solve scenes.
pub fn builtin(name: &str, opts: &BuiltinOptions) -> anyhow::Result<Scene> {
    match name {
        "checkerboard" => checkerboard(opts, false),
        "checkerboard3d" => checkerboard(opts, true),
        "pointsource" => pointsource(opts),
        "slab" => crate::scenes::vacuum::slab(opts.dim, opts.res.as_deref(), opts.slab),
        "milne" => crate::scenes::vacuum::milne(opts.dim, opts.res.as_deref(), opts.slab),
        _ => Err(
            scene_registry::wrong_kind_error(name, SceneKind::Solve).unwrap_or_else(|| {
                anyhow::anyhow!(
                    "unknown scene {name:?} (built-in scenes: {}; or a path to a .toml scene file)",
                    builtin_names().join(", ")
                )
            }),
        ),
    }
}

/// Resolves `--res` (one value for all axes or one per axis) for a grid of dimension `dim`.
pub fn resolve_res(dim: Dim, default: usize, res: Option<&[usize]>) -> anyhow::Result<[usize; 3]> {
    let axes = dim.axes();
    let r = match res {
        None => {
            let mut r = [default; 3];
            if dim == Dim::Two {
                r[2] = 1;
            }
            r
        }
        Some([n]) => {
            let mut r = [*n; 3];
            if dim == Dim::Two {
                r[2] = 1;
            }
            r
        }
        Some(v) if v.len() == axes => [v[0], v[1], if axes == 3 { v[2] } else { 1 }],
        Some(v) if v.len() == 3 && dim == Dim::Two && v[2] == 1 => [v[0], v[1], 1],
        Some(v) => bail!(
            "--res needs 1 or {axes} values for a {axes}D problem, got {}",
            v.len()
        ),
    };
    ensure!(
        r.iter().all(|&n| n > 0),
        "resolution must be positive on every axis, got {}×{}×{}",
        r[0],
        r[1],
        r[2]
    );
    Ok(r)
}

/// The 2D lattice rule of docs/design.md §7 for block (cx, cy) = (⌈x⌉, ⌈y⌉).
pub fn checkerboard_absorbs_2d(x: f64, y: f64) -> bool {
    let (cx, cy) = (x.ceil() as i64, y.ceil() as i64);
    (cx + cy) % 2 == 0 && 1 < cx && cx < 7 && 1 < cy && cy - 2 * (cx - 4).abs() < 4
}

/// The 3D lattice rule of docs/design.md §7.
pub fn checkerboard_absorbs_3d(x: f64, y: f64, z: f64) -> bool {
    let (cx, cz) = (x.ceil() as i64, z.ceil() as i64);
    checkerboard_absorbs_2d(x, y) && (cx + cz) % 2 == 0 && 1 < cx && cx < 7 && 1 < cz && cz < 7
}

fn checkerboard(opts: &BuiltinOptions, lattice3d: bool) -> anyhow::Result<Scene> {
    let dim = opts
        .dim
        .unwrap_or(if lattice3d { Dim::Three } else { Dim::Two });
    let res = resolve_res(dim, if lattice3d { 31 } else { 71 }, opts.res.as_deref())?;
    let absorbs = move |p: Point| {
        if lattice3d {
            checkerboard_absorbs_3d(p[0], p[1], p[2])
        } else {
            checkerboard_absorbs_2d(p[0], p[1])
        }
    };
    // Absorbing blocks: σ_a = 10, σ_s = 0; elsewhere σ_a = 0, σ_s = 1.
    let sigma_t = Field::analytic(move |p| if absorbs(p) { 10.0 } else { 1.0 });
    let sigma_s = Field::analytic(move |p| if absorbs(p) { 0.0 } else { 1.0 });
    let inside = |v: f64| 3.0 < v && v < 4.0;
    let q = Field::analytic(move |p: Point| {
        let z_ok = !lattice3d || inside(p[2]);
        if inside(p[0]) && inside(p[1]) && z_ok {
            1.0
        } else {
            0.0
        }
    });
    let mut notes = Vec::new();
    for (d, &n) in res.iter().enumerate().take(dim.axes()) {
        if n % 7 == 0 {
            notes.push(format!(
                "resolution {n} on axis {d} puts grid faces on block boundaries (7k/n is an integer); \
                 the block rule then depends on rounding"
            ));
        }
    }
    let grid = Grid {
        dim,
        min: [0.0; 3],
        max: [7.0; 3],
        res,
    };
    Ok(Scene {
        name: if lattice3d {
            "checkerboard3d"
        } else {
            "checkerboard"
        }
        .into(),
        problem: Problem {
            grid,
            sigma_t,
            scattering: Scattering::SigmaS(sigma_s),
            phase: Phase::Isotropic,
            sources: vec![SourceTerm {
                l: 0,
                m: 0,
                field: q,
            }],
            boundary: Boundary::Neumann,
            sigma_t_min: None,
        },
        default_order: if lattice3d { 1 } else { 5 },
        notes,
    })
}

fn pointsource(opts: &BuiltinOptions) -> anyhow::Result<Scene> {
    let p = opts.pointsource;
    ensure!(
        p.sigma_t.is_finite() && p.sigma_t > 0.0,
        "--sigma-t must be positive, got {}",
        p.sigma_t
    );
    ensure!(
        (0.0..=1.0).contains(&p.albedo),
        "--albedo must lie in [0, 1], got {}",
        p.albedo
    );
    ensure!(
        p.g.is_finite() && p.g.abs() < 1.0,
        "--g must satisfy |g| < 1, got {}",
        p.g
    );
    ensure!(
        p.half_width.is_finite() && p.half_width > 0.0,
        "--half-width must be positive, got {}",
        p.half_width
    );
    let dim = opts.dim.unwrap_or(Dim::Three);
    let res = resolve_res(dim, 80, opts.res.as_deref())?;
    let w = p.half_width;
    let grid = Grid {
        dim,
        min: [0.0; 3],
        max: [2.0 * w; 3],
        res,
    };
    let axes = dim.axes();
    let h: Vec<f64> = (0..3).map(|d| grid.h(d)).collect();
    // The source cell: index n/2 on every axis (cell (40,40,40) for 80³ cells).
    let cell: Vec<usize> = res.iter().map(|n| n / 2).collect();
    let centre: Vec<f64> = (0..3)
        .map(|d| grid.min[d] + (cell[d] as f64 + 0.5) * h[d])
        .collect();
    let vol: f64 = h.iter().take(axes).product();
    let min = grid.min;
    let q = match p.source {
        PointSourceShape::Cell => Field::analytic(move |x: Point| {
            let hit = (0..axes).all(|d| ((x[d] - min[d]) / h[d]).floor() as i64 == cell[d] as i64);
            if hit {
                1.0 / vol
            } else {
                0.0
            }
        }),
        PointSourceShape::Gaussian(s) => {
            let norm = (2.0 * std::f64::consts::PI * s * s).powf(-(axes as f64) / 2.0);
            Field::analytic(move |x: Point| {
                let r2: f64 = (0..axes).map(|d| (x[d] - centre[d]).powi(2)).sum();
                norm * (-r2 / (2.0 * s * s)).exp()
            })
        }
    };
    let mut notes = Vec::new();
    if dim == Dim::Two {
        notes.push("pointsource in 2D is a line source along z (z-independent), not the 3D Green's function".into());
    }
    Ok(Scene {
        name: "pointsource".into(),
        problem: Problem {
            grid,
            sigma_t: Field::Constant(p.sigma_t),
            scattering: Scattering::Albedo(Field::Constant(p.albedo)),
            phase: if p.g == 0.0 {
                Phase::Isotropic
            } else {
                Phase::HenyeyGreenstein(p.g)
            },
            sources: vec![SourceTerm {
                l: 0,
                m: 0,
                field: q,
            }],
            boundary: Boundary::Neumann,
            sigma_t_min: None,
        },
        default_order: 1,
        notes,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn checkerboard_has_eleven_absorbing_blocks() {
        let mut n = 0;
        for cx in 1..=7 {
            for cy in 1..=7 {
                if checkerboard_absorbs_2d(cx as f64 - 0.5, cy as f64 - 0.5) {
                    n += 1;
                }
            }
        }
        assert_eq!(n, 11);
    }

    #[test]
    fn res_rules() {
        assert_eq!(resolve_res(Dim::Two, 71, None).unwrap(), [71, 71, 1]);
        assert_eq!(resolve_res(Dim::Three, 71, Some(&[5])).unwrap(), [5, 5, 5]);
        assert_eq!(
            resolve_res(Dim::Three, 71, Some(&[5, 6, 1])).unwrap(),
            [5, 6, 1]
        );
        assert!(resolve_res(Dim::Three, 71, Some(&[5, 6])).is_err());
        assert!(resolve_res(Dim::Two, 71, Some(&[0])).is_err());
        assert!(builtin("nope", &BuiltinOptions::default()).is_err());
    }

    #[test]
    fn every_registered_solve_scene_builds_and_render_names_point_to_pn_render() {
        let opts = BuiltinOptions {
            res: Some(vec![4]),
            ..Default::default()
        };
        for name in builtin_names() {
            let s = builtin(name, &opts).unwrap_or_else(|e| panic!("{name}: {e:#}"));
            assert_eq!(s.name, name);
        }
        let e = format!("{:#}", builtin("cloud", &opts).unwrap_err());
        assert!(e.contains("`pn render cloud`"), "{e}");
        let e = format!("{:#}", builtin("nope", &opts).unwrap_err());
        assert!(
            e.contains("unknown scene") && e.contains("checkerboard3d"),
            "{e}"
        );
    }

    #[test]
    fn point_source_has_unit_integral() {
        let s = builtin(
            "pointsource",
            &BuiltinOptions {
                res: Some(vec![8]),
                ..Default::default()
            },
        )
        .unwrap();
        let g = &s.problem.grid;
        let mut total = 0.0;
        for i in 0..8 {
            for j in 0..8 {
                for k in 0..8 {
                    let p = [i, j, k].map(|c| (c as f64 + 0.5) * g.h(0));
                    total += s.problem.source(0, 0, p).unwrap() * g.cell_volume();
                }
            }
        }
        assert!((total - 1.0).abs() < 1e-12);
    }
}
