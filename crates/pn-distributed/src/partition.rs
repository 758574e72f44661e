//! The box partition: the cells split into `px × py × pz` boxes, one per process, and which
//! process owns each staggered position.
//!
//! Along an axis with `n` cells and `p` boxes, box `b` owns the cells
//! `cuts[b] .. cuts[b + 1]` (`cuts[b] = ⌊b·n / p⌋`, sizes differing by at most one). A moment
//! with `n + 1` face positions along the axis (docs/design.md §3) has its position `i` on the
//! lower face of cell `i`; it belongs to that cell's box, and the extra position `n` on the
//! upper domain face to the last box. Processes are numbered with x slowest, as the
//! unknowns are (`rank = (bx·py + by)·pz + bz`).

use std::ops::Range;

/// Fewest cells a box may have along a split axis: the reduced operator `S = D_e − B D_o⁻¹ C`
/// couples positions up to two apart (one step of `C`, one of `B`), so a thinner box would
/// need ghost values from beyond its neighbours.
pub const MIN_CELLS_PER_BOX: usize = 2;

/// Why a grid cannot be split as asked.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum PartitionError {
    /// No processes, or none along an axis.
    #[error("a partition needs at least one process along every axis, got {procs:?}")]
    NoProcesses {
        /// Processes per axis.
        procs: [usize; 3],
    },
    /// More processes along an axis than the grid allows.
    #[error(
        "{procs} processes along {axis} but the grid has {cells} cells there: each process's box \
         needs at least {MIN_CELLS_PER_BOX} cells along a split axis (its ghost layer), so at most \
         {max} processes along {axis}"
    )]
    TooManyProcesses {
        /// The axis name (x, y, z).
        axis: &'static str,
        /// Processes asked for along it.
        procs: usize,
        /// Cells along it.
        cells: usize,
        /// The most processes the axis allows.
        max: usize,
    },
    /// A 2D grid split along z.
    #[error("a 2D grid cannot be split along z (got {procs} processes there)")]
    SplitFlatAxis {
        /// Processes asked for along z.
        procs: usize,
    },
    /// No split of the process count fits the grid.
    #[error(
        "{ranks} processes cannot split a {res:?} grid: every box needs at least \
         {MIN_CELLS_PER_BOX} cells along each split axis (at most {max} processes here)"
    )]
    NoFit {
        /// Processes.
        ranks: usize,
        /// Cells per axis.
        res: [usize; 3],
        /// The most processes the grid allows.
        max: usize,
    },
}

const AXES: [&str; 3] = ["x", "y", "z"];

/// The cells split into boxes, one per process (see the module documentation).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Decomposition {
    res: [usize; 3],
    procs: [usize; 3],
    cuts: [Vec<usize>; 3],
}

impl Decomposition {
    /// `procs[d]` boxes along each axis of a grid of `res` cells (`res[2] = 1`, `procs[2] = 1`
    /// for 2D).
    pub fn new(res: [usize; 3], procs: [usize; 3]) -> Result<Self, PartitionError> {
        if procs.contains(&0) {
            return Err(PartitionError::NoProcesses { procs });
        }
        if res[2] == 1 && procs[2] > 1 {
            return Err(PartitionError::SplitFlatAxis { procs: procs[2] });
        }
        for d in 0..3 {
            if procs[d] > 1 && res[d] < MIN_CELLS_PER_BOX * procs[d] {
                return Err(PartitionError::TooManyProcesses {
                    axis: AXES[d],
                    procs: procs[d],
                    cells: res[d],
                    max: (res[d] / MIN_CELLS_PER_BOX).max(1),
                });
            }
        }
        let cuts = std::array::from_fn(|d| (0..=procs[d]).map(|b| b * res[d] / procs[d]).collect());
        Ok(Self { res, procs, cuts })
    }

    /// The split of `ranks` processes over `res` with the smallest total box surface (the
    /// halo traffic), among those whose boxes are thick enough; ties go to the split with
    /// more processes along x.
    pub fn balanced(res: [usize; 3], ranks: usize) -> Result<Self, PartitionError> {
        let max_along = |d: usize| {
            if d == 2 && res[2] == 1 {
                1
            } else {
                (res[d] / MIN_CELLS_PER_BOX).max(1)
            }
        };
        let mut best: Option<([usize; 3], f64)> = None;
        for px in (1..=ranks).rev().filter(|p| ranks.is_multiple_of(*p)) {
            for py in (1..=ranks / px)
                .rev()
                .filter(|p| (ranks / px).is_multiple_of(*p))
            {
                let procs = [px, py, ranks / px / py];
                if (0..3).any(|d| procs[d] > max_along(d)) {
                    continue;
                }
                let size: [f64; 3] = std::array::from_fn(|d| res[d] as f64 / procs[d] as f64);
                let surface = size[0] * size[1] + size[1] * size[2] + size[0] * size[2];
                if best.is_none_or(|(_, s)| surface < s - 1e-9) {
                    best = Some((procs, surface));
                }
            }
        }
        match best {
            Some((procs, _)) => Self::new(res, procs),
            None => Err(PartitionError::NoFit {
                ranks,
                res,
                max: (0..3).map(max_along).product(),
            }),
        }
    }

