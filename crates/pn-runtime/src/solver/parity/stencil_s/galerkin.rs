//! The multigrid setup's products from the stencils: `diag(S)` and the first Galerkin
//! operator `Pᵀ S P` (issue 19: "Galerkin products from the matrix-free stencil").
//!
//! Both read the rows of `B` and of `C̃ = D_o⁻¹ C` as their moment's stencil restricted
//! to the grid plus the row's corrections ([`StencilBlock`]), never the blocks' stored
//! entries, and give the same values as the block routes
//! ([`crate::solver::parity::precond::diagonal`],
//! [`crate::solver::parity::galerkin::coarse_from_split`]) up to the order of the
//! additions (`crates/pn-runtime/tests/stencil_s.rs`).
//!
//! * `diag(S)_i = D_e,i − Σ_k B_ik C̃_ki`: for a row whose `B` row and the `C` entries that
//!   reference it are all stencil entries, the sum runs over the row's stencil terms with
//!   each term's matching `C` weight found once per moment; the few other rows (the
//!   corrections' rows and columns) sum over their actual entries.
//! * `Pᵀ S P = Pᵀ D_e P − (Pᵀ B)(C̃ P)`: a row whose aggregate is a block of its moment's
//!   grid takes its stencil part from a map fixed per moment and position class
//!   ([`CoarseMaps`], module `interior`: one multiply-add per coarse term and odd slot) and
//!   adds the few corrections' products; any other row (the general route) adds its
//!   members' `B` rows into a small dense window over the odd positions they can reach
//!   (instead of sorting them), then scatters each reached row of `C̃` to the aggregates of
//!   its columns. 80³ P_5 point source: 3.0 s by the general route, 1.36 s with the maps
//!   (0.4 s of it building the CSR); 40³: 0.35 → 0.17 s.

use super::interior::{CoarseMaps, LaneScratch, MapScratch, LANES};
use super::{Moments, StencilBlock, StencilReduced, Term};
use crate::matfree::shifted_lines;
use crate::solver::multigrid::aggregate::Aggregation;
use crate::solver::multigrid::galerkin::build_rows_with;
use crate::solver::multigrid::stencil_level::{ClassParts, TermIndex};
use crate::solver::parity::block_mat::BlockMat;
use rayon::prelude::*;
use sprs::CsMat;
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};

impl Moments {
    /// The moments of the class `kept`, in local order (for [`Moments::locate`]).
    fn class(&self, kept: bool) -> Vec<usize> {
        (0..self.ext.len())
            .filter(|&q| self.kept[q] == kept)
            .collect()
    }

    /// Moment and grid position of local row `r` of the class whose moments are `class`
    /// ([`Moments::class`]).
    #[inline]
    fn locate(&self, class: &[usize], r: usize) -> (usize, [i64; 3]) {
        let at = class.partition_point(|&q| self.local_off[q] <= r);
        let q = class[at.max(1) - 1];
        let e = self.ext[q];
        let l = r - self.local_off[q];
        let (yz, z) = (l / e[2], l % e[2]);
        (q, [(yz / e[1]) as i64, (yz % e[1]) as i64, z as i64])
    }

    /// Local index of moment `p` at `idx`, if `idx` lies in `p`'s grid.
    #[inline]
    fn index(&self, p: usize, idx: [i64; 3]) -> Option<usize> {
        let e = self.ext[p];
        (0..3)
            .all(|d| idx[d] >= 0 && idx[d] < e[d] as i64)
            .then(|| self.local_off[p] + self.linear(p, idx.map(|v| v as usize)))
    }
}

/// One term of a row moment's stencil with its column as `offset + x·sx + y·sy + z` of the
/// row's position (valid inside [`Interior`]'s box).
#[derive(Clone, Copy)]
struct FlatTerm {
    offset: i64,
    sx: i64,
    sy: i64,
    moment: usize,
    delta: [i64; 3],
    weight: f64,
}

