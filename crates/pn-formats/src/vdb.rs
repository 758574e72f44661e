//! OpenVDB float grids (`.vdb`) read with the `vdb-rs` crate, as dense [`VoxelGrid`]s.
//!
//! What is read, and how it is placed (tests/data/vdb/README.md):
//! - one grid of value type `float` (`Tree_float_5_4_3`), chosen by name;
//! - its active voxels and active tiles (tiles fill their whole 8³ or 128³ block); inactive
//!   voxels read as 0, the background of fog volumes (vdb-rs 0.6 does not expose the stored
//!   background value);
//! - the dense block spanned by the active voxels' index bounding box;
//! - its world placement from the grid's index-to-world map: voxel `(i, j, k)` is the cell
//!   centred at `indexToWorld(i, j, k)`, so the medium box runs from
//!   `indexToWorld(bbox_min − ½)` to `indexToWorld(bbox_max + ½)`, which is what a `.vol`
//!   file of the same cells states in its header.
//!
//! Not supported, with an error that says so: half-precision grids (vdb-rs cannot decode
//! them), other value types, transforms other than (uniform) scale and translation,
//! mirrored (negative) scales, and files vdb-rs cannot parse. vdb-rs panics on some malformed
//! or unsupported input instead of returning an error; such a panic is caught here and
//! reported as an error naming the file.

use anyhow::{bail, ensure, Context};
use pn_runtime::field::VoxelGrid;
use std::io::BufReader;
use std::path::Path;

/// The value type vdb-rs can read as `f32`: OpenVDB's `FloatGrid` saved in full precision.
const FLOAT_TREE: &str = "Tree_float_5_4_3";

/// The densest grid this reader expands (cells; 1 GiB of f64), so that a stray voxel or tile
/// far away cannot ask for terabytes: the render's limit on a medium's voxels (2^27) too.
const MAX_DENSE_CELLS: usize = 1 << 27;

/// An inclusive box of voxel indices.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct IndexBox {
    /// Lowest index on each axis.
    pub min: [i64; 3],
    /// Highest index on each axis (inclusive).
    pub max: [i64; 3],
}

impl IndexBox {
    /// Voxels per axis.
    pub fn dims(&self) -> [usize; 3] {
        [0, 1, 2].map(|d| (self.max[d] - self.min[d] + 1) as usize)
    }
}

/// OpenVDB's index-to-world map, restricted to what vdb-rs reads: `world = scale·index + translation`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct IndexToWorld {
    /// Voxel size per axis.
    pub scale: [f64; 3],
    /// World position of index (0, 0, 0).
    pub translation: [f64; 3],
}

impl IndexToWorld {
    /// The world position of a (possibly fractional) index position.
    pub fn apply(&self, index: [f64; 3]) -> [f64; 3] {
        [0, 1, 2].map(|d| self.scale[d] * index[d] + self.translation[d])
    }
}

/// One float grid of a `.vdb` file: its active voxels, sparse, with the file's placement.
#[derive(Clone, Debug)]
pub struct VdbGrid {
    /// The grid's name in the file.
    pub name: String,
    /// Index-to-world map.
    pub transform: IndexToWorld,
    /// Index bounding box of the active voxels (`None` for a grid with none).
    pub active_box: Option<IndexBox>,
    /// Active leaf voxels as (index, value).
    pub voxels: Vec<([i64; 3], f32)>,
    /// Active tiles: blocks of voxels with one value, kept as blocks (a damaged file's tile
    /// could otherwise expand to billions of voxels before any size is checked; fuzzer
    /// finding, issue 53). [`Self::dense`] fills them in.
    pub tiles: Vec<VdbTile>,
}

/// An active tile of a VDB tree: the `size`³ voxels from `origin` on, all `value`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct VdbTile {
    /// Index of the block's first voxel.
    pub origin: [i64; 3],
    /// Voxels per side.
    pub size: i64,
    /// The value of every voxel of the block.
    pub value: f32,
}

impl VdbTile {
    /// Index of the block's last voxel (saturating: a damaged file's far-out tile must not
    /// overflow).
    pub fn last(&self) -> [i64; 3] {
        self.origin.map(|c| c.saturating_add(self.size - 1))
    }
}

