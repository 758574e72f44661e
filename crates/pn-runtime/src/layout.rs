//! Unknown layout: which positions each moment occupies and the global index map.
//!
//! A moment with `shift[d] == 0` has `n_d` centred positions along axis d, one with
//! `shift[d] == 1` has `n_d + 1` face positions (both domain faces; the extra one on the
//! max side is the "extra boundary unknown" of docs/design.md §3). Unknowns are stored moment
//! by moment; within a moment, x is the slowest axis: `offset[q] + (ix·ny + iy)·nz + iz`.

use crate::problem::{Boundary, BoundaryKind, Grid};
use pn_stencil::{Dim, HalfOffset, MomentPlacement};

/// Per-moment extents and offsets into the global unknown vector.
#[derive(Clone, Debug, PartialEq)]
pub struct Layout {
    /// Placement of each moment (copied from the kernel).
    pub moments: Vec<MomentPlacement>,
    /// Positions per axis for each moment.
    pub extents: Vec<[usize; 3]>,
    /// First global index of each moment; `offsets[moments.len()]` is the total.
    pub offsets: Vec<usize>,
}

impl Layout {
    /// Builds the layout of `moments` on `grid`.
    pub fn new(grid: &Grid, moments: &[MomentPlacement]) -> anyhow::Result<Self> {
        let mut extents = Vec::with_capacity(moments.len());
        let mut total = 0usize;
        let mut offsets = vec![total];
        for mp in moments {
            anyhow::ensure!(
                mp.shift.iter().all(|&s| s <= 1),
                "moment ({},{}) has a shift > 1",
                mp.l,
                mp.m
            );
            if grid.dim == Dim::Two {
                anyhow::ensure!(
                    mp.shift[2] == 0,
                    "2D moment ({},{}) is shifted in z",
                    mp.l,
                    mp.m
                );
            }
            let e: [usize; 3] = std::array::from_fn(|d| grid.res[d] + mp.shift[d] as usize);
            let n: usize = e.iter().product();
            total += n;
            offsets.push(total);
            extents.push(e);
        }
        Ok(Self {
            moments: moments.to_vec(),
            extents,
            offsets,
        })
    }

    /// Total number of unknowns.
    pub fn len(&self) -> usize {
        // `offsets` starts with 0 and ends with the total (see `new`).
        self.offsets.last().copied().unwrap_or(0)
    }

    /// Whether there are no unknowns.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Global index of moment `q` at position index `idx`.
    pub fn index(&self, q: usize, idx: [usize; 3]) -> usize {
        let e = self.extents[q];
        self.offsets[q] + (idx[0] * e[1] + idx[1]) * e[2] + idx[2]
    }

    /// The moment and position index of global index `g`.
    pub fn locate(&self, g: usize) -> (usize, [usize; 3]) {
        let q = self.offsets.partition_point(|&o| o <= g) - 1;
        let e = self.extents[q];
        let r = g - self.offsets[q];
        (q, [r / (e[1] * e[2]), (r / e[2]) % e[1], r % e[2]])
    }

    /// The moments and positions of the global indices `g, g + 1, …` in turn, as
    /// [`Layout::locate`] gives them, each found from the previous one by a step instead of
    /// a search and three divisions (the assembly walks its rows in order).
    pub fn positions_from(&self, g: usize) -> Positions<'_> {
        let (q, idx) = if g < self.len() {
            self.locate(g)
        } else {
            (self.moments.len(), [0; 3])
        };
        Positions {
            layout: self,
            q,
            idx,
        }
    }

    /// Absolute half-cell coordinate of position `idx` of moment `q`
    /// (`2i+1` for a centre, `2s` for a face).
    pub fn half_coord(&self, q: usize, idx: [usize; 3]) -> [i64; 3] {
        let s = self.moments[q].shift;
        let mut h = [0i64; 3];
        for d in 0..3 {
            h[d] = if s[d] == 1 {
                2 * idx[d] as i64
            } else {
                2 * idx[d] as i64 + 1
            };
        }
        h
    }

    /// The storage index of moment `q` at absolute half-coordinate `half`, closed by the
    /// boundary condition: `None` when Dirichlet drops the reference.
    ///
    /// Neumann (extrapolation) clamps each axis index to the moment's range, i.e. the same
    /// moment at the nearest inside position (docs/design.md §3); each face uses its own
    /// kind. A Marshak face is never reached by a reference: the rows that would reach
    /// across it (those of the face unknowns) are replaced by the Marshak conditions
    /// ([`crate::marshak`]); should one reach it anyway it is dropped, as under Dirichlet.
    pub fn resolve(&self, q: usize, half: [i64; 3], bc: Boundary) -> Option<usize> {
        let s = self.moments[q].shift;
        let e = self.extents[q];
        let mut idx = [0usize; 3];
        for d in 0..3 {
            // Face s sits at 2s, centre i at 2i+1; parity was checked by `check_parity`.
            let raw = if s[d] == 1 {
                half[d].div_euclid(2)
            } else {
                (half[d] - 1).div_euclid(2)
            };
            let max = e[d] as i64 - 1;
            if raw < 0 || raw > max {
                match bc.face(d, usize::from(raw > max)) {
                    BoundaryKind::Neumann => idx[d] = raw.clamp(0, max) as usize,
                    BoundaryKind::Dirichlet | BoundaryKind::Marshak => return None,
                }
            } else {
                idx[d] = raw as usize;
            }
        }
        Some(self.index(q, idx))
    }

    /// Checks that `offset` from a row of moment `row` lands on positions of moment `q`
    /// (matching parity on every axis).
    pub fn check_parity(&self, row: usize, q: usize, offset: HalfOffset) -> anyhow::Result<()> {
        for d in 0..3 {
            // Absolute parity: a centred position is odd (2i+1), a face even (2s).
            let reached = ((1 - self.moments[row].shift[d] as i32) + offset[d]).rem_euclid(2);
            let want = 1 - self.moments[q].shift[d] as i32;
            anyhow::ensure!(
                reached == want,
                "stencil row {row} references moment {q} at offset {offset:?}, which is not one of its grid positions (axis {d})"
            );
        }
        Ok(())
    }
}