/// A row moment's stencil for the positions where every term lies inside the grid.
struct Interior {
    lo: [i64; 3],
    hi: [i64; 3],
    terms: Vec<FlatTerm>,
}

/// The rows of one block: stencil terms and corrections, with a fast path for the rows
/// whose stencil lies inside the grid.
struct Rows<'a> {
    block: &'a StencilBlock,
    m: &'a Moments,
    interior: Vec<Interior>,
    /// Corrections of row `r`: `fix_ptr[r]..fix_ptr[r + 1]` (CSR style).
    fix_ptr: Vec<u32>,
}

impl<'a> Rows<'a> {
    /// The rows of `block`, which has `n_rows` rows.
    fn new(block: &'a StencilBlock, m: &'a Moments, n_rows: usize) -> Self {
        // `fix_ptr[r]`: the corrections of the rows before `r` (they are sorted by row),
        // stepped chunk by chunk in parallel from a search for each chunk's first row.
        const ROWS: usize = 8192;
        let fix_rows = &block.fix_rows;
        debug_assert!(fix_rows.windows(2).all(|w| w[0] <= w[1]));
        let mut fix_ptr = vec![0u32; n_rows + 1];
        fix_ptr
            .par_chunks_mut(ROWS)
            .enumerate()
            .for_each(|(c, out)| {
                let r0 = c * ROWS;
                let mut p = fix_rows.partition_point(|&x| (x as usize) < r0);
                for (r, o) in (r0..).zip(out) {
                    while p < fix_rows.len() && (fix_rows[p] as usize) < r {
                        p += 1;
                    }
                    *o = p as u32;
                }
            });
        let interior = block
            .terms
            .iter()
            .map(|terms| {
                let (mut lo, mut hi) = ([0i64; 3], [i64::MAX; 3]);
                let flat = terms
                    .iter()
                    .map(|t| {
                        let e = m.ext[t.moment].map(|v| v as i64);
                        for d in 0..3 {
                            lo[d] = lo[d].max(-t.delta[d]);
                            hi[d] = hi[d].min(e[d] - t.delta[d]);
                        }
                        let (sy, sx) = (e[2], e[1] * e[2]);
                        FlatTerm {
                            offset: m.local_off[t.moment] as i64
                                + t.delta[0] * sx
                                + t.delta[1] * sy
                                + t.delta[2],
                            sx,
                            sy,
                            moment: t.moment,
                            delta: t.delta,
                            weight: t.weight,
                        }
                    })
                    .collect();
                Interior {
                    lo,
                    hi,
                    terms: flat,
                }
            })
            .collect();
        Self {
            block,
            m,
            interior,
            fix_ptr,
        }
    }

    /// Calls `f(column, place, weight)` for every entry of local row `r` (moment `q` at
    /// `pos`): the stencil terms inside the grid with their column's moment and position as
    /// `place`, then the corrections with `place` `None` (a column may come twice).
    #[inline]
    fn for_row(
        &self,
        q: usize,
        pos: [i64; 3],
        r: usize,
        mut f: impl FnMut(usize, Option<(usize, [i64; 3])>, f64),
    ) {
        let inner = &self.interior[q];
        if (0..3).all(|d| pos[d] >= inner.lo[d] && pos[d] < inner.hi[d]) {
            for t in &inner.terms {
                let c = t.offset + pos[0] * t.sx + pos[1] * t.sy + pos[2];
                f(c as usize, Some((t.moment, add(pos, t.delta))), t.weight);
            }
        } else {
            for t in &self.block.terms[q] {
                let idx = add(pos, t.delta);
                if let Some(c) = self.m.index(t.moment, idx) {
                    f(c, Some((t.moment, idx)), t.weight);
                }
            }
        }
        for k in self.fix_ptr[r] as usize..self.fix_ptr[r + 1] as usize {
            f(
                self.block.fix_cols[k] as usize,
                None,
                self.block.fix_vals[k],
            );
        }
    }
}

