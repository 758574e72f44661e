//! TOML scene files for `pn solve`: the transport problem on a grid (see
//! [`pn_runtime::scene_registry`] for how they differ from the render scenes of `pn render`).
//!
//! ```toml
//! name = "cloud"                 # optional; default: the file stem
//! dim = 3                        # 2 or 3 (default 3)
//! resolution = [64, 64, 64]      # optional when a voxel file gives it
//! domain_min = [0.0, 0.0, 0.0]   # default: the first .vol's bounding box, else [0,0,0]
//! domain_max = [1.0, 1.0, 1.0]   # default: the first .vol's bounding box, else [1,1,1]
//! order = 3                      # default P_N order (default 1)
//! boundary = "neumann"           # or "dirichlet"
//! sigma_t_min = 1e-3             # needed where σ_t reaches 0
//! sigma_t = { file = "density.vol", scale = 40.0 }   # a number, or a .vol / .npy file
//! albedo = 0.9                   # or sigma_s = ... (exactly one of the two)
//! g = 0.0                        # Henyey–Greenstein g; 0 = isotropic
//!
//! [[source]]                     # Q_l^m; repeat for more moments
//! l = 0
//! m = 0
//! value = 1.0                    # or file = "q.npy" (optionally scale = ...)
//! box_min = [0.4, 0.4, 0.4]      # optional: value only inside this box
//! box_max = [0.6, 0.6, 0.6]
//! ```
//!
//! Voxel data cover the domain cell-centred (data of another resolution than the grid are
//! interpolated trilinearly between their cell centres, with a note); `.npy` arrays have shape `(nx, ny, nz)` (or
//! `(nx, ny)` in 2D), C order, x the first axis; `.vol` follows docs/design.md §6. Relative paths
//! are relative to the scene file.

use anyhow::{bail, ensure, Context};
use pn_formats::read_npy;
use pn_formats::read_vol;
use pn_runtime::field::{Field, VoxelGrid};
use pn_runtime::problem::{Boundary, Grid, Phase, Problem, Scattering, SourceTerm};
use pn_runtime::scene_registry::{self, SceneKind};
use pn_runtime::scenes::Scene;
use pn_stencil::Dim;
use serde::Deserialize;
use std::path::{Path, PathBuf};
use std::sync::Arc;

/// A scalar given in the file: a number or voxel data.
#[derive(Deserialize, Debug, Clone)]
#[serde(untagged)]
enum FieldSpec {
    Value(f64),
    File(FileSpec),
}

#[derive(Deserialize, Debug, Clone)]
#[serde(deny_unknown_fields)]
struct FileSpec {
    file: PathBuf,
    #[serde(default = "one")]
    scale: f64,
}

fn one() -> f64 {
    1.0
}

#[derive(Deserialize, Debug)]
#[serde(deny_unknown_fields)]
struct SourceSpec {
    l: u32,
    m: i32,
    value: Option<f64>,
    file: Option<PathBuf>,
    #[serde(default = "one")]
    scale: f64,
    box_min: Option<[f64; 3]>,
    box_max: Option<[f64; 3]>,
}

#[derive(Deserialize, Debug)]
#[serde(deny_unknown_fields)]
struct SceneSpec {
    name: Option<String>,
    dim: Option<u8>,
    resolution: Option<Vec<usize>>,
    domain_min: Option<[f64; 3]>,
    domain_max: Option<[f64; 3]>,
    order: Option<usize>,
    boundary: Option<Boundary>,
    sigma_t_min: Option<f64>,
    sigma_t: FieldSpec,
    sigma_s: Option<FieldSpec>,
    albedo: Option<FieldSpec>,
    #[serde(default)]
    g: f64,
    #[serde(default)]
    source: Vec<SourceSpec>,
}

/// Reads and checks a scene file.
pub fn load_scene(path: &Path) -> anyhow::Result<Scene> {
    let text = pn_formats::read_text(path)
        .with_context(|| format!("cannot read scene file {}", path.display()))?;
    let spec: SceneSpec = toml::from_str(&text).map_err(|e| {
        let (line, col) = e.span().map(|s| line_col(&text, s.start)).unwrap_or((0, 0));
        let msg = e
            .message()
            .trim()
            .split('\n')
            .map(str::trim)
            .collect::<Vec<_>>()
            .join("; ");
        let hint = match crate::scene_kind::toml_kind(&text) {
            Some(SceneKind::Render) => format!(
                " ({})",
                scene_registry::wrong_kind_file_hint(path, SceneKind::Render)
            ),
            _ => String::new(),
        };
        anyhow::anyhow!("{}:{line}:{col}: {msg}{hint}", path.display())
    })?;
    let base = path.parent().unwrap_or(Path::new(".")).to_path_buf();
    build(spec, &base, path).with_context(|| format!("scene file {}", path.display()))
}

/// 1-based line and column of byte `offset` in `text`.
fn line_col(text: &str, offset: usize) -> (usize, usize) {
    let before = &text[..offset.min(text.len())];
    let line = before.matches('\n').count() + 1;
    let col = before
        .rsplit('\n')
        .next()
        .map(|l| l.chars().count())
        .unwrap_or(0)
        + 1;
    (line, col)
}