/// Iterator of [`Layout::positions_from`].
pub struct Positions<'a> {
    layout: &'a Layout,
    q: usize,
    idx: [usize; 3],
}

impl Iterator for Positions<'_> {
    type Item = (usize, [usize; 3]);

    fn next(&mut self) -> Option<Self::Item> {
        let ext = &self.layout.extents;
        if self.q >= ext.len() {
            return None;
        }
        let here = (self.q, self.idx);
        let e = ext[self.q];
        // z fastest, then y, then x, then the next non-empty moment.
        self.idx[2] += 1;
        if self.idx[2] == e[2] {
            self.idx[2] = 0;
            self.idx[1] += 1;
            if self.idx[1] == e[1] {
                self.idx[1] = 0;
                self.idx[0] += 1;
                if self.idx[0] == e[0] {
                    self.idx[0] = 0;
                    self.q += 1;
                    while self.q < ext.len() && ext[self.q].iter().product::<usize>() == 0 {
                        self.q += 1;
                    }
                }
            }
        }
        Some(here)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn mp(shift: [u8; 3]) -> MomentPlacement {
        MomentPlacement { l: 0, m: 0, shift }
    }

    fn grid() -> Grid {
        Grid {
            dim: Dim::Three,
            min: [0.0; 3],
            max: [1.0; 3],
            res: [3, 4, 2],
        }
    }

    #[test]
    fn extents_and_round_trip() {
        let l = Layout::new(&grid(), &[mp([0, 0, 0]), mp([1, 0, 1])]).unwrap();
        assert_eq!(l.extents, vec![[3, 4, 2], [4, 4, 3]]);
        assert_eq!(l.len(), 24 + 48);
        for g in 0..l.len() {
            let (q, idx) = l.locate(g);
            assert_eq!(l.index(q, idx), g);
        }
        // Stepping through the positions gives what locate gives, from any start.
        for start in [0, 1, 23, 24, 50, l.len() - 1, l.len()] {
            let walked: Vec<_> = l.positions_from(start).collect();
            let located: Vec<_> = (start..l.len()).map(|g| l.locate(g)).collect();
            assert_eq!(walked, located, "from {start}");
        }
    }

    #[test]
    fn boundary_closure() {
        let l = Layout::new(&grid(), &[mp([0, 0, 0]), mp([1, 0, 0])]).unwrap();
        // Centre −1 along x (half −1) clamps to centre 0 under Neumann, dropped under Dirichlet.
        assert_eq!(
            l.resolve(0, [-1, 1, 1], Boundary::Neumann),
            Some(l.index(0, [0, 0, 0]))
        );
        assert_eq!(l.resolve(0, [-1, 1, 1], Boundary::Dirichlet), None);
        // Face 3 (half 6) is inside for the shifted moment.
        assert_eq!(
            l.resolve(1, [6, 1, 1], Boundary::Dirichlet),
            Some(l.index(1, [3, 0, 0]))
        );
        // Centre 3 (half 7) is outside for a centred moment with n = 3.
        assert_eq!(
            l.resolve(0, [7, 1, 1], Boundary::Neumann),
            Some(l.index(0, [2, 0, 0]))
        );
        // Per face: reflecting at x min, dropped at x max.
        let bc: Boundary = "xmax=dirichlet".parse().unwrap();
        assert_eq!(l.resolve(0, [-1, 1, 1], bc), Some(l.index(0, [0, 0, 0])));
        assert_eq!(l.resolve(0, [7, 1, 1], bc), None);
        assert!(l.check_parity(1, 0, [1, 0, 0]).is_ok());
        assert!(l.check_parity(1, 0, [2, 0, 0]).is_err());
    }
}