#[inline]
fn add(a: [i64; 3], b: [i64; 3]) -> [i64; 3] {
    [a[0] + b[0], a[1] + b[1], a[2] + b[2]]
}

/// The weight of the term of moment `q` at shift `delta` in `terms`, 0 if none.
fn weight_of(terms: &[Term], q: usize, delta: [i64; 3]) -> f64 {
    terms
        .iter()
        .filter(|t| t.moment == q && t.delta == delta)
        .map(|t| t.weight)
        .sum()
}

impl StencilReduced {
    /// `diag(S)` (kept-local order), from the stencils.
    pub fn diagonal(&self, d_e: &[f64], d_o: &[f64]) -> Vec<f64> {
        let (n_e, n_o) = (d_e.len(), d_o.len());
        let m = &self.moments;
        let (b, c) = (&self.b, &self.c);
        let b_rows = Rows::new(b, m, n_e);
        let c_rows = Rows::new(c, m, n_o);
        // For each kept moment q and each of its B terms, the C weight back to q.
        let back: Vec<Vec<f64>> = (0..m.ext.len())
            .map(|q| {
                b.terms[q]
                    .iter()
                    .map(|t| weight_of(&c.terms[t.moment], q, t.delta.map(|v| -v)))
                    .collect()
            })
            .collect();
        // Rows whose sum is not the stencil's: a correction in their B row, or a C
        // correction in their column.
        let mut irregular = vec![false; n_e];
        for &r in &b.fix_rows {
            irregular[r as usize] = true;
        }
        for &col in &c.fix_cols {
            irregular[col as usize] = true;
        }
        // The regular rows plane by plane, as `S` is applied (`stencil_slab`): from `D_e`,
        // each term subtracts `(w_B w_C) / D_o` at its shifted positions, line by line — the
        // same operations in the same order as row by row, without locating each row and
        // each reference (80³ P_5 point source: 0.45 → 0.05 s).
        let mut diag = d_e.to_vec();
        super::for_slabs(m, true, &mut diag, |q, ix, _, out| {
            let e = m.ext[q];
            for (t, w) in b.terms[q].iter().zip(&back[q]) {
                let ep = m.ext[t.moment];
                let [dx, dy, dz] = t.delta;
                let ixr = ix as i64 + dx;
                if ixr < 0 || ixr >= ep[0] as i64 {
                    continue;
                }
                let plane = m.local_off[t.moment] + ixr as usize * ep[1] * ep[2];
                let tw = t.weight * w;
                for (at, first) in shifted_lines(e, ep, plane, dy, dz) {
                    let ds = &d_o[first..first + at.len()];
                    out[at].iter_mut().zip(ds).for_each(|(o, &d)| *o -= tw / d);
                }
            }
        });
        // The irregular rows over their actual entries.
        let (kept, elim) = (m.class(true), m.class(false));
        let rows: Vec<usize> = (0..n_e).filter(|&i| irregular[i]).collect();
        let sums: Vec<f64> = rows
            .par_iter()
            .with_min_len(1024)
            .map(|&i| {
                let (q, pos) = m.locate(&kept, i);
                let mut s = d_e[i];
                // `C̃_ki`: the stencil's weight back (`back`, or found for a correction's
                // column) plus the corrections of row `k` in column `i`.
                let c_back = |k: usize, stencil_weight: f64| {
                    let fixes = c_rows.fix_ptr[k] as usize..c_rows.fix_ptr[k + 1] as usize;
                    fixes
                        .filter(|&f| c.fix_cols[f] as usize == i)
                        .fold(stencil_weight, |cw, f| cw + c.fix_vals[f])
                };
                // The row's entries in `Rows::for_row`'s order: the stencil terms inside the
                // grid (each with its `C` weight back from `back`), then the corrections.
                for (t, &w) in b.terms[q].iter().zip(&back[q]) {
                    if let Some(k) = m.index(t.moment, add(pos, t.delta)) {
                        s -= t.weight * c_back(k, w) / d_o[k];
                    }
                }
                for f in b_rows.fix_ptr[i] as usize..b_rows.fix_ptr[i + 1] as usize {
                    let k = b.fix_cols[f] as usize;
                    let (r, pk) = m.locate(&elim, k);
                    let delta = [0, 1, 2].map(|d| pos[d] - pk[d]);
                    s -= b.fix_vals[f] * c_back(k, weight_of(&c.terms[r], q, delta)) / d_o[k];
                }
                s
            })
            .collect();
        for (&i, s) in rows.iter().zip(sums) {
            diag[i] = s;
        }
        diag
    }

