//! A coarse level's operator stored as **per-class stencils with per-row weights**: no
//! column indices.
//!
//! The aggregated levels keep the structure of the finest one: every unknown is a class
//! (moment) at a position of that class's box, numbered class by class, x slowest
//! ([`super::aggregate`]), and a row couples to a fixed set of (class, position shift) pairs
//! — the Galerkin product of a stencil with piecewise-constant aggregation is again a
//! stencil, only its weights vary from row to row (with the medium, and at the
//! boundaries). [`StencilLevel::from_csr`] recovers, for each class, the set of shifts its
//! rows reach (the *terms*), and stores one `f32` weight per row and term, zero where a row
//! lacks the term (at the boundaries). A product then reads 4 bytes per stored weight
//! instead of the compact CSR's 8 per entry (4 for the `f32` value, 4 for the column), and
//! reads the source vector plane by plane in order instead of gathering it.
//!
//! The first level of the parity systems is built straight in this form
//! ([`StencilLevel::from_parts`], from
//! [`crate::solver::parity::stencil_s::StencilReduced::coarse_parts`]), without its CSR;
//! [`StencilLevel::galerkin`] then forms the next level's CSR from the stored weights.
//!
//! Levels whose unknowns are not whole class boxes in that order, whose rows reach further
//! than [`REACH`] positions, or whose boundary rows would pad the weights by more than
//! [`MAX_PADDING`] are left to the compact CSR ([`StencilLevel::from_csr`] returns `None`).

use super::Geometry;
use crate::matfree::{for_planes_across, range, shifted_lines};
use rayon::prelude::*;
use sprs::CsMat;
use std::sync::atomic::{AtomicBool, Ordering};

/// Largest shift per axis between a row's position and a column's (in positions of the
/// level's grids). Aggregation by two of a stencil reaching two positions reaches one or
/// two; three leaves room for the staggered grids' half-cell offsets.
pub const REACH: i64 = 3;

/// Values per parallel task when weights are rounded to `f32`.
const CONVERT_CHUNK: usize = 1 << 14;

/// Width of the shift table per axis.
const SPAN: usize = (2 * REACH + 1) as usize;

/// Largest ratio of stored weights (terms × rows, the boundary rows' zeros included) to
/// the level's non-zeros: above it the compact CSR moves fewer bytes.
pub const MAX_PADDING: f64 = 1.8;

/// One term of a class's stencil: the source class (its block) and the position shift.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
struct LevelTerm {
    block: usize,
    delta: [i64; 3],
}

/// The rows of one class: a whole box of positions, x slowest.
#[derive(Clone, Debug)]
struct ClassBlock {
    /// First unknown of the class.
    start: usize,
    /// Extent of the class's box.
    ext: [usize; 3],
    /// The shifts the class's rows reach.
    terms: Vec<LevelTerm>,
    /// Weights x-plane by x-plane, term by term within a plane: the weight of term `k` in
    /// row `i` of plane `ix` is at `(ix · terms + k) · plane + i`.
    weights: Vec<f32>,
}

impl ClassBlock {
    fn plane(&self) -> usize {
        (self.ext[1] * self.ext[2]).max(1)
    }

    fn len(&self) -> usize {
        self.ext.iter().product()
    }

    /// Sets to zero the weights whose reference lies outside its source box (`ext`: the
    /// boxes of all blocks), so that [`StencilLevel::galerkin_level`] may sum weights
    /// without testing each reference and a product may run over a whole plane of lines
    /// without cutting them at the box's ends. [`StencilLevel::for_row`] and the CSR
    /// Galerkin product skip such references in any case, so the operator is unchanged.
    /// Every level holds no other (the tests check it for each way a level is built).
    fn zero_outside(&mut self, ext: &[[usize; 3]]) {
        let (e, plane, kn) = (self.ext, self.plane(), self.terms.len());
        for (k, t) in self.terms.iter().enumerate() {
            let ep = ext[t.block];
            let [dx, dy, dz] = t.delta;
            let (xs, ys, zs) = (
                range(e[0], ep[0], dx),
                range(e[1], ep[1], dy),
                range(e[2], ep[2], dz),
            );
            for ix in 0..e[0] {
                let wk = &mut self.weights[(ix * kn + k) * plane..(ix * kn + k + 1) * plane];
                if !xs.contains(&ix) {
                    wk.fill(0.0);
                    continue;
                }
                for iy in 0..e[1] {
                    let line = &mut wk[iy * e[2]..(iy + 1) * e[2]];
                    if ys.contains(&iy) {
                        line[..zs.start].fill(0.0);
                        line[zs.end.max(zs.start)..].fill(0.0);
                    } else {
                        line.fill(0.0);
                    }
                }
            }
        }
    }
}

/// A square operator on a structured level as per-class stencils with per-row `f32`
/// weights (see the module documentation).
#[derive(Debug)]
pub struct StencilLevel {
    blocks: Vec<ClassBlock>,
    n: usize,
}

