//! Un-staggering: every moment moved to the cell centres.
//!
//! A moment shifted along axis d lives on faces s and s+1 on either side of centre s; its
//! centre value is the average of the two (of 4 for an edge-located moment, 8 for a
//! corner-located one).

use crate::layout::Layout;
use crate::problem::Grid;
use rayon::prelude::*;

/// All moments at cell centres.
#[derive(Clone, Debug, PartialEq)]
pub struct CellMoments {
    /// Cells per axis.
    pub res: [usize; 3],
    /// Moments per cell, `(lmax+1)²`, indexed by `l(l+1)+m`.
    pub per_cell: usize,
    /// `((i·ny + j)·nz + k)·per_cell + l(l+1)+m`; moments the stencil does not carry are 0.
    pub data: Vec<f64>,
}

impl CellMoments {
    /// Moment `l(l+1)+m` = `index` of cell (i, j, k).
    pub fn get(&self, i: usize, j: usize, k: usize, index: usize) -> f64 {
        self.data[((i * self.res[1] + j) * self.res[2] + k) * self.per_cell + index]
    }

    /// One moment over all cells, x slowest (C order of shape `(nx, ny, nz)`).
    pub fn component(&self, index: usize) -> Vec<f64> {
        self.data
            .iter()
            .skip(index)
            .step_by(self.per_cell)
            .copied()
            .collect()
    }

    /// The same moments with the bands up to `lmax` (new ones 0); itself when it already
    /// has them.
    pub fn padded_to(self, lmax: usize) -> Self {
        let per_cell = (lmax + 1) * (lmax + 1);
        if per_cell <= self.per_cell {
            return self;
        }
        let mut data = vec![0.0; self.data.len() / self.per_cell.max(1) * per_cell];
        for (to, from) in data
            .chunks_exact_mut(per_cell)
            .zip(self.data.chunks_exact(self.per_cell))
        {
            to[..self.per_cell].copy_from_slice(from);
        }
        Self {
            res: self.res,
            per_cell,
            data,
        }
    }
}

/// Moves every moment of `u` to the cell centres of `grid`.
pub fn unstagger(grid: &Grid, layout: &Layout, u: &[f64]) -> CellMoments {
    let lmax = layout.moments.iter().map(|m| m.l).max().unwrap_or(0) as usize;
    let per_cell = (lmax + 1) * (lmax + 1);
    let res = grid.res;
    let cells = grid.cells();
    let mut data = vec![0.0; cells * per_cell];
    data.par_chunks_mut(per_cell)
        .enumerate()
        .for_each(|(c, out)| {
            let k = c % res[2];
            let j = (c / res[2]) % res[1];
            let i = c / (res[2] * res[1]);
            for (q, mp) in layout.moments.iter().enumerate() {
                let index = (mp.l * (mp.l + 1) + mp.m) as usize;
                let mut sum = 0.0;
                let mut count = 0usize;
                for corner in 0..8usize {
                    // Only corners along shifted axes; skip duplicates for centred axes.
                    if (0..3).any(|d| (corner >> d) & 1 == 1 && mp.shift[d] == 0) {
                        continue;
                    }
                    let idx = [
                        i + (corner & 1),
                        j + ((corner >> 1) & 1),
                        k + ((corner >> 2) & 1),
                    ];
                    sum += u[layout.index(q, idx)];
                    count += 1;
                }
                out[index] = sum / count as f64;
            }
        });
    CellMoments {
        res,
        per_cell,
        data,
    }
}

#[cfg(test)]
mod tests {
    #[test]
    fn padding_keeps_the_moments_and_adds_zero_bands() {
        let m = CellMoments {
            res: [2, 1, 1],
            per_cell: 4,
            data: (0..8).map(f64::from).collect(),
        };
        let p = m.clone().padded_to(2);
        assert_eq!(p.per_cell, 9);
        for c in 0..2 {
            assert_eq!(&p.data[c * 9..c * 9 + 4], &m.data[c * 4..c * 4 + 4]);
            assert!(p.data[c * 9 + 4..c * 9 + 9].iter().all(|&v| v == 0.0));
        }
        assert_eq!(m.clone().padded_to(1), m);
        assert_eq!(m.clone().padded_to(0), m);
    }

    use super::*;
    use pn_stencil::{Dim, MomentPlacement};

    #[test]
    fn averages_faces_and_corners() {
        let grid = Grid {
            dim: Dim::Two,
            min: [0.0; 3],
            max: [1.0; 3],
            res: [2, 1, 1],
        };
        let moments = vec![
            MomentPlacement {
                l: 0,
                m: 0,
                shift: [0, 0, 0],
            },
            MomentPlacement {
                l: 1,
                m: 1,
                shift: [1, 0, 0],
            },
            MomentPlacement {
                l: 2,
                m: -2,
                shift: [1, 1, 0],
            },
        ];
        let layout = Layout::new(&grid, &moments).unwrap();
        // centre: 2 values; x-faces: 3; corners: 3×2.
        let u = vec![1.0, 2.0, 10.0, 20.0, 40.0, 1.0, 3.0, 5.0, 7.0, 9.0, 11.0];
        let cm = unstagger(&grid, &layout, &u);
        assert_eq!(cm.per_cell, 9);
        assert_eq!(cm.get(0, 0, 0, 0), 1.0);
        assert_eq!(cm.get(1, 0, 0, 3), 30.0);
        // corner moment index 2·3−2 = 4; cell 1 uses corners (1,0),(1,1),(2,0),(2,1).
        assert_eq!(cm.get(1, 0, 0, 4), (5.0 + 7.0 + 9.0 + 11.0) / 4.0);
        assert_eq!(cm.get(0, 0, 0, 1), 0.0);
    }
}