    /// The first Galerkin operator `Pᵀ S P` of the aggregation `ag` of the kept unknowns
    /// (kept-local order), from the stencils.
    pub fn coarse(&self, d_e: &[f64], d_o: &[f64], ag: &Aggregation) -> CsMat<f64> {
        self.coarse_with(d_e, d_o, ag, true).0
    }

    /// [`StencilReduced::coarse`] with the rows' stencil part from the position maps
    /// ([`CoarseMaps`], where `use_maps` and the aggregation allow) or all rows by the
    /// general route, and the number of rows the maps computed.
    pub fn coarse_with(
        &self,
        d_e: &[f64],
        d_o: &[f64],
        ag: &Aggregation,
        use_maps: bool,
    ) -> (CsMat<f64>, usize) {
        let (n_e, n_o) = (d_e.len(), d_o.len());
        let m = &self.moments;
        let (b, c) = (&self.b, &self.c);
        let (b_rows, c_rows) = (Rows::new(b, m, n_e), Rows::new(c, m, n_o));
        let nm = m.ext.len();
        // The window: odd positions within the B terms' reach of a 2×2×2 aggregate.
        let (mut lo, mut hi) = ([0i64; 3], [0i64; 3]);
        for t in b.terms.iter().flatten() {
            for d in 0..3 {
                lo[d] = lo[d].min(t.delta[d]);
                hi[d] = hi[d].max(t.delta[d]);
            }
        }
        let w = [0, 1, 2].map(|d| (hi[d] - lo[d] + 2) as usize);
        let per_moment = w[0] * w[1] * w[2];
        let (kept, elim) = (m.class(true), m.class(false));
        let maps = if use_maps {
            CoarseMaps::new(m, b, c, n_o, ag.coarse_len())
        } else {
            None
        };
        let fixes = Fixes {
            m,
            b,
            c,
            b_rows: &b_rows,
            c_rows: &c_rows,
            elim: &elim,
            d_o,
        };
        let interior_rows = AtomicUsize::new(0);
        let scratch = || Window {
            sums: vec![0.0; nm * per_moment],
            touched: Vec::new(),
            spill: Vec::new(),
            maps: MapScratch::default(),
        };
        let a = build_rows_with(
            ag.coarse_len(),
            ag.coarse_len(),
            scratch,
            |row, acc, scr| {
                let Window {
                    sums: win,
                    touched,
                    spill,
                    maps: inner,
                } = scr;
                let members = &ag.members[ag.ptr[row]..ag.ptr[row + 1]];
                let (q, corner) = m.locate(&kept, members[0] as usize);
                if let Some((maps, prepared)) = maps
                    .as_ref()
                    .and_then(|mp| Some((mp, mp.prepare(m, d_o, q, corner, members, inner)?)))
                {
                    if inner.corrected.is_empty() && fixes.plain(members) {
                        // No corrections: the map's columns are sorted and distinct.
                        maps.emit(&prepared, d_e, inner, |j, v| acc.push_sorted(j, v));
                    } else {
                        maps.emit(&prepared, d_e, inner, |j, v| acc.add(j, v));
                        fixes.products(members, &inner.corrected, |j, v| acc.add(ag.agg[j], v));
                    }
                    interior_rows.fetch_add(1, Ordering::Relaxed);
                    return;
                }
                let base = add(corner, lo);
                for &i in members {
                    let i = i as usize;
                    acc.add(row as u32, d_e[i]);
                    let (_, pos) = m.locate(&kept, i);
                    b_rows.for_row(q, pos, i, |k, place, v| {
                        let (r, pk) = place.unwrap_or_else(|| m.locate(&elim, k));
                        let o = [0, 1, 2].map(|d| pk[d] - base[d]);
                        if (0..3).all(|d| o[d] >= 0 && (o[d] as usize) < w[d]) {
                            let s = r * per_moment
                                + (o[0] as usize * w[1] + o[1] as usize) * w[2]
                                + o[2] as usize;
                            if win[s] == 0.0 {
                                touched.push(s as u32);
                            }
                            win[s] += v;
                            // A sum that cancels to exactly 0 would be pushed again: harmless,
                            // the slot is read once and cleared below.
                        } else {
                            spill.push((k, v));
                        }
                    });
                }
                // Scatter the reached rows of C̃ = D_o⁻¹ C to the aggregates of their columns.
                let mut scatter = |k: usize, r: usize, pk: [i64; 3], v: f64| {
                    let f = -v / d_o[k];
                    c_rows.for_row(r, pk, k, |j, _, cw| acc.add(ag.agg[j], f * cw));
                };
                for &s in touched.iter() {
                    let s = s as usize;
                    let v = std::mem::take(&mut win[s]);
                    if v == 0.0 {
                        continue;
                    }
                    let r = s / per_moment;
                    let o = s % per_moment;
                    let pk = add(
                        base,
                        [
                            (o / (w[1] * w[2])) as i64,
                            ((o / w[2]) % w[1]) as i64,
                            (o % w[2]) as i64,
                        ],
                    );
                    let k = m.local_off[r] + m.linear(r, pk.map(|v| v as usize));
                    scatter(k, r, pk, v);
                }
                touched.clear();
                for (k, v) in spill.drain(..) {
                    let (r, pk) = m.locate(&elim, k);
                    scatter(k, r, pk, v);
                }
            },
        );
        (a, interior_rows.into_inner())
    }
}