impl VdbGrid {
    /// The dense block over `window` (inactive voxels read as 0), placed in world space by
    /// the grid's transform (module docs).
    pub fn dense(&self, window: IndexBox) -> anyhow::Result<VoxelGrid> {
        let dims = window.dims();
        let cells = dims
            .iter()
            .try_fold(1usize, |acc, &n| acc.checked_mul(n))
            .filter(|&n| n <= MAX_DENSE_CELLS)
            .with_context(|| {
                format!(
                    "grid {:?}: the index box {:?}..={:?} ({:?} voxels) is too large to read \
                     densely (at most {MAX_DENSE_CELLS} cells)",
                    self.name, window.min, window.max, dims
                )
            })?;
        let mut data = vec![0.0f64; cells];
        for t in &self.tiles {
            // The tile's block clipped to the window.
            let lo = [0, 1, 2].map(|d| t.origin[d].max(window.min[d]));
            let hi = [0, 1, 2].map(|d| t.last()[d].min(window.max[d]));
            if (0..3).any(|d| lo[d] > hi[d]) {
                continue;
            }
            for i in lo[0]..=hi[0] {
                for j in lo[1]..=hi[1] {
                    let row = ((i - window.min[0]) as usize * dims[1]
                        + (j - window.min[1]) as usize)
                        * dims[2];
                    let (k0, k1) = (
                        (lo[2] - window.min[2]) as usize,
                        (hi[2] - window.min[2]) as usize,
                    );
                    data[row + k0..=row + k1].fill(f64::from(t.value));
                }
            }
        }
        for &(p, v) in &self.voxels {
            if (0..3).all(|d| (window.min[d]..=window.max[d]).contains(&p[d])) {
                let [i, j, k] = [0, 1, 2].map(|d| (p[d] - window.min[d]) as usize);
                data[(i * dims[1] + j) * dims[2] + k] = f64::from(v);
            }
        }
        let lo = window.min.map(|c| c as f64 - 0.5);
        let hi = window.max.map(|c| c as f64 + 0.5);
        VoxelGrid::new(
            dims,
            self.transform.apply(lo),
            self.transform.apply(hi),
            data,
        )
    }

    /// Active voxels: the leaf voxels and every voxel of the active tiles.
    pub fn active_voxel_count(&self) -> u128 {
        self.voxels.len() as u128
            + self
                .tiles
                .iter()
                .map(|t| (t.size as u128).pow(3))
                .sum::<u128>()
    }

    /// The dense block over the active bounding box.
    pub fn dense_active(&self) -> anyhow::Result<VoxelGrid> {
        let window = self
            .active_box
            .with_context(|| format!("grid {:?} has no active voxels", self.name))?;
        self.dense(window)
    }
}

/// Reads grid `name` of a `.vdb` file; with `name = None`, the grid called `density`, or the
/// file's only grid.
pub fn read_vdb(path: &Path, name: Option<&str>) -> anyhow::Result<VdbGrid> {
    read_vdb_inner(path, name).with_context(|| format!("VDB file {}", path.display()))
}