impl StencilLevel {
    /// The operator `a` (square CSR, sorted or not) of the unknowns `g`; `None` when the
    /// level is not structured (see the module documentation) or an entry does not fit
    /// `f32` (overflowing, or non-zero and flushed to zero).
    pub fn from_csr(a: &CsMat<f64>, g: &Geometry) -> Option<Self> {
        let n = a.rows();
        if !a.is_csr() || a.cols() != n || g.len() != n || n == 0 {
            return None;
        }
        let (starts, ext, block_of_class) = class_blocks(g)?;
        let shape = Shape {
            g,
            block_of_class,
            starts,
            ext,
        };
        // The terms of each class: the shifts of its middle row, then those of any row
        // that reaches further (rare: the boundary rows usually reach less), after which
        // the weights are filled again.
        let mut terms: Vec<Vec<LevelTerm>> = (0..shape.starts.len())
            .map(|q| {
                let e = shape.ext[q];
                let r = shape.starts[q] + linear(e, e.map(|v| v / 2));
                let row = a.outer_view(r)?;
                row.indices().iter().map(|&c| shape.term(r, c)).collect()
            })
            .collect::<Option<_>>()?;
        let weights = match shape.fill(a, &terms) {
            Fill::Done(w) => w,
            Fill::Unfit => return None,
            Fill::Missing => {
                for (q, t) in shape.missing_terms(a, &terms)? {
                    terms[q].push(t);
                }
                match shape.fill(a, &terms) {
                    Fill::Done(w) => w,
                    _ => return None,
                }
            }
        };
        let stored: usize = weights.iter().map(Vec::len).sum();
        if stored as f64 > MAX_PADDING * a.nnz().max(1) as f64 {
            return None;
        }
        let blocks = weights
            .into_iter()
            .zip(terms)
            .enumerate()
            .map(|(q, (weights, terms))| ClassBlock {
                start: shape.starts[q],
                ext: shape.ext[q],
                terms,
                weights,
            })
            .collect();
        // Weights whose reference leaves its box are zero: no column there.
        Some(Self { blocks, n })
    }

    /// The level of `blocks`, their weights whose reference leaves its source box set to
    /// zero ([`ClassBlock::zero_outside`]): for weights given from outside
    /// ([`StencilLevel::from_parts`]); [`StencilLevel::from_csr`] and
    /// [`StencilLevel::galerkin_level`] produce no such weights.
    fn masked(mut blocks: Vec<ClassBlock>, n: usize) -> Self {
        let ext: Vec<[usize; 3]> = blocks.iter().map(|b| b.ext).collect();
        blocks.par_iter_mut().for_each(|b| b.zero_outside(&ext));
        Self { blocks, n }
    }

    /// Rows (and columns).
    pub fn len(&self) -> usize {
        self.n
    }

    /// Whether the operator has no rows.
    pub fn is_empty(&self) -> bool {
        self.n == 0
    }

    /// Stored weights (terms × rows per class, the boundary rows' zeros included).
    pub fn stored(&self) -> usize {
        self.blocks.iter().map(|b| b.weights.len()).sum()
    }

    /// Modelled bytes of one product: the weights (4 bytes each), `x` read and `y` written
    /// once (8 bytes each).
    pub fn bytes_per_product(&self) -> u64 {
        (4 * self.stored() + 16 * self.n) as u64
    }

    /// `y = A x`, accumulated in `f64`.
    pub fn apply(&self, x: &[f64], y: &mut [f64]) {
        assert_eq!(x.len(), self.n);
        assert_eq!(y.len(), self.n);
        // Plane by plane across the classes: the source planes a plane reads stay in cache
        // for the other classes' planes at the same x.
        let boxes = self
            .blocks
            .iter()
            .enumerate()
            .map(|(q, b)| (q, b.len(), b.plane()));
        for_planes_across(y, boxes, |q, ix, _, out| self.slab(q, ix, x, out));
    }

    /// Plane `ix` of class `q`: `out = Σ_terms w_row · x[shifted]` over the references
    /// inside the source class's box.
    fn slab(&self, q: usize, ix: usize, x: &[f64], out: &mut [f64]) {
        let b = &self.blocks[q];
        let (e, plane, kn) = (b.ext, b.plane(), b.terms.len());
        let w = &b.weights[ix * kn * plane..(ix + 1) * kn * plane];
        out.fill(0.0);
        for (k, t) in b.terms.iter().enumerate() {
            let wk = &w[k * plane..(k + 1) * plane];
            let src = &self.blocks[t.block];
            let ep = src.ext;
            let [dx, dy, dz] = t.delta;
            let ixr = ix as i64 + dx;
            if ixr < 0 || ixr >= ep[0] as i64 {
                continue;
            }
            let src_plane = src.start + ixr as usize * ep[1] * ep[2];
            let ys = range(e[1], ep[1], dy);
            if ys.is_empty() {
                continue;
            }
            if ep[2] == e[2] {
                // Lines of equal length: the y-lines are one contiguous run from the first
                // in-box reference to the last. The rows in between whose reference leaves
                // the box along z (at the ends of the lines) have zero weights (the level's
                // invariant, see `ClassBlock::zero_outside`) and read a source value inside
                // the source plane, so they add nothing.
                let zs = range(e[2], ep[2], dz);
                if zs.is_empty() {
                    continue;
                }
                let lo = ys.start * e[2] + zs.start;
                let hi = (ys.end - 1) * e[2] + zs.end;
                let first = (src_plane as i64
                    + (ys.start as i64 + dy) * e[2] as i64
                    + zs.start as i64
                    + dz) as usize;
                let xs = &x[first..first + (hi - lo)];
                out[lo..hi]
                    .iter_mut()
                    .zip(&wk[lo..hi])
                    .zip(xs)
                    .for_each(|((o, &w), &x)| *o += w as f64 * x);
                continue;
            }
            for (at, first) in shifted_lines(e, ep, src_plane, dy, dz) {
                let xs = &x[first..first + at.len()];
                out[at.clone()]
                    .iter_mut()
                    .zip(&wk[at])
                    .zip(xs)
                    .for_each(|((o, &w), &x)| *o += w as f64 * x);
            }
        }
    }
}

