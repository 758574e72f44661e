//! Media from voxel files (`.vol`, `.npy`, OpenVDB) and arrays: the density and albedo
//! grids of `kind = "grid"`, and [`RenderScene::set_density_arrays`].

use super::*;
use crate::medium::DensityGrid;
use anyhow::{bail, ensure, Context};
use pn_formats::read_npy;
use pn_formats::read_vol;
use pn_formats::{read_vdb, IndexBox, VdbGrid};
use std::path::{Path, PathBuf};
use std::sync::Arc;

/// Bytes a voxel of each array takes while [`RenderScene::set_density_arrays`] builds the
/// medium from it: the f64 value handed over and the f32 the grid keeps.
pub const ARRAY_BYTES_PER_VOXEL: u128 = 12;

/// Checks the shape (nx, ny, nz) of `arrays` density or albedo arrays of that shape before
/// they are copied for [`RenderScene::set_density_arrays`]: no zero-length axis, and their copy
/// ([`ARRAY_BYTES_PER_VOXEL`] a voxel each) within `limit` bytes, the refusal giving the
/// figure. The Python binding checks numpy arrays with it (`limit`: the default memory limit
/// of a solve, [`pn_runtime::memory_estimate::default_limit_bytes`]), so that a huge or
/// broadcast array is refused before anything is allocated. `name` starts the message.
pub fn check_array_shape(
    name: &str,
    dims: [usize; 3],
    arrays: u32,
    limit: u64,
) -> anyhow::Result<()> {
    ensure!(
        dims.iter().all(|&n| n > 0),
        "{name} has a zero-length axis: shape {dims:?}"
    );
    let voxels: u128 = dims.iter().map(|&n| n as u128).product();
    let bytes = voxels
        .saturating_mul(ARRAY_BYTES_PER_VOXEL)
        .saturating_mul(arrays as u128);
    ensure!(
        bytes <= limit as u128,
        "{name} of shape {dims:?} is {voxels} voxels: copying it{} takes about {}, more than \
         the memory limit of {}",
        if arrays > 1 { " and the albedo" } else { "" },
        pn_runtime::memory_estimate::human_bytes(bytes),
        pn_runtime::memory_estimate::human_bytes(limit as u128)
    );
    Ok(())
}

impl RenderScene {
    /// Replaces the medium's density, and optionally its albedo, by arrays held in memory
    /// (the Python package): `density` and `albedo` in C order of shape `dims` = (nx, ny, nz),
    /// x the slowest axis, as `.npy` files are read; they cover the scene's medium box. The
    /// checks are those of grid files: finite, non-negative densities, albedos in [0, 1].
    pub fn set_density_arrays(
        &mut self,
        dims: [usize; 3],
        density: Vec<f64>,
        albedo: Option<Vec<f64>>,
    ) -> anyhow::Result<()> {
        let (bmin, bmax) = (self.medium.bbox_min, self.medium.bbox_max);
        let vg = pn_runtime::field::VoxelGrid::new(dims, bmin, bmax, density).context("density")?;
        let grid = DensityGrid::from_voxel_grid(&vg, bmin, bmax).context("density")?;
        if let Some(a) = albedo {
            ensure!(
                self.colours.as_ref().is_none_or(|c| c.albedo.is_none()),
                "give the albedo per channel or as an array, not both"
            );
            let va = pn_runtime::field::VoxelGrid::new(dims, bmin, bmax, a).context("albedo")?;
            self.medium.albedo = albedo_voxels(&va, bmin, bmax).context("albedo")?;
        }
        self.medium.resolution = grid.res;
        self.medium.source = MediumSource::File {
            path: PathBuf::from("<array>"),
            grid: Arc::new(grid),
        };
        Ok(())
    }
}