impl StencilReduced {
    /// The first Galerkin operator `Pᵀ S P` as a structured level's `f64` stencil weights
    /// ([`ClassParts`], one block per kept moment), straight from the position maps: the
    /// level's CSR is never formed (80³ P_5: 52 M entries, 0.8 GB, and its conversion to
    /// the stencil level). `None` when some row has no map (see [`CoarseMaps`]) or a
    /// correction reaches a coarse column outside its moment's terms; then
    /// [`StencilReduced::coarse`] forms the CSR.
    pub fn coarse_parts(
        &self,
        d_e: &[f64],
        d_o: &[f64],
        ag: &Aggregation,
    ) -> Option<Vec<ClassParts>> {
        let (n_e, n_o) = (d_e.len(), d_o.len());
        let m = &self.moments;
        let (b, c) = (&self.b, &self.c);
        let maps = CoarseMaps::new(m, b, c, n_o, ag.coarse_len())?;
        let (b_rows, c_rows) = (Rows::new(b, m, n_e), Rows::new(c, m, n_o));
        let elim = m.class(false);
        let fixes = Fixes {
            m,
            b,
            c,
            b_rows: &b_rows,
            c_rows: &c_rows,
            elim: &elim,
            d_o,
        };
        let kept: Vec<usize> = (0..m.ext.len()).filter(|&q| m.kept[q]).collect();
        let f = maps.factor().map(|v| v as i64);
        let failed = AtomicBool::new(false);
        let mut parts = Vec::with_capacity(kept.len());
        for &q in &kept {
            let terms = maps.terms(q)?;
            let (start, cext) = maps.coarse_box(q);
            let plane = (cext[1] * cext[2]).max(1);
            let kn = terms.len();
            // Term index by (column moment, shift) for the corrections' columns.
            let index = TermIndex::new(m.ext.len(), terms.iter().copied())?;
            let mut weights = vec![0.0f64; kn * cext.iter().product::<usize>()];
            // The corrections of coarse row `i` of a plane `w` (at coarse position `ci`,
            // aggregate `members`, corrected slots `corrected`: as in `coarse`), each added
            // to its column's term.
            let correct = |w: &mut [f64],
                           i: usize,
                           ci: [i64; 3],
                           members: &[u32],
                           corrected: &[(usize, f64)]| {
                fixes.products(members, corrected, |j, v| {
                    let j = ag.agg[j] as usize;
                    let (p, pj) = (ag.coarse.class[j] as usize, ag.coarse.coords[j]);
                    let delta = [0, 1, 2].map(|d| pj[d] as i64 - ci[d]);
                    match index.get(p, delta) {
                        Some(k) => w[k * plane + i] += v,
                        None => failed.store(true, Ordering::Relaxed),
                    }
                });
            };
            weights
                .par_chunks_mut((kn * plane).max(1))
                .enumerate()
                .for_each_init(
                    || (MapScratch::default(), LaneScratch::default()),
                    |(scr, lanes), (ix, w)| {
                        let mut i = 0;
                        while i < plane {
                            let ci = [ix as i64, (i / cext[2]) as i64, (i % cext[2]) as i64];
                            let corner: [i64; 3] = std::array::from_fn(|d| f[d] * ci[d]);
                            let row = start + ix * plane + i;
                            // LANES rows along z at once where they share a map.
                            if i % cext[2] + LANES <= cext[2] {
                                let members: [&[u32]; LANES] = std::array::from_fn(|l| {
                                    &ag.members[ag.ptr[row + l]..ag.ptr[row + l + 1]]
                                });
                                if maps.emit_lanes(
                                    m,
                                    d_e,
                                    d_o,
                                    q,
                                    corner,
                                    members,
                                    lanes,
                                    |k, v| {
                                        w[k * plane + i..k * plane + i + LANES]
                                            .iter_mut()
                                            .zip(v)
                                            .for_each(|(o, v)| *o += v);
                                    },
                                ) {
                                    for (l, mem) in members.iter().enumerate() {
                                        let cl = [ci[0], ci[1], ci[2] + l as i64];
                                        correct(w, i + l, cl, mem, &lanes.corrected[l]);
                                    }
                                    i += LANES;
                                    continue;
                                }
                            }
                            let members = &ag.members[ag.ptr[row]..ag.ptr[row + 1]];
                            let Some(prepared) = maps.prepare(m, d_o, q, corner, members, scr)
                            else {
                                failed.store(true, Ordering::Relaxed);
                                return;
                            };
                            maps.emit_class_terms(&prepared, d_e, scr, |k, v| {
                                w[k * plane + i] += v;
                            });
                            correct(w, i, ci, members, &scr.corrected);
                            i += 1;
                        }
                    },
                );
            if failed.load(Ordering::Relaxed) {
                return None;
            }
            parts.push(ClassParts {
                start,
                ext: cext,
                terms: terms
                    .iter()
                    .map(|&(p, d)| (kept.binary_search(&p).unwrap_or(usize::MAX), d))
                    .collect(),
                weights,
            });
        }
        Some(parts)
    }
}