/// One class of a level given directly as stencil weights in `f64` (for
/// [`StencilLevel::from_parts`]): its first unknown, box, terms (source class's block and
/// shift) and weights laid out as [`StencilLevel`] stores them (x-plane by x-plane, term by
/// term within a plane).
pub struct ClassParts {
    /// First unknown of the class.
    pub start: usize,
    /// Extent of the class's box.
    pub ext: [usize; 3],
    /// Source block (index into the parts) and position shift of each term.
    pub terms: Vec<(usize, [i64; 3])>,
    /// Weight of term `k` in row `i` of plane `ix` at `(ix · terms + k) · plane + i`.
    pub weights: Vec<f64>,
}

impl ClassParts {
    fn plane(&self) -> usize {
        (self.ext[1] * self.ext[2]).max(1)
    }
}

/// Relative asymmetry of the level given by `parts`, as `csr_asymmetry` in the parent module
/// measures it on a CSR matrix: `|a_ij − a_ji| / (max_k |a_ik| + max_k |a_jk|)` of some
/// entry where it exceeds `tol`, or 0 when every entry is within `tol`.
pub fn parts_asymmetry(parts: &[ClassParts], tol: f64) -> f64 {
    // Row scales (largest |weight|), per class in row order, plane by plane: each term's
    // weights of a plane are contiguous.
    let scale: Vec<Vec<f64>> = parts
        .iter()
        .map(|c| {
            let (plane, kn) = (c.plane(), c.terms.len());
            let mut s = vec![0.0f64; c.ext.iter().product::<usize>()];
            s.par_chunks_mut(plane).enumerate().for_each(|(ix, out)| {
                for k in 0..kn {
                    let wk = &c.weights[(ix * kn + k) * plane..(ix * kn + k + 1) * plane];
                    out.iter_mut()
                        .zip(wk)
                        .for_each(|(m, &w)| *m = m.max(w.abs()));
                }
            });
            s
        })
        .collect();
    // The transposed term of each term: (block, index in the block's terms).
    let back: Vec<Vec<Option<usize>>> = parts
        .iter()
        .enumerate()
        .map(|(q, c)| {
            c.terms
                .iter()
                .map(|&(b, d)| parts[b].terms.iter().position(|&t| t == (q, d.map(|v| -v))))
                .collect()
        })
        .collect();
    parts
        .iter()
        .enumerate()
        .find_map(|(q, c)| {
            let (plane, kn, e) = (c.plane(), c.terms.len(), c.ext);
            (0..e.iter().product::<usize>())
                .into_par_iter()
                .find_map_any(|r| {
                    let (ix, i) = (r / plane, r % plane);
                    let pos = [ix as i64, (i / e[2]) as i64, (i % e[2]) as i64];
                    (0..kn).find_map(|k| {
                        let w = c.weights[(ix * kn + k) * plane + i];
                        if w == 0.0 {
                            return None;
                        }
                        let (b, d) = c.terms[k];
                        let src = &parts[b];
                        let j = [0, 1, 2].map(|a| pos[a] + d[a]);
                        if (0..3).any(|a| j[a] < 0 || j[a] >= src.ext[a] as i64) {
                            return Some(f64::INFINITY); // an entry outside the level
                        }
                        let j = j.map(|v| v as usize);
                        let (jp, jl) = (j[0], j[1] * src.ext[2] + j[2]);
                        let jr = jp * src.plane() + jl;
                        let t = back[q][k].map_or(0.0, |kb| {
                            src.weights[(jp * src.terms.len() + kb) * src.plane() + jl]
                        });
                        let s = scale[q][r] + scale[b][jr];
                        let dlt = (w - t).abs();
                        (dlt > tol * s).then(|| dlt / s)
                    })
                })
        })
        .unwrap_or(0.0)
}

impl StencilLevel {
    /// The level given by `parts` (see [`ClassParts`]), its weights rounded to `f32`; `None`
    /// when a term reaches further than [`REACH`] or a weight does not fit `f32`.
    pub fn from_parts(parts: Vec<ClassParts>) -> Option<Self> {
        let n = parts.iter().map(|c| c.ext.iter().product::<usize>()).sum();
        let blocks = parts
            .into_iter()
            .map(|c| {
                if c.terms.iter().any(|t| t.1.iter().any(|v| v.abs() > REACH)) {
                    return None;
                }
                // Into a buffer of known length (an indexed pass: collecting into an
                // `Option<Vec<_>>` in parallel goes through per-task lists).
                let mut weights = vec![0.0f32; c.weights.len()];
                let fits = AtomicBool::new(true);
                weights
                    .par_chunks_mut(CONVERT_CHUNK)
                    .zip(c.weights.par_chunks(CONVERT_CHUNK))
                    .for_each(|(out, from)| {
                        for (o, &v) in out.iter_mut().zip(from) {
                            let w = v as f32;
                            if !(w.is_finite() && (w != 0.0 || v == 0.0)) {
                                fits.store(false, Ordering::Relaxed);
                            }
                            *o = w;
                        }
                    });
                if !fits.into_inner() {
                    return None;
                }
                Some(ClassBlock {
                    start: c.start,
                    ext: c.ext,
                    terms: c
                        .terms
                        .iter()
                        .map(|&(block, delta)| LevelTerm { block, delta })
                        .collect(),
                    weights,
                })
            })
            .collect::<Option<Vec<_>>>()?;
        Some(Self::masked(blocks, n))
    }