/// What a grid file holds: its voxels, whether the file placed them in space, and for a VDB
/// file the grid itself with the index box read (to read a second grid over the same voxels).
pub(super) struct GridFile {
    pub(super) voxels: pn_runtime::field::VoxelGrid,
    pub(super) placed: bool,
    pub(super) vdb: Option<(VdbGrid, IndexBox)>,
}

/// Reads a `.vol`, `.npy` or `.vdb` grid file; `grid` names the grid of a VDB file.
pub(super) fn read_grid_file(path: &Path, grid: Option<&str>) -> anyhow::Result<GridFile> {
    let ext = path.extension().and_then(|e| e.to_str());
    ensure!(
        grid.is_none() || ext == Some("vdb"),
        "{}: a grid name applies to .vdb files only",
        path.display()
    );
    match ext {
        Some("vol") => Ok(GridFile {
            voxels: read_vol(path)?,
            placed: true,
            vdb: None,
        }),
        Some("npy") => {
            let a = read_npy(path)?;
            ensure!(
                a.shape.len() == 3,
                "{}: expected a 3D array of shape (nx, ny, nz), got shape {:?}",
                path.display(),
                a.shape
            );
            let dims = [a.shape[0], a.shape[1], a.shape[2]];
            let (min, max) = DEFAULT_BBOX;
            Ok(GridFile {
                voxels: pn_runtime::field::VoxelGrid::new(dims, min, max, a.data)?,
                placed: false,
                vdb: None,
            })
        }
        Some("vdb") => {
            let g = read_vdb(path, grid)?;
            let window = g.active_box.with_context(|| {
                format!("{}: grid {:?} has no active voxels", path.display(), g.name)
            })?;
            let voxels = g
                .dense(window)
                .with_context(|| format!("VDB file {}", path.display()))?;
            Ok(GridFile {
                voxels,
                placed: true,
                vdb: Some((g, window)),
            })
        }
        _ => bail!(
            "{}: unsupported grid file (expected .vol, .npy or .vdb)",
            path.display()
        ),
    }
}

/// A per-voxel albedo on the density's voxels (the box of the medium): every value in
/// [0, 1], the first other one named by its voxel (i, j, k).
pub(super) fn albedo_voxels(
    vg: &pn_runtime::field::VoxelGrid,
    bbox_min: [f64; 3],
    bbox_max: [f64; 3],
) -> anyhow::Result<Albedo> {
    if let Some(p) = vg.data.iter().position(|v| !(0.0..=1.0).contains(v)) {
        let [_, ny, nz] = vg.dims;
        let (i, j, k) = (p / (ny * nz), (p / nz) % ny, p % nz);
        bail!(
            "albedo must lie in [0, 1], voxel ({i}, {j}, {k}) is {}",
            vg.data[p]
        );
    }
    let g = DensityGrid::from_voxel_grid(vg, bbox_min, bbox_max)?;
    Ok(Albedo::Voxels(Arc::new(g.data)))
}

/// Reads the albedo grid file. A VDB albedo next to a VDB density is read over the density's
/// index box (its inactive voxels read as 0) and must share the density's transform, so that
/// the two grids' voxels coincide; otherwise the file's voxels are taken as they are.
pub(super) fn read_albedo_file(
    path: &Path,
    grid: Option<&str>,
    density: Option<&(VdbGrid, IndexBox)>,
) -> anyhow::Result<pn_runtime::field::VoxelGrid> {
    match density {
        Some((d, window)) if path.extension().and_then(|e| e.to_str()) == Some("vdb") => {
            let a = read_vdb(path, grid)?;
            ensure!(
                a.transform == d.transform,
                "{}: grid {:?} has the index-to-world map {:?}, the density grid {:?} has {:?}; \
                 the two grids must share one transform",
                path.display(),
                a.name,
                a.transform,
                d.name,
                d.transform
            );
            a.dense(*window)
                .with_context(|| format!("VDB file {}", path.display()))
        }
        _ => Ok(read_grid_file(path, grid)?.voxels),
    }
}