    /// The partition of the grid coarsened by two along every axis with more than one cell
    /// (multigrid's next level: cell or position `i` becomes `⌊i/2⌋`): the cuts halved and
    /// rounded up, so that a box may own nothing on a coarse level.
    pub fn coarsened(&self) -> Self {
        let halve = |d: usize, v: usize| if self.res[d] > 1 { v.div_ceil(2) } else { v };
        Self {
            res: std::array::from_fn(|d| halve(d, self.res[d])),
            procs: self.procs,
            cuts: std::array::from_fn(|d| self.cuts[d].iter().map(|&c| halve(d, c)).collect()),
        }
    }

    /// Cells per axis.
    pub fn res(&self) -> [usize; 3] {
        self.res
    }

    /// Boxes per axis.
    pub fn procs(&self) -> [usize; 3] {
        self.procs
    }

    /// Number of boxes (processes).
    pub fn ranks(&self) -> usize {
        self.procs.iter().product()
    }

    /// The box coordinates of `rank`.
    pub fn coords(&self, rank: usize) -> [usize; 3] {
        let [_, py, pz] = self.procs;
        [rank / (py * pz), (rank / pz) % py, rank % pz]
    }

    /// The cells of `rank`'s box per axis.
    pub fn cells(&self, rank: usize) -> [Range<usize>; 3] {
        let c = self.coords(rank);
        std::array::from_fn(|d| self.cuts[d][c[d]]..self.cuts[d][c[d] + 1])
    }

    /// The positions `rank` owns per axis of a moment with `ext` positions per axis (`n` or
    /// `n + 1`; empty ranges for a box that owns no cells on a coarse level).
    pub fn positions(&self, rank: usize, ext: [usize; 3]) -> [Range<usize>; 3] {
        let c = self.coords(rank);
        std::array::from_fn(|d| {
            let (lo, hi) = (self.cuts[d][c[d]], self.cuts[d][c[d] + 1]);
            // The box with the last cell also owns the positions past it (the upper face).
            if hi == self.res[d] && lo < hi {
                lo..ext[d]
            } else {
                lo..hi
            }
        })
    }

    /// The box index along axis `d` that owns position `i` (see the module documentation).
    fn box_along(&self, d: usize, i: usize) -> usize {
        let cell = i.min(self.res[d] - 1);
        // The last box starting at or before `cell` (on coarse levels boxes may be empty:
        // equal cuts; the non-empty one after them owns the position).
        (self.cuts[d].partition_point(|&c| c <= cell) - 1).min(self.procs[d] - 1)
    }

    /// The process that owns position `idx` of any moment.
    pub fn owner(&self, idx: [usize; 3]) -> usize {
        let b: [usize; 3] = std::array::from_fn(|d| self.box_along(d, idx[d]));
        (b[0] * self.procs[1] + b[1]) * self.procs[2] + b[2]
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn boxes_cover_every_position_once() {
        let dec = Decomposition::new([7, 5, 9], [3, 1, 2]).unwrap();
        for ext in [[7, 5, 9], [8, 5, 9], [7, 6, 10]] {
            let mut seen = vec![0u8; ext.iter().product()];
            for r in 0..dec.ranks() {
                let [x, y, z] = dec.positions(r, ext);
                for i in x.clone() {
                    for j in y.clone() {
                        for k in z.clone() {
                            assert_eq!(dec.owner([i, j, k]), r);
                            seen[(i * ext[1] + j) * ext[2] + k] += 1;
                        }
                    }
                }
            }
            assert!(seen.iter().all(|&s| s == 1), "{ext:?}");
        }
    }

    #[test]
    fn coarse_levels_cover_every_position_once() {
        let mut dec = Decomposition::new([9, 12, 1], [4, 3, 1]).unwrap();
        for _ in 0..4 {
            dec = dec.coarsened();
            let r = dec.res();
            for ext in [r, [r[0] + 1, r[1], 1]] {
                let mut seen = vec![0u8; ext.iter().product()];
                for rank in 0..dec.ranks() {
                    let [x, y, z] = dec.positions(rank, ext);
                    for i in x.clone() {
                        for j in y.clone() {
                            for k in z.clone() {
                                assert_eq!(dec.owner([i, j, k]), rank);
                                seen[(i * ext[1] + j) * ext[2] + k] += 1;
                            }
                        }
                    }
                }
                assert!(seen.iter().all(|&s| s == 1), "{r:?} {ext:?}");
            }
        }
        assert_eq!(dec.res(), [1, 1, 1]);
    }

    #[test]
    fn refuses_thin_boxes_with_the_limit() {
        let e = Decomposition::new([7, 8, 8], [4, 1, 1]).unwrap_err();
        assert!(e.to_string().contains("at most 3 processes along x"), "{e}");
        assert!(Decomposition::new([8, 8, 1], [1, 1, 2]).is_err());
        assert!(Decomposition::new([8, 8, 8], [0, 1, 1]).is_err());
        let e = Decomposition::balanced([3, 3, 3], 2).unwrap_err();
        assert!(e.to_string().contains("at most 1 processes"), "{e}");
    }

    #[test]
    fn balanced_prefers_cubes() {
        assert_eq!(
            Decomposition::balanced([32, 32, 32], 8).unwrap().procs(),
            [2, 2, 2]
        );
        assert_eq!(
            Decomposition::balanced([64, 16, 16], 4).unwrap().procs(),
            [4, 1, 1]
        );
        assert_eq!(
            Decomposition::balanced([32, 32, 1], 4).unwrap().procs(),
            [2, 2, 1]
        );
        assert_eq!(
            Decomposition::balanced([37, 37, 37], 3).unwrap().procs(),
            [3, 1, 1]
        );
    }
}