    /// Non-zero weights.
    pub fn nonzeros(&self) -> usize {
        self.blocks
            .iter()
            .map(|b| b.weights.par_iter().filter(|&&w| w != 0.0).count())
            .sum()
    }

    /// Calls `f(column, weight)` for the non-zero weights of row `r`.
    fn for_row(&self, r: usize, mut f: impl FnMut(usize, f64)) {
        let q = self.blocks.partition_point(|b| b.start <= r) - 1;
        let b = &self.blocks[q];
        let (plane, kn, e) = (b.plane(), b.terms.len(), b.ext);
        let l = r - b.start;
        let (ix, i) = (l / plane, l % plane);
        let pos = [ix as i64, (i / e[2]) as i64, (i % e[2]) as i64];
        for (k, t) in b.terms.iter().enumerate() {
            let w = b.weights[(ix * kn + k) * plane + i];
            if w == 0.0 {
                continue;
            }
            let src = &self.blocks[t.block];
            let j = [0, 1, 2].map(|a| pos[a] + t.delta[a]);
            if (0..3).all(|a| j[a] >= 0 && j[a] < src.ext[a] as i64) {
                f(src.start + linear(src.ext, j.map(|v| v as usize)), w as f64);
            }
        }
    }

    /// The diagonal: the weights of each class's term on its own class at shift zero (the
    /// only term that can reach a row's own column), zero where a class has none.
    pub fn diagonal(&self) -> Vec<f64> {
        let mut d = vec![0.0; self.n];
        for (q, b) in self.blocks.iter().enumerate() {
            let mine = &mut d[b.start..b.start + b.len()];
            let (plane, kn) = (b.plane(), b.terms.len());
            let own = b
                .terms
                .iter()
                .position(|t| t.block == q && t.delta == [0; 3]);
            if let Some(k) = own {
                mine.par_chunks_mut(plane)
                    .enumerate()
                    .for_each(|(ix, out)| {
                        let w = &b.weights[(ix * kn + k) * plane..(ix * kn + k + 1) * plane];
                        out.iter_mut().zip(w).for_each(|(o, &w)| *o = w as f64);
                    });
            }
        }
        d
    }

    /// The Galerkin operator `Pᵀ A P` of the aggregation `ag` of this level's unknowns.
    pub fn galerkin(&self, ag: &super::aggregate::Aggregation) -> CsMat<f64> {
        super::galerkin::build_rows(ag.coarse_len(), ag.coarse_len(), |ci, acc| {
            for &r in &ag.members[ag.ptr[ci]..ag.ptr[ci + 1]] {
                self.for_row(r as usize, |c, w| acc.add(ag.agg[c], w));
            }
        })
    }