/// Voxel data loaded from a file, before it is placed on the domain.
struct Loaded {
    dims: [usize; 3],
    bbox: Option<([f64; 3], [f64; 3])>,
    data: Vec<f64>,
}

fn load_voxels(base: &Path, file: &Path) -> anyhow::Result<Loaded> {
    let path = base.join(file);
    match path.extension().and_then(|e| e.to_str()) {
        Some("vol") => {
            let g = read_vol(&path)?;
            Ok(Loaded {
                dims: g.dims,
                bbox: Some((g.min, g.max)),
                data: g.data,
            })
        }
        Some("npy") => {
            let a = read_npy(&path)?;
            let dims = match a.shape.as_slice() {
                [x, y] => [*x, *y, 1],
                [x, y, z] => [*x, *y, *z],
                s => bail!(
                    "{}: expected a 2D or 3D array, got shape {s:?}",
                    path.display()
                ),
            };
            ensure!(
                dims.iter().all(|&d| d > 0),
                "{}: empty array",
                path.display()
            );
            Ok(Loaded {
                dims,
                bbox: None,
                data: a.data,
            })
        }
        _ => bail!("{}: voxel data must be a .vol or .npy file", path.display()),
    }
}

fn build(spec: SceneSpec, base: &Path, path: &Path) -> anyhow::Result<Scene> {
    let dim = match spec.dim.unwrap_or(3) {
        2 => Dim::Two,
        3 => Dim::Three,
        d => bail!("dim must be 2 or 3, got {d}"),
    };
    // Load all voxel files first: they may define resolution and domain.
    let mut files: Vec<(String, PathBuf, f64, bool)> = Vec::new(); // (what, file, scale, non-negative)
    let mut push = |what: &str, f: &Option<FieldSpec>, nonneg: bool| {
        if let Some(FieldSpec::File(fs)) = f {
            files.push((what.to_string(), fs.file.clone(), fs.scale, nonneg));
        }
    };
    push("sigma_t", &Some(spec.sigma_t.clone()), true);
    push("sigma_s", &spec.sigma_s, true);
    push("albedo", &spec.albedo, true);
    let mut loaded = Vec::new();
    for (what, file, scale, nonneg) in &files {
        let l = load_voxels(base, file).with_context(|| format!("field {what}"))?;
        check_values(what, file, &l, *nonneg)?;
        ensure!(
            scale.is_finite() && *scale >= 0.0,
            "field {what}: scale must be non-negative, got {scale}"
        );
        loaded.push((what.clone(), l));
    }
    let mut source_voxels = Vec::new();
    for (i, s) in spec.source.iter().enumerate() {
        if let Some(f) = &s.file {
            let l = load_voxels(base, f).with_context(|| format!("source #{}", i + 1))?;
            check_values("source", f, &l, s.l == 0)?;
            source_voxels.push(Some(l));
        } else {
            source_voxels.push(None);
        }
    }

    let first = loaded
        .first()
        .map(|(_, l)| l)
        .or(source_voxels.iter().flatten().next());
    let res = match (&spec.resolution, first) {
        (Some(r), _) => pn_runtime::scenes::resolve_res(dim, 1, Some(r))?,
        (None, Some(l)) => {
            if dim == Dim::Two {
                [l.dims[0], l.dims[1], 1]
            } else {
                l.dims
            }
        }
        (None, None) => bail!("no resolution given (set resolution = [nx, ny, nz])"),
    };
    let bbox = loaded.iter().find_map(|(_, l)| l.bbox);
    let min = spec.domain_min.or(bbox.map(|b| b.0)).unwrap_or([0.0; 3]);
    let max = spec.domain_max.or(bbox.map(|b| b.1)).unwrap_or([1.0; 3]);
    let grid = Grid { dim, min, max, res };
    grid.validate()?;
    let mut notes = Vec::new();
    for l in loaded
        .iter()
        .map(|(_, l)| l)
        .chain(source_voxels.iter().flatten())
    {
        if l.dims != res {
            notes.push(format!(
                "voxel data of {}×{}×{} cells is interpolated trilinearly between its cell centres onto the {}×{}×{} grid",
                l.dims[0], l.dims[1], l.dims[2], res[0], res[1], res[2]
            ));
        }
    }
    notes.dedup();

    let to_field = |spec: &FieldSpec, l: Option<&Loaded>| -> anyhow::Result<Field> {
        Ok(match spec {
            FieldSpec::Value(v) => Field::Constant(*v),
            FieldSpec::File(fs) => {
                let l = l.context("internal: voxel data not loaded")?;
                let g = VoxelGrid::new(l.dims, min, max, l.data.clone())?;
                Field::Scaled(fs.scale, Box::new(Field::Voxel(Arc::new(g))))
            }
        })
    };
    let find = |what: &str| loaded.iter().find(|(w, _)| w == what).map(|(_, l)| l);
    let sigma_t = to_field(&spec.sigma_t, find("sigma_t"))?;
    let scattering = match (&spec.sigma_s, &spec.albedo) {
        (Some(s), None) => Scattering::SigmaS(to_field(s, find("sigma_s"))?),
        (None, Some(a)) => Scattering::Albedo(to_field(a, find("albedo"))?),
        (None, None) => bail!("give either sigma_s or albedo"),
        (Some(_), Some(_)) => bail!("give either sigma_s or albedo, not both"),
    };
    for (name, v) in [
        ("sigma_t", &spec.sigma_t),
        (
            "sigma_s",
            spec.sigma_s.as_ref().unwrap_or(&FieldSpec::Value(0.0)),
        ),
        (
            "albedo",
            spec.albedo.as_ref().unwrap_or(&FieldSpec::Value(0.0)),
        ),
    ] {
        if let FieldSpec::Value(x) = v {
            ensure!(
                x.is_finite() && *x >= 0.0,
                "{name} must be a non-negative number, got {x}"
            );
        }
    }
    ensure!(
        spec.g.is_finite() && spec.g.abs() < 1.0,
        "g must satisfy |g| < 1, got {}",
        spec.g
    );

    let sources = build_sources(&spec.source, source_voxels, min, max)?;
    ensure!(!sources.is_empty(), "the scene has no [[source]]");

    let problem = Problem {
        grid,
        sigma_t,
        scattering,
        phase: if spec.g == 0.0 {
            Phase::Isotropic
        } else {
            Phase::HenyeyGreenstein(spec.g)
        },
        sources,
        boundary: spec.boundary.unwrap_or(Boundary::Neumann),
        sigma_t_min: spec.sigma_t_min,
    };
    problem.validate()?;
    let name = spec.name.unwrap_or_else(|| {
        path.file_stem()
            .and_then(|s| s.to_str())
            .unwrap_or("scene")
            .to_string()
    });
    Ok(Scene {
        name,
        problem,
        default_order: spec.order.unwrap_or(1),
        notes,
    })
}

