//! Result files: `fluence.npy`, `moments.npy`, `fluence.png` and `report.json`.
//!
//! Everything is written into a temporary directory next to the target and only then
//! moved into place, so an error never leaves half-written files in the output directory.

pub mod report;

use crate::npy::write_npy;
use crate::png;
use pn_runtime::pipeline::Solution;
use pn_runtime::problem::Grid;
use pn_stencil::Dim;
use report::SolveReport;
use std::path::Path;

/// Names of the files [`write_outputs`] produces.
pub const OUTPUT_FILES: [&str; 4] = ["fluence.npy", "moments.npy", "fluence.png", "report.json"];

/// Removes the temporary directory unless it was consumed.
/// Shape of a per-cell array: `(nx, ny)` in 2D, `(nx, ny, nz)` in 3D.
pub fn cell_shape(grid: &Grid) -> Vec<usize> {
    match grid.dim {
        Dim::Two => vec![grid.res[0], grid.res[1]],
        Dim::Three => grid.res.to_vec(),
    }
}

/// Writes all result files of `sol` into `dir` (created if needed), `report` as
/// `report.json` (each file is written into a temporary directory first and moved into
/// place only when all were written).
pub fn write_outputs(
    dir: &Path,
    grid: &Grid,
    sol: &Solution,
    report: &SolveReport,
) -> anyhow::Result<()> {
    let stage = crate::files::StagedDir::new(dir)?;
    let tmp = stage.path();

    let shape = cell_shape(grid);
    let l00 = sol.l00();
    write_npy(&tmp.join("fluence.npy"), &shape, &l00)?;
    let mut mshape = shape.clone();
    mshape.push(sol.moments.per_cell);
    write_npy(&tmp.join("moments.npy"), &mshape, &sol.moments.data)?;

    // 3D: the z-slice through the middle.
    let [nx, ny, nz] = grid.res;
    let k = nz / 2;
    let slice_vals: Vec<f64> = (0..nx)
        .flat_map(|i| (0..ny).map(move |j| (i, j)))
        .map(|(i, j)| l00[(i * ny + j) * nz + k])
        .collect();
    let title = match grid.dim {
        Dim::Two => format!("{}: log10 L_0^0", report.base.scene),
        Dim::Three => format!(
            "{}: log10 L_0^0, z = {:.4}",
            report.base.scene,
            grid.coord(2, 2 * k as i64 + 1)
        ),
    };
    png::write_png(
        &tmp.join("fluence.png"),
        &png::Slice {
            nx,
            ny,
            values: &slice_vals,
            min: [grid.min[0], grid.min[1]],
            max: [grid.max[0], grid.max[1]],
            title,
        },
    )?;
    crate::json::write_atomic(&tmp.join("report.json"), report)?;

    stage.commit()?;
    Ok(())
}