    /// The Galerkin operator `Pᵀ A P` of the aggregation `ag` as a stencil level, computed
    /// from the stored weights without forming its CSR; `None` where `ag` is not the
    /// halving of this level's class boxes ([`super::aggregate::aggregate`]'s rule) or the
    /// result is not a stencil level ([`StencilLevel::from_csr`]'s conditions: padding,
    /// `f32` range).
    ///
    /// With aggregation by two, a row at fine position `2I + π` (`π ∈ {0, 1}` per halved
    /// axis) reaching shift `d` reaches the coarse shift `⌊(π + d)/2⌋` from `I`,
    /// whatever `I`: every (fine term, `π`) pair adds one fine weight plane to one coarse
    /// term's plane. The pairs are added members first (`π` in the members' order), terms
    /// second, into `f64` sums from zero — the order in which [`StencilLevel::galerkin`]
    /// accumulates each entry, so the sums are the same; the coarse terms are ordered as
    /// [`StencilLevel::from_csr`] orders them (by source block, then shift), those whose
    /// weights all vanish dropped. 80³ P_5 point source, level 1 → 2: CSR product and
    /// conversion 0.27 + 0.05 s.
    pub fn galerkin_level(&self, ag: &super::aggregate::Aggregation) -> Option<Self> {
        let (starts, cext, _) = class_blocks(&ag.coarse)?;
        if starts.len() != self.blocks.len() {
            return None;
        }
        let halve: [bool; 3] = std::array::from_fn(|d| self.blocks.iter().any(|b| b.ext[d] > 1));
        let coarse_of = |v: [usize; 3]| -> [usize; 3] {
            std::array::from_fn(|d| if halve[d] { v[d] / 2 } else { v[d] })
        };
        // The aggregation must be the halving, class block by class block.
        for (q, b) in self.blocks.iter().enumerate() {
            let last = coarse_of(b.ext.map(|v| v.max(1) - 1)).map(|v| v + 1);
            if cext[q] != last {
                return None;
            }
            let plane = b.plane();
            let ok = (0..b.len()).into_par_iter().all(|l| {
                let pos = [l / plane, (l % plane) / b.ext[2], l % b.ext[2]];
                ag.agg[b.start + l] as usize == starts[q] + linear(cext[q], coarse_of(pos))
            });
            if !ok {
                return None;
            }
        }
        // Member offsets in the members' order (fine index ascending: x, then y, then z).
        let offsets: Vec<[usize; 3]> = (0..8usize)
            .map(|m| [m >> 2 & 1, m >> 1 & 1, m & 1])
            .filter(|o| (0..3).all(|d| halve[d] || o[d] == 0))
            .collect();
        let mut blocks = Vec::with_capacity(self.blocks.len());
        let mut nonzeros = 0usize;
        for (q, b) in self.blocks.iter().enumerate() {
            let (e, ce) = (b.ext, cext[q]);
            let (plane, cplane, kn) = (b.plane(), (ce[1] * ce[2]).max(1), b.terms.len());
            // Coarse term of each (member offset, fine term).
            let shift = |o: &[usize; 3], t: &LevelTerm| LevelTerm {
                block: t.block,
                delta: std::array::from_fn(|d| {
                    if halve[d] {
                        (o[d] as i64 + t.delta[d]).div_euclid(2)
                    } else {
                        t.delta[d]
                    }
                }),
            };
            let mut terms: Vec<LevelTerm> = offsets
                .iter()
                .flat_map(|o| b.terms.iter().map(move |t| shift(o, t)))
                .collect();
            terms.sort_unstable();
            terms.dedup();
            let map: Vec<Vec<usize>> = offsets
                .iter()
                .map(|o| {
                    b.terms
                        .iter()
                        .map(|t| terms.binary_search(&shift(o, t)).unwrap_or(usize::MAX))
                        .collect()
                })
                .collect();
            let ckn = terms.len();
            let mut sums = vec![0.0f64; ckn * cplane * ce[0]];
            sums.par_chunks_mut((ckn * cplane).max(1))
                .enumerate()
                .for_each(|(cx, out)| {
                    for (o, to) in offsets.iter().zip(&map) {
                        let ix = if halve[0] { 2 * cx + o[0] } else { cx };
                        if ix >= e[0] {
                            continue;
                        }
                        for (k, &ck) in to.iter().enumerate() {
                            let wk = &b.weights[(ix * kn + k) * plane..(ix * kn + k + 1) * plane];
                            let ok = &mut out[ck * cplane..(ck + 1) * cplane];
                            for cy in 0..ce[1] {
                                let iy = if halve[1] { 2 * cy + o[1] } else { cy };
                                if iy >= e[1] {
                                    continue;
                                }
                                let (src, dst) = (
                                    &wk[iy * e[2]..(iy + 1) * e[2]],
                                    &mut ok[cy * ce[2]..(cy + 1) * ce[2]],
                                );
                                if halve[2] {
                                    dst.iter_mut()
                                        .zip(src.iter().skip(o[2]).step_by(2))
                                        .for_each(|(s, &w)| *s += w as f64);
                                } else {
                                    dst.iter_mut().zip(src).for_each(|(s, &w)| *s += w as f64);
                                }
                            }
                        }
                    }
                });
            // Drop the terms whose weights all vanish; round to f32 as from_csr does.
            let keep: Vec<bool> = (0..ckn)
                .map(|ck| {
                    (0..ce[0]).any(|cx| {
                        let at = (cx * ckn + ck) * cplane;
                        sums[at..at + cplane].iter().any(|&v| v != 0.0)
                    })
                })
                .collect();
            let kept: Vec<usize> = (0..ckn).filter(|&ck| keep[ck]).collect();
            let mut weights = Vec::with_capacity(kept.len() * cplane * ce[0]);
            for cx in 0..ce[0] {
                for &ck in &kept {
                    let at = (cx * ckn + ck) * cplane;
                    for &v in &sums[at..at + cplane] {
                        let w = v as f32;
                        if !w.is_finite() || (w == 0.0 && v != 0.0) {
                            return None;
                        }
                        nonzeros += (v != 0.0) as usize;
                        weights.push(w);
                    }
                }
            }
            blocks.push(ClassBlock {
                start: starts[q],
                ext: ce,
                terms: kept.iter().map(|&ck| terms[ck]).collect(),
                weights,
            });
        }
        let stored: usize = blocks.iter().map(|b| b.weights.len()).sum();
        if stored as f64 > MAX_PADDING * nonzeros.max(1) as f64 {
            return None;
        }
        // Each coarse weight sums fine weights whose references lie in their boxes, so
        // the coarse references lie in theirs: nothing to zero.
        Some(Self {
            blocks,
            n: ag.coarse_len(),
        })
    }

    /// The operator as a CSR matrix (its `f32` weights).
    pub fn to_csr(&self) -> CsMat<f64> {
        super::galerkin::build_rows(self.n, self.n, |r, acc| {
            self.for_row(r, |c, w| acc.add(c as u32, w));
        })
    }
}

/// The classes of a level as boxes ([`class_blocks`]), for reading its CSR rows as terms.
struct Shape<'a> {
    g: &'a Geometry,
    block_of_class: Vec<usize>,
    starts: Vec<usize>,
    ext: Vec<[usize; 3]>,
}

/// What [`Shape::fill`] found.
enum Fill {
    /// The weights of every class.
    Done(Vec<Vec<f32>>),
    /// Some row reaches a shift missing from its class's terms.
    Missing,
    /// Some entry does not fit `f32`, or a shift exceeds [`REACH`].
    Unfit,
}