/// The corrections' share of a coarse row whose stencil part came from a position map
/// (module `interior`): `−Pᵀ B_fix D_o⁻¹ C P − Pᵀ B_st D_o⁻¹ C_fix P`.
struct Fixes<'a> {
    m: &'a Moments,
    b: &'a StencilBlock,
    c: &'a StencilBlock,
    b_rows: &'a Rows<'a>,
    c_rows: &'a Rows<'a>,
    elim: &'a [usize],
    d_o: &'a [f64],
}

impl Fixes<'_> {
    /// Whether no child in `members` has a `B` correction.
    fn plain(&self, members: &[u32]) -> bool {
        let p = &self.b_rows.fix_ptr;
        members.iter().all(|&i| p[i as usize] == p[i as usize + 1])
    }

    /// `add(j, v)` (`j` a fine even column) for the children's `B` corrections times the whole
    /// `C` row they reach, and for the `C` corrections of the slots the stencil `B` reaches
    /// (`corrected`: odd unknown and summed stencil weight `β`, from the map).
    fn products(
        &self,
        members: &[u32],
        corrected: &[(usize, f64)],
        mut add: impl FnMut(usize, f64),
    ) {
        let (b, c, d_o) = (self.b, self.c, self.d_o);
        for &i in members {
            let i = i as usize;
            for f in self.b_rows.fix_ptr[i] as usize..self.b_rows.fix_ptr[i + 1] as usize {
                let k = b.fix_cols[f] as usize;
                let g = -b.fix_vals[f] / d_o[k];
                let (r, pk) = self.m.locate(self.elim, k);
                self.c_rows.for_row(r, pk, k, |j, _, cw| add(j, g * cw));
            }
        }
        for &(k, beta) in corrected {
            let g = -beta / d_o[k];
            for f in self.c_rows.fix_ptr[k] as usize..self.c_rows.fix_ptr[k + 1] as usize {
                add(c.fix_cols[f] as usize, g * c.fix_vals[f]);
            }
        }
    }
}

