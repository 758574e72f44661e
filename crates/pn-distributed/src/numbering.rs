//! The distributed numbering of one class of unknowns (the kept or the eliminated moments):
//! process 0's unknowns first, then process 1's, …; within a process in ascending storage
//! index (moment by moment, x slowest, [`pn_runtime::Layout`]). Every process
//! computes any unknown's owner and number from the layout and the partition alone, so
//! building the ghost lists needs no communication.

use crate::partition::Decomposition;
use pn_runtime::Layout;

/// The numbering of the unknowns of the moments `in_class` (see the module documentation).
#[derive(Clone, Debug)]
pub struct Numbering {
    in_class: Vec<bool>,
    /// First number of each process, then the total.
    rank_start: Vec<usize>,
    /// Per process, the local start of each moment's box (unused for moments not in class).
    moment_start: Vec<Vec<usize>>,
    /// Per process and moment, the owned positions per axis (start and length).
    boxes: Vec<Vec<[(usize, usize); 3]>>,
}

impl Numbering {
    /// The numbering of the moments with `in_class[q]` on `layout` split by `dec`.
    pub fn new(layout: &Layout, dec: &Decomposition, in_class: Vec<bool>) -> Self {
        let nm = layout.moments.len();
        let mut rank_start = vec![0];
        let mut moment_start = Vec::with_capacity(dec.ranks());
        let mut boxes = Vec::with_capacity(dec.ranks());
        for r in 0..dec.ranks() {
            let mut at = 0;
            let mut starts = vec![0; nm];
            let mut bx = Vec::with_capacity(nm);
            for q in 0..nm {
                let p = dec.positions(r, layout.extents[q]);
                let b: [(usize, usize); 3] = std::array::from_fn(|d| (p[d].start, p[d].len()));
                starts[q] = at;
                if in_class[q] {
                    at += b.iter().map(|v| v.1).product::<usize>();
                }
                bx.push(b);
            }
            rank_start.push(rank_start[r] + at);
            moment_start.push(starts);
            boxes.push(bx);
        }
        Self {
            in_class,
            rank_start,
            moment_start,
            boxes,
        }
    }

    /// Unknowns of the class on all processes.
    pub fn total(&self) -> usize {
        self.rank_start[self.rank_start.len() - 1]
    }

    /// Unknowns of the class on `rank`.
    pub fn local_len(&self, rank: usize) -> usize {
        self.rank_start[rank + 1] - self.rank_start[rank]
    }

    /// The first number of `rank`.
    pub fn rank_start(&self, rank: usize) -> usize {
        self.rank_start[rank]
    }

    /// Whether moment `q` is in the class.
    pub fn contains_moment(&self, q: usize) -> bool {
        self.in_class[q]
    }

    /// The local number on `rank` of position `idx` of moment `q` (which `rank` owns).
    pub fn local(&self, rank: usize, q: usize, idx: [usize; 3]) -> usize {
        let b = &self.boxes[rank][q];
        let rel: [usize; 3] = std::array::from_fn(|d| idx[d] - b[d].0);
        self.moment_start[rank][q] + (rel[0] * b[1].1 + rel[1]) * b[2].1 + rel[2]
    }

    /// The owner and the global number of storage index `g` (`None` when its moment is not
    /// in the class).
    pub fn global(&self, layout: &Layout, dec: &Decomposition, g: usize) -> Option<(usize, usize)> {
        let (q, idx) = layout.locate(g);
        if !self.in_class[q] {
            return None;
        }
        let r = dec.owner(idx);
        Some((r, self.rank_start[r] + self.local(r, q, idx)))
    }

    /// The storage indices `rank` owns, in its local order (ascending).
    pub fn owned(&self, layout: &Layout, rank: usize) -> Vec<usize> {
        let mut out = Vec::with_capacity(self.local_len(rank));
        for (q, b) in self.boxes[rank].iter().enumerate() {
            if !self.in_class[q] {
                continue;
            }
            for i in b[0].0..b[0].0 + b[0].1 {
                for j in b[1].0..b[1].0 + b[1].1 {
                    let first = layout.index(q, [i, j, b[2].0]);
                    out.extend(first..first + b[2].1);
                }
            }
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use pn_runtime::problem::Grid;
    use pn_stencil::Dim;

    #[test]
    fn numbers_are_a_bijection_in_rank_order() {
        let choice =
            pn_kernels::pn_kernel(3, Dim::Three, pn_stencil::Staggering::Staggered).unwrap();
        let grid = Grid {
            dim: Dim::Three,
            min: [0.0; 3],
            max: [1.0; 3],
            res: [7, 6, 5],
        };
        let layout = Layout::new(&grid, choice.kernel.moments()).unwrap();
        let dec = Decomposition::new([7, 6, 5], [3, 2, 1]).unwrap();
        let in_class: Vec<bool> = layout.moments.iter().map(|m| m.l % 2 == 0).collect();
        let num = Numbering::new(&layout, &dec, in_class);
        let mut seen = vec![false; num.total()];
        for r in 0..dec.ranks() {
            let owned = num.owned(&layout, r);
            assert_eq!(owned.len(), num.local_len(r));
            assert!(owned.windows(2).all(|w| w[0] < w[1]));
            for (k, &g) in owned.iter().enumerate() {
                let (owner, n) = num.global(&layout, &dec, g).unwrap();
                assert_eq!((owner, n), (r, num.rank_start(r) + k));
                assert!(!seen[n]);
                seen[n] = true;
            }
        }
        assert!(seen.iter().all(|&s| s));
    }
}