fn read_vdb_inner(path: &Path, name: Option<&str>) -> anyhow::Result<VdbGrid> {
    let file = std::fs::File::open(path).context("cannot open the file")?;
    // A stream (`/dev/zero`), device or folder is refused before the reader sees it.
    anyhow::ensure!(
        file.metadata().context("cannot open the file")?.is_file(),
        "not a regular file (a folder, device or stream)"
    );
    let grid = catch_reader_panic(move || -> anyhow::Result<VdbGrid> {
        let mut reader = vdb_rs::VdbReader::new(BufReader::new(file))
            .map_err(|e| anyhow::anyhow!("not a readable VDB file ({})", describe(&e)))?;
        let mut names = reader.available_grids();
        names.sort();
        let name = match name {
            Some(n) => n.to_owned(),
            None if names.iter().any(|n| n == "density") => "density".to_owned(),
            None if names.len() == 1 => names[0].clone(),
            None => bail!("the file holds the grids {names:?}; say which one with the `grid` key"),
        };
        let desc = reader
            .grid_descriptors
            .get(&name)
            .with_context(|| format!("the file has no grid named {name:?} (it has {names:?})"))?;
        let ty = desc.grid_type.as_str();
        if ty.starts_with(FLOAT_TREE)
            && (ty.ends_with("_HalfFloat") || desc.meta_data.is_half_float())
        {
            bail!(
                "grid {name:?} is saved in half precision, which this reader (vdb-rs 0.6) cannot \
                 decode; save it in full precision (OpenVDB: setSaveFloatAsHalf(false))"
            );
        }
        ensure!(
            ty == FLOAT_TREE,
            "grid {name:?} has value type {ty:?}; only float grids ({FLOAT_TREE}) are supported"
        );
        let grid = reader
            .read_grid::<f32>(&name)
            .map_err(|e| anyhow::anyhow!("grid {name:?} cannot be read ({})", describe(&e)))?;
        let transform = match grid.transform {
            vdb_rs::Map::UniformScaleMap { scale_values, .. } => IndexToWorld {
                scale: scale_values.to_array(),
                translation: [0.0; 3],
            },
            vdb_rs::Map::ScaleTranslateMap {
                scale_values,
                translation,
                ..
            } => IndexToWorld {
                scale: scale_values.to_array(),
                translation: translation.to_array(),
            },
        };
        ensure!(
            transform.scale.iter().all(|s| s.is_finite() && *s > 0.0)
                && transform.translation.iter().all(|t| t.is_finite()),
            "grid {name:?}: the index-to-world map {transform:?} is not a positive, finite scale \
             and translation (mirrored grids are not supported)"
        );
        let mut voxels = Vec::new();
        let mut tiles = Vec::new();
        for (pos, value, level) in grid.iter() {
            let origin = pos.to_array().map(|c| c.round() as i64);
            let size = level.scale() as i64;
            if size == 1 {
                voxels.push((origin, value));
            } else {
                tiles.push(VdbTile {
                    origin,
                    size,
                    value,
                });
            }
        }
        if let Some((p, v)) = voxels.iter().find(|(_, v)| !v.is_finite()) {
            bail!("grid {name:?}: voxel {p:?} holds {v}, not a finite number");
        }
        if let Some(t) = tiles.iter().find(|t| !t.value.is_finite()) {
            bail!(
                "grid {name:?}: the tile at {:?} holds {}, not a finite number",
                t.origin,
                t.value
            );
        }
        let corners = voxels
            .iter()
            .flat_map(|&(p, _)| [p, p])
            .chain(tiles.iter().flat_map(|t| [t.origin, t.last()]));
        let active_box = corners.fold(None, |b: Option<IndexBox>, q| {
            Some(match b {
                None => IndexBox { min: q, max: q },
                Some(b) => IndexBox {
                    min: [0, 1, 2].map(|d| b.min[d].min(q[d])),
                    max: [0, 1, 2].map(|d| b.max[d].max(q[d])),
                },
            })
        });
        Ok(VdbGrid {
            name,
            transform,
            active_box,
            voxels,
            tiles,
        })
    })?;
    Ok(grid)
}

/// vdb-rs's errors print as bare variant names ("IoError"); say what they mean.
fn describe(e: &vdb_rs::ParseError) -> String {
    match e {
        vdb_rs::ParseError::IoError(io) if io.kind() == std::io::ErrorKind::UnexpectedEof => {
            "the file ends early: truncated or damaged".to_owned()
        }
        vdb_rs::ParseError::IoError(io) => format!("read error: {io}"),
        vdb_rs::ParseError::MagicMismatch => "the OpenVDB magic number is missing".to_owned(),
        vdb_rs::ParseError::UnsupportedVersion(v) => format!("unsupported file version {v}"),
        other => other.to_string(),
    }
}

/// Runs `f`, turning a panic inside vdb-rs into an error. The default panic message is
/// suppressed while `f` runs (the hook is process-wide; the reader runs before any solve).
fn catch_reader_panic<T>(f: impl FnOnce() -> anyhow::Result<T>) -> anyhow::Result<T> {
    let hook = std::panic::take_hook();
    std::panic::set_hook(Box::new(|_| {}));
    let result = std::panic::catch_unwind(std::panic::AssertUnwindSafe(f));
    std::panic::set_hook(hook);
    match result {
        Ok(r) => r,
        Err(payload) => {
            let msg = payload
                .downcast_ref::<&str>()
                .map(|s| s.to_string())
                .or_else(|| payload.downcast_ref::<String>().cloned())
                .unwrap_or_else(|| "no message".to_owned());
            bail!("the VDB reader (vdb-rs) gave up on this file: {msg}")
        }
    }
}