/// The scratch of one task of [`StencilReduced::coarse`]: the window's sums (zero between
/// rows), the slots touched in the current row, and the entries outside the window.
struct Window {
    sums: Vec<f64>,
    touched: Vec<u32>,
    spill: Vec<(usize, f64)>,
    maps: MapScratch,
}

impl StencilReduced {
    /// `B` and `C̃ = D_o⁻¹ C` as CSR blocks, from the stencils and corrections (columns
    /// sorted, repeated columns summed, exact zeros dropped), for the routes that read the
    /// blocks entry by entry.
    pub fn to_blocks(&self, d_o: &[f64]) -> (BlockMat, BlockMat) {
        let m = &self.moments;
        let n_e: usize = (0..m.ext.len())
            .filter(|&q| m.kept[q])
            .map(|q| m.ext[q].iter().product::<usize>())
            .sum();
        let n_o = d_o.len();
        let (kept, elim) = (m.class(true), m.class(false));
        let block =
            |rows: &Rows, class: &[usize], n_rows: usize, n_cols: usize, scale: Option<&[f64]>| {
                let per_row: Vec<Vec<(u32, f64)>> = (0..n_rows)
                    .into_par_iter()
                    .with_min_len(4096)
                    .map(|r| {
                        let (q, pos) = m.locate(class, r);
                        let mut e: Vec<(u32, f64)> = Vec::new();
                        rows.for_row(q, pos, r, |c, _, w| e.push((c as u32, w)));
                        e.sort_unstable_by_key(|x| x.0);
                        let mut out: Vec<(u32, f64)> = Vec::with_capacity(e.len());
                        for (c, w) in e {
                            match out.last_mut() {
                                Some(last) if last.0 == c => last.1 += w,
                                _ => out.push((c, w)),
                            }
                        }
                        let s = scale.map_or(1.0, |d| 1.0 / d[r]);
                        out.retain(|x| x.1 != 0.0);
                        out.iter_mut().for_each(|x| x.1 *= s);
                        out
                    })
                    .collect();
                let mut indptr = Vec::with_capacity(n_rows + 1);
                indptr.push(0usize);
                let (mut idx, mut val) = (Vec::new(), Vec::new());
                for row in per_row {
                    for (c, w) in row {
                        idx.push(c);
                        val.push(w);
                    }
                    indptr.push(idx.len());
                }
                BlockMat::new((n_rows, n_cols), indptr, idx, val)
            };
        let b = block(&Rows::new(&self.b, m, n_e), &kept, n_e, n_o, None);
        let c = block(&Rows::new(&self.c, m, n_o), &elim, n_o, n_e, Some(d_o));
        (b, c)
    }
}
