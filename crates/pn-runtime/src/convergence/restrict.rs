//! Restriction of cell-centred fields to coarser grids and block averages.

use crate::problem::Grid;
use anyhow::{ensure, Result};

/// The integer ratio `fine/coarse` per axis; an error when an axis does not nest.
pub fn restriction_ratio(fine: [usize; 3], coarse: [usize; 3]) -> Result<[usize; 3]> {
    let mut r = [1; 3];
    for d in 0..3 {
        ensure!(
            coarse[d] > 0 && fine[d] >= coarse[d] && fine[d].is_multiple_of(coarse[d]),
            "resolution {}×{}×{} does not nest in {}×{}×{}: every axis must be an integer \
             multiple of the coarser one",
            fine[0],
            fine[1],
            fine[2],
            coarse[0],
            coarse[1],
            coarse[2]
        );
        r[d] = fine[d] / coarse[d];
    }
    Ok(r)
}

/// Restricts `fine` (cells `fine_res`) to `coarse_res` cells: every coarse cell gets the
/// mean of its `r_x·r_y·r_z` children. This is the cell average of the piecewise-constant
/// fine field, so it is exact for constants and for fields linear in the cell index (the
/// mean of a linear function over symmetric children is its value at the coarse centre).
pub fn restrict(fine: &[f64], fine_res: [usize; 3], coarse_res: [usize; 3]) -> Result<Vec<f64>> {
    let n: usize = fine_res.iter().product();
    ensure!(
        fine.len() == n,
        "field has {} values, the grid {:?} has {n} cells",
        fine.len(),
        fine_res
    );
    let r = restriction_ratio(fine_res, coarse_res)?;
    let [cx, cy, cz] = coarse_res;
    let [_, fy, fz] = fine_res;
    let children = (r[0] * r[1] * r[2]) as f64;
    let mut out = vec![0.0; cx * cy * cz];
    for i in 0..cx {
        for j in 0..cy {
            for k in 0..cz {
                let mut s = 0.0;
                for a in 0..r[0] {
                    for b in 0..r[1] {
                        let row = ((i * r[0] + a) * fy + j * r[1] + b) * fz + k * r[2];
                        s += fine[row..row + r[2]].iter().sum::<f64>();
                    }
                }
                out[(i * cy + j) * cz + k] = s / children;
            }
        }
    }
    Ok(out)
}

/// Overlap lengths of the cells of one axis with the blocks of that axis:
/// `(cell, block, length)` for every non-empty overlap.
fn overlaps(min: f64, max: f64, cells: usize, blocks: usize) -> Vec<(usize, usize, f64)> {
    let h = (max - min) / cells as f64;
    let b = (max - min) / blocks as f64;
    let mut out = Vec::new();
    for i in 0..cells {
        let (lo, hi) = (min + i as f64 * h, min + (i + 1) as f64 * h);
        let first = (((lo - min) / b).floor().max(0.0) as usize).min(blocks - 1);
        for k in first..blocks {
            let (blo, bhi) = (min + k as f64 * b, min + (k + 1) as f64 * b);
            if blo >= hi {
                break;
            }
            let len = hi.min(bhi) - lo.max(blo);
            if len > 0.0 {
                out.push((i, k, len));
            }
        }
    }
    out
}

/// Averages of the piecewise-constant cell field `values` over `blocks` equal blocks per
/// axis tiling the grid's domain (e.g. the checkerboard's 7×7 unit blocks), weighting every
/// cell by the volume it shares with the block. Exact for any resolution: cells cut by a
/// block face contribute to both blocks in proportion. Returns the blocks in C order.
pub fn block_averages(values: &[f64], grid: &Grid, blocks: [usize; 3]) -> Result<Vec<f64>> {
    ensure!(
        values.len() == grid.cells(),
        "field has {} values, the grid has {} cells",
        values.len(),
        grid.cells()
    );
    ensure!(
        blocks.iter().all(|&b| b > 0),
        "block counts must be positive, got {blocks:?}"
    );
    let ov: Vec<_> = (0..3)
        .map(|d| overlaps(grid.min[d], grid.max[d], grid.res[d], blocks[d]))
        .collect();
    let [_, ny, nz] = grid.res;
    let nb = blocks[0] * blocks[1] * blocks[2];
    let mut sum = vec![0.0; nb];
    let mut vol = vec![0.0; nb];
    for &(i, bi, wi) in &ov[0] {
        for &(j, bj, wj) in &ov[1] {
            for &(k, bk, wk) in &ov[2] {
                let w = wi * wj * wk;
                let b = (bi * blocks[1] + bj) * blocks[2] + bk;
                sum[b] += w * values[(i * ny + j) * nz + k];
                vol[b] += w;
            }
        }
    }
    Ok(sum.iter().zip(&vol).map(|(s, v)| s / v).collect())
}