impl Shape<'_> {
    fn block(&self, i: usize) -> usize {
        self.block_of_class[self.g.class[i] as usize]
    }

    /// The term of entry `(r, c)`, or `None` beyond [`REACH`].
    #[inline]
    fn term(&self, r: usize, c: usize) -> Option<LevelTerm> {
        let (pr, pc) = (self.g.coords[r], self.g.coords[c]);
        let delta = [0, 1, 2].map(|k| pc[k] as i64 - pr[k] as i64);
        delta.iter().all(|v| v.abs() <= REACH).then(|| LevelTerm {
            block: self.block(c),
            delta,
        })
    }

    /// Each class's index of its terms (`None` for a shift beyond [`REACH`]).
    fn tables(&self, terms: &[Vec<LevelTerm>]) -> Option<Vec<TermIndex>> {
        let nb = self.starts.len();
        terms
            .iter()
            .map(|ts| TermIndex::new(nb, ts.iter().map(|t| (t.block, t.delta))))
            .collect()
    }

    /// The weights of `a`'s rows on the classes' `terms`, x-plane by x-plane.
    fn fill(&self, a: &CsMat<f64>, terms: &[Vec<LevelTerm>]) -> Fill {
        let Some(tables) = self.tables(terms) else {
            return Fill::Unfit;
        };
        let (missing, unfit) = (AtomicBool::new(false), AtomicBool::new(false));
        let (ap, ai, av) = (a.indptr(), a.indices(), a.data());
        let ap = ap.raw_storage();
        let weights = (0..self.starts.len())
            .map(|q| {
                let e = self.ext[q];
                let plane = (e[1] * e[2]).max(1);
                let kn = terms[q].len();
                let mut w = vec![0.0f32; kn * e.iter().product::<usize>()];
                w.par_chunks_mut((kn * plane).max(1))
                    .enumerate()
                    .for_each(|(ix, w)| {
                        for i in 0..plane {
                            let r = self.starts[q] + ix * plane + i;
                            for p in ap[r]..ap[r + 1] {
                                let Some(t) = self.term(r, ai[p]) else {
                                    unfit.store(true, Ordering::Relaxed);
                                    return;
                                };
                                let Some(k) = tables[q].get(t.block, t.delta) else {
                                    missing.store(true, Ordering::Relaxed);
                                    return;
                                };
                                let v = av[p] as f32;
                                if !v.is_finite() || (v == 0.0 && av[p] != 0.0) {
                                    unfit.store(true, Ordering::Relaxed);
                                }
                                w[k * plane + i] += v;
                            }
                        }
                    });
                w
            })
            .collect();
        if unfit.into_inner() {
            Fill::Unfit
        } else if missing.into_inner() {
            Fill::Missing
        } else {
            Fill::Done(weights)
        }
    }

    /// The `(class, term)` pairs some row of `a` reaches beyond its class's `terms`.
    fn missing_terms(
        &self,
        a: &CsMat<f64>,
        terms: &[Vec<LevelTerm>],
    ) -> Option<Vec<(usize, LevelTerm)>> {
        let tables = self.tables(terms)?;
        let (ap, ai) = (a.indptr(), a.indices());
        let ap = ap.raw_storage();
        (0..a.rows())
            .into_par_iter()
            .with_min_len(4096)
            .map(|r| {
                let q = self.block(r);
                let mut out = Vec::new();
                for &c in &ai[ap[r]..ap[r + 1]] {
                    let t = self.term(r, c)?;
                    if tables[q].get(t.block, t.delta).is_none() {
                        out.push((q, t));
                    }
                }
                Some(out)
            })
            .try_reduce(Vec::new, |mut a, b| {
                a.extend(b);
                a.sort_unstable();
                a.dedup();
                Some(a)
            })
    }
}

/// The index of each term of a stencil in its list, by (source block or class, shift), for
/// shifts of at most [`REACH`] per axis: a dense table, no hashing (it is read once per
/// stored entry).
pub(crate) struct TermIndex {
    table: Vec<u32>,
}

impl TermIndex {
    /// The index of `terms` (`(block, shift)` in list order) over `blocks` blocks; `None`
    /// when a shift exceeds [`REACH`] or a block is out of range.
    pub(crate) fn new(
        blocks: usize,
        terms: impl IntoIterator<Item = (usize, [i64; 3])>,
    ) -> Option<Self> {
        let mut table = vec![u32::MAX; blocks * SPAN * SPAN * SPAN];
        for (k, (b, d)) in terms.into_iter().enumerate() {
            *table.get_mut(Self::slot(b, d)?)? = k as u32;
        }
        Some(Self { table })
    }

    /// The index of the term `(block, shift)`, if the stencil has it.
    #[inline]
    pub(crate) fn get(&self, block: usize, delta: [i64; 3]) -> Option<usize> {
        let k = *self.table.get(Self::slot(block, delta)?)?;
        (k != u32::MAX).then_some(k as usize)
    }

    #[inline]
    fn slot(block: usize, delta: [i64; 3]) -> Option<usize> {
        delta.iter().all(|v| v.abs() <= REACH).then(|| {
            let [x, y, z] = delta.map(|v| (v + REACH) as usize);
            ((block * SPAN + x) * SPAN + y) * SPAN + z
        })
    }
}

/// Position `idx` of a box `e`, x slowest.
fn linear(e: [usize; 3], idx: [usize; 3]) -> usize {
    (idx[0] * e[1] + idx[1]) * e[2] + idx[2]
}