/// The `[[source]]` terms: a constant (optionally inside a box) or voxel data (`vox`, loaded
/// with the scene's other voxel files) over the domain `min`..`max`.
fn build_sources(
    specs: &[SourceSpec],
    vox: Vec<Option<Loaded>>,
    min: [f64; 3],
    max: [f64; 3],
) -> anyhow::Result<Vec<SourceTerm>> {
    let mut sources = Vec::new();
    for (s, vox) in specs.iter().zip(vox) {
        ensure!(
            s.m.unsigned_abs() <= s.l,
            "source Q_{}^{}: |m| must not exceed l",
            s.l,
            s.m
        );
        let field = match (s.value, vox) {
            (Some(v), None) => {
                ensure!(
                    v.is_finite(),
                    "source Q_{}^{}: value must be finite",
                    s.l,
                    s.m
                );
                match (s.box_min, s.box_max) {
                    (None, None) => Field::Constant(v),
                    (Some(lo), Some(hi)) => Field::analytic(move |p| {
                        if (0..3).all(|d| lo[d] <= p[d] && p[d] <= hi[d]) {
                            v
                        } else {
                            0.0
                        }
                    }),
                    _ => bail!("source Q_{}^{}: give both box_min and box_max", s.l, s.m),
                }
            }
            (None, Some(l)) => {
                ensure!(
                    s.scale.is_finite(),
                    "source Q_{}^{}: scale must be finite, got {}",
                    s.l,
                    s.m,
                    s.scale
                );
                ensure!(
                    s.box_min.is_none() && s.box_max.is_none(),
                    "source Q_{}^{}: box_min/box_max only apply to value",
                    s.l,
                    s.m
                );
                let g = VoxelGrid::new(l.dims, min, max, l.data)?;
                Field::Scaled(s.scale, Box::new(Field::Voxel(Arc::new(g))))
            }
            _ => bail!(
                "source Q_{}^{}: give exactly one of value and file",
                s.l,
                s.m
            ),
        };
        sources.push(SourceTerm {
            l: s.l,
            m: s.m,
            field,
        });
    }
    Ok(sources)
}

fn check_values(what: &str, file: &Path, l: &Loaded, nonneg: bool) -> anyhow::Result<()> {
    for (i, v) in l.data.iter().enumerate() {
        if !v.is_finite() || (nonneg && *v < 0.0) {
            let k = i % l.dims[2];
            let j = (i / l.dims[2]) % l.dims[1];
            let x = i / (l.dims[2] * l.dims[1]);
            bail!(
                "{what} from {}: value {v} at cell ({x}, {j}, {k}) is {}",
                file.display(),
                if v.is_finite() {
                    "negative"
                } else {
                    "not finite"
                }
            );
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn line_and_column() {
        assert_eq!(line_col("ab\ncd", 4), (2, 2));
        assert_eq!(line_col("ab", 0), (1, 1));
    }

    #[test]
    fn a_render_scene_file_points_to_pn_render() {
        let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../scenes/cloud.toml");
        let e = format!("{:#}", load_scene(&path).unwrap_err());
        assert!(e.contains("unknown field `medium`"), "{e}");
        assert!(
            e.contains("this is a render scene file: run it with `pn render "),
            "{e}"
        );
    }
}