/// The classes of `g` as whole boxes numbered x slowest, one class after the other: each
/// block's first unknown and extent, and the block of each class (`usize::MAX` for classes
/// absent). `None` when a class is split, a box is incomplete or out of order.
#[allow(clippy::type_complexity)]
fn class_blocks(g: &Geometry) -> Option<(Vec<usize>, Vec<[usize; 3]>, Vec<usize>)> {
    let classes = g.class.iter().max().map_or(0, |&c| c as usize + 1);
    let mut block_of_class = vec![usize::MAX; classes];
    let (mut starts, mut ext) = (Vec::new(), Vec::<[usize; 3]>::new());
    for (i, (&c, x)) in g.class.iter().zip(&g.coords).enumerate() {
        if i == 0 || g.class[i - 1] != c {
            if block_of_class[c as usize] != usize::MAX {
                return None;
            }
            block_of_class[c as usize] = starts.len();
            starts.push(i);
            ext.push([0; 3]);
        }
        let e = ext.last_mut()?;
        for d in 0..3 {
            e[d] = e[d].max(x[d] as usize + 1);
        }
    }
    let ends: Vec<usize> = starts.iter().skip(1).copied().chain([g.len()]).collect();
    for (q, &s) in starts.iter().enumerate() {
        if ends[q] - s != ext[q].iter().product::<usize>() {
            return None;
        }
    }
    let ordered = (0..starts.len()).all(|q| {
        (starts[q]..ends[q])
            .into_par_iter()
            .all(|i| i - starts[q] == linear(ext[q], g.coords[i].map(|v| v as usize)))
    });
    ordered.then_some((starts, ext, block_of_class))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::solver::multigrid::aggregate::aggregate;
    use sprs::TriMat;

    /// Two classes on staggered boxes (5×4×3 and 4×4×3): class 0 with a 7-point Laplacian,
    /// both coupled to each other at shifts 0 and −1 in x, with random row-varying weights;
    /// the product equals the CSR one to `f32` rounding of the weights, and the aggregated
    /// geometry of the level is accepted too.
    #[test]
    fn stencil_level_equals_the_csr_product() {
        let boxes = [[5usize, 4, 3], [4, 4, 3]];
        let g = boxes_geometry(&boxes);
        let start = [0, boxes[0].iter().product::<usize>()];
        let n = g.len();
        let idx = |c: usize, p: [i64; 3]| -> Option<usize> {
            let e = boxes[c];
            (0..3)
                .all(|d| p[d] >= 0 && (p[d] as usize) < e[d])
                .then(|| start[c] + linear(e, p.map(|v| v as usize)))
        };
        let mut t = TriMat::new((n, n));
        let mut seed = 1u64;
        let mut rnd = || {
            seed = seed
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            ((seed >> 33) as f64 / (1u64 << 31) as f64) - 0.5
        };
        for r in 0..n {
            let (c, p) = (g.class[r] as usize, g.coords[r].map(|v| v as i64));
            t.add_triplet(r, r, 6.0 + rnd());
            let mut shifts = vec![];
            if c == 0 {
                for d in 0..3 {
                    for s in [-1, 1] {
                        let mut q = [0; 3];
                        q[d] = s;
                        shifts.push((0, q));
                    }
                }
            }
            shifts.push((1 - c, [0, 0, 0]));
            shifts.push((1 - c, [if c == 0 { -1 } else { 1 }, 0, 0]));
            for (cc, s) in shifts {
                if let Some(col) = idx(cc, [0, 1, 2].map(|d| p[d] + s[d])) {
                    t.add_triplet(r, col, rnd());
                }
            }
        }
        let a: CsMat<f64> = t.to_csr();
        let s = StencilLevel::from_csr(&a, &g).expect("structured");
        assert!(s.stored() >= a.nnz());
        assert!(zero_outside_already(&s));
        let x: Vec<f64> = (0..n).map(|i| (i as f64 * 0.37).sin()).collect();
        let mut want = vec![0.0; n];
        pn_krylov::linalg::spmv(&a, &x, &mut want);
        let mut got = vec![f64::NAN; n];
        s.apply(&x, &mut got);
        let scale = want.iter().fold(0.0f64, |m, v| m.max(v.abs()));
        for (w, v) in want.iter().zip(&got) {
            assert!((w - v).abs() <= 1e-6 * scale, "{w} vs {v}");
        }
        // The diagonal is the f32-rounded matrix diagonal.
        let diag = s.diagonal();
        for (r, &d) in diag.iter().enumerate() {
            let want = a.get(r, r).copied().unwrap_or(0.0) as f32;
            assert_eq!(d, want as f64, "row {r}");
        }
        // The aggregated geometry is structured as well.
        let agg = aggregate(&g);
        assert!(class_blocks(&agg.coarse).is_some());
        // A permuted geometry is refused.
        let mut h = g.clone();
        h.coords.swap(0, 1);
        assert!(StencilLevel::from_csr(&a, &h).is_none());
    }

    /// Shifts of the random 3D levels: along one, two and three axes, reaching two.
    const SHIFTS_3D: [[i64; 3]; 6] = [
        [0, 0, 0],
        [1, 0, -1],
        [0, -1, 1],
        [-1, 1, 0],
        [0, 2, -1],
        [0, 0, 2],
    ];

    /// Whether every weight of `level` whose reference leaves its box is zero already.
    fn zero_outside_already(level: &StencilLevel) -> bool {
        let ext: Vec<[usize; 3]> = level.blocks.iter().map(|b| b.ext).collect();
        level.blocks.iter().all(|b| {
            let mut masked = b.clone();
            masked.zero_outside(&ext);
            masked.weights == b.weights
        })
    }

    /// Unknowns of `boxes` numbered class by class, x slowest.
    fn boxes_geometry(boxes: &[[usize; 3]]) -> Geometry {
        let mut g = Geometry {
            class: Vec::new(),
            coords: Vec::new(),
        };
        for (c, e) in boxes.iter().enumerate() {
            for i in 0..e[0] {
                for j in 0..e[1] {
                    for k in 0..e[2] {
                        g.class.push(c as u32);
                        g.coords.push([i as u32, j as u32, k as u32]);
                    }
                }
            }
        }
        g
    }

    /// Parts on `boxes` (numbered as [`boxes_geometry`]) with every class reaching every
    /// class at `shifts`, all weights non-zero (also where the reference leaves its box).
    fn random_parts(boxes: &[[usize; 3]], shifts: &[[i64; 3]], seed: u64) -> Vec<ClassParts> {
        let mut seed = seed;
        let mut rnd = || {
            seed = seed
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            0.25 + ((seed >> 33) as f64 / (1u64 << 31) as f64)
        };
        let terms: Vec<(usize, [i64; 3])> = (0..boxes.len())
            .flat_map(|b| shifts.iter().map(move |&d| (b, d)))
            .collect();
        let mut start = 0;
        boxes
            .iter()
            .map(|&ext| {
                let len = ext.iter().product::<usize>();
                let part = ClassParts {
                    start,
                    ext,
                    terms: terms.clone(),
                    weights: (0..terms.len() * len).map(|_| rnd()).collect(),
                };
                start += len;
                part
            })
            .collect()
    }

    /// The Galerkin product formed straight as a stencil level equals the CSR product of
    /// the same level (rounded to `f32` as a stencil level stores it), in 3D with odd and
    /// even box extents and in 2D (z not halved), and its diagonal the CSR's.
    #[test]
    fn galerkin_level_equals_the_csr_galerkin_product() {
        let shifts_2d = [[0, 0, 0], [1, 0, 0], [0, -1, 0], [-1, 1, 0], [2, -2, 0]];
        for (boxes, shifts) in [
            (
                vec![[11usize, 10, 9], [10, 11, 9], [9, 9, 10]],
                &SHIFTS_3D[..],
            ),
            (vec![[15usize, 14, 1], [14, 15, 1]], &shifts_2d[..]),
        ] {
            let g = boxes_geometry(&boxes);
            let level = StencilLevel::from_parts(random_parts(&boxes, shifts, 3)).unwrap();
            let ag = aggregate(&g);
            let want = level.galerkin(&ag);
            let coarse = level.galerkin_level(&ag).expect("a stencil level");
            assert!(zero_outside_already(&coarse));
            let got = coarse.to_csr();
            assert_eq!(got.rows(), want.rows());
            for (r, row) in want.outer_iterator().enumerate() {
                for (c, &v) in row.iter() {
                    let w = got.get(r, c).copied().unwrap_or(0.0);
                    assert_eq!(w, v as f32 as f64, "entry ({r}, {c})");
                }
            }
            assert_eq!(got.nnz(), want.iter().filter(|(&v, _)| v != 0.0).count());
            let diag = coarse.diagonal();
            for (r, &d) in diag.iter().enumerate() {
                assert_eq!(d, want.get(r, r).copied().unwrap_or(0.0) as f32 as f64);
            }
            // An aggregation that is not the halving is refused.
            let mut other = ag.clone();
            other.agg.swap(0, ag.agg.len() - 1);
            assert!(level.galerkin_level(&other).is_none());
        }
    }

    /// A level from parts whose weights are non-zero everywhere, also where the reference
    /// leaves the source box (along x, y or z; between boxes of equal and of different
    /// extents): the product equals the row-by-row sum over the in-box references — no
    /// weight whose reference leaves its box contributes (a product reading a plane as one
    /// line would wrap such a reference to the neighbouring line), and none is dropped.
    #[test]
    fn product_from_parts_skips_every_reference_outside_its_box() {
        let boxes = [[4usize, 5, 3], [4, 5, 3], [3, 4, 3]];
        let n: usize = boxes.iter().map(|e| e.iter().product::<usize>()).sum();
        let parts = random_parts(&boxes, &SHIFTS_3D, 7);
        let starts: Vec<usize> = parts.iter().map(|p| p.start).collect();
        let x: Vec<f64> = (0..n).map(|i| (i as f64 * 0.37).sin()).collect();
        let mut want = vec![0.0; n];
        for (c, part) in parts.iter().enumerate() {
            let e = part.ext;
            let plane = e[1] * e[2];
            for r in 0..e.iter().product::<usize>() {
                let (ix, i) = (r / plane, r % plane);
                let pos = [ix as i64, (i / e[2]) as i64, (i % e[2]) as i64];
                for (k, &(b, d)) in part.terms.iter().enumerate() {
                    let ep = boxes[b];
                    let j = [0, 1, 2].map(|a| pos[a] + d[a]);
                    if (0..3).all(|a| j[a] >= 0 && j[a] < ep[a] as i64) {
                        let w = part.weights[(ix * part.terms.len() + k) * plane + i] as f32;
                        want[starts[c] + r] +=
                            w as f64 * x[starts[b] + linear(ep, j.map(|v| v as usize))];
                    }
                }
            }
        }
        let level = StencilLevel::from_parts(parts).expect("in reach");
        let mut got = vec![f64::NAN; n];
        level.apply(&x, &mut got);
        for (w, v) in want.iter().zip(&got) {
            assert!((w - v).abs() <= 1e-12 * w.abs().max(1.0), "{w} vs {v}");
        }
    }
}
