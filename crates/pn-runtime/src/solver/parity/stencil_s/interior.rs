//! The first Galerkin operator's rows from **maps fixed per row moment and position
//! class**: the stencil part of `Pᵀ S P` without a sparse accumulator.
//!
//! A coarse row `(q, I)` of `Pᵀ S P` sums, over its aggregate's children `i = f·I + c`
//! (`f` = 2 on the coarsened axes, 1 elsewhere), `D_e,i` on the diagonal and
//! `−B_ik C_kj / D_o,k` over the odd unknowns `k = i + δ₁` its `B` terms reach and the
//! columns `j = k + δ₂` of their `C` terms, into the coarse column `(p, ⌊j / f⌋)`
//! (docs/design.md §5). The stencil weights are the same for every row; which children,
//! `k` and `j` lie inside their grids depends only on where `I` lies per axis: inside the
//! box where everything does (*mid*), or at one of the few positions near a face. So, per
//! row moment and combination of per-axis classes, the stencil part of the row is
//!
//! `a(q, I; p, Δ) = Σ_children D_e [Δ = 0, p = q] + Σ_slots γ(p, Δ; r, u) / D_o(r, f·I + u)`
//!
//! with `γ = −Σ B_w C_w` summed once over every valid (child, `B` term, `C` term) triple
//! that meets odd slot `(r, u)` and coarse term `(p, Δ)`. A row then costs one read of
//! `1 / D_o` per slot and one multiply-add per non-zero `γ`. The blocks' corrections
//! (`B = B_st + B_fix`, `C = C_st + C_fix`, the fixes being the Neumann-clamped
//! references) add `−Pᵀ B_fix D_o⁻¹ C P − Pᵀ B_st D_o⁻¹ C_fix P`; [`PositionMap::row`]
//! reports the slots with `C` corrections and their summed `B_st` weight `β` so that the
//! caller ([`super::StencilReduced::coarse`]) adds them, and the `B` corrections of the
//! children, from the rows themselves.

use super::{Moments, StencilBlock};
use std::collections::BTreeMap;

/// Largest number of position-class combinations per row moment (tiny grids where most
/// positions are near a face take the general route instead).
const MAX_CLASSES: usize = 125;

/// A coarse term: column moment and coarse shift.
#[derive(Clone, Copy)]
struct CoarseTerm {
    moment: usize,
    delta: [i64; 3],
}

/// The stencil part of the rows of one row moment at one combination of per-axis
/// position classes (see the module documentation).
struct PositionMap {
    /// Local offsets of the children inside the grid from the first child.
    children: Vec<usize>,
    /// Slots: index into `moments_reached`, offset from the moment's corner index, and
    /// the summed `B` weight `β` of the children reaching the slot.
    slot_moment: Vec<u16>,
    slot_offset: Vec<i64>,
    slot_beta: Vec<f64>,
    /// Coarse terms in ascending column order, `γ` of term `k` at `ptr[k]..ptr[k + 1]`.
    terms: Vec<CoarseTerm>,
    diag: Option<usize>,
    ptr: Vec<u32>,
    slot: Vec<u32>,
    gamma: Vec<f64>,
    /// Index of each term in its moment's [`MomentMaps::terms`].
    class_term: Vec<u32>,
}

/// All the (child, `B` term, `C` term) triples of one row moment, before the grids cut
/// them.
struct Template {
    children: Vec<[i64; 3]>,
    /// Odd slots `(moment, offset from the corner)`, sorted.
    slots: Vec<(usize, [i64; 3])>,
    /// `(child, slot, B weight)`.
    reach: Vec<(usize, usize, f64)>,
    /// `(child, slot, column moment, column offset, term, −B_w C_w)`.
    triples: Vec<(usize, usize, usize, [i64; 3], usize, f64)>,
    terms: Vec<CoarseTerm>,
}

/// The maps of one row moment.
struct MomentMaps {
    /// Coarse positions `lo ≤ I < hi` per axis are *mid*; the others are listed in
    /// `special` and have their own class.
    lo: [i64; 3],
    hi: [i64; 3],
    special: [Vec<i64>; 3],
    /// Eliminated moments the slots belong to.
    moments_reached: Vec<usize>,
    /// Indexed by the class combination; `None` where the combination never occurs.
    maps: Vec<Option<PositionMap>>,
    /// Every term of any of the maps, sorted (column moment, coarse shift).
    terms: Vec<(usize, [i64; 3])>,
}

/// The stencil part of every coarse row of `Pᵀ S P` whose aggregate is a block of its
/// moment's grid (see the module documentation).
pub(super) struct CoarseMaps {
    moments: Vec<Option<MomentMaps>>,
    factor: [usize; 3],
    /// First coarse unknown and coarse extent of each kept moment.
    coarse_start: Vec<usize>,
    coarse_ext: Vec<[usize; 3]>,
    /// Rows of `C` (odd-local) that carry corrections.
    fixed_c: Vec<bool>,
}

/// Per-task scratch of [`CoarseMaps::row`].
#[derive(Default)]
pub(super) struct MapScratch {
    inv: Vec<f64>,
    base: Vec<i64>,
    /// The row's slots with `C` corrections: odd-local index and `β`.
    pub(super) corrected: Vec<(usize, f64)>,
}

impl CoarseMaps {
    /// The maps for the blocks `b`, `c` of `m` (`n_o` eliminated unknowns) and the
    /// aggregation by two of every axis where a kept moment has more than one position;
    /// `None` when the aggregation's `coarse_len` is not that of the kept moments' halved
    /// boxes (then every row takes the general route).
    pub(super) fn new(
        m: &Moments,
        b: &StencilBlock,
        c: &StencilBlock,
        n_o: usize,
        coarse_len: usize,
    ) -> Option<Self> {
        use rayon::prelude::*;
        let nm = m.ext.len();
        let halve: [bool; 3] =
            std::array::from_fn(|d| (0..nm).any(|q| m.kept[q] && m.ext[q][d] > 1));
        let factor = halve.map(|h| if h { 2 } else { 1 });
        let mut coarse_start = vec![usize::MAX; nm];
        let mut coarse_ext = vec![[0usize; 3]; nm];
        let mut at = 0;
        for q in (0..nm).filter(|&q| m.kept[q]) {
            let e = m.ext[q];
            coarse_ext[q] = std::array::from_fn(|d| e[d].div_ceil(factor[d]));
            coarse_start[q] = at;
            at += coarse_ext[q].iter().product::<usize>();
        }
        if at != coarse_len {
            return None;
        }
        let mut fixed_c = vec![false; n_o];
        for &r in &c.fix_rows {
            fixed_c[r as usize] = true;
        }
        let moments = (0..nm)
            .into_par_iter()
            .map(|q| {
                if !m.kept[q] || b.terms[q].is_empty() {
                    return None;
                }
                MomentMaps::new(m, b, c, q, factor, coarse_ext[q])
            })
            .collect();
        Some(Self {
            moments,
            factor,
            coarse_start,
            coarse_ext,
            fixed_c,
        })
    }

    /// The maps of kept moment `q`, the coarse position of the row whose first child lies at
    /// `corner`, and the index of its position map; `None` when the moment has no maps or
    /// `corner` is not an aggregate's first child.
    fn locate(&self, q: usize, corner: [i64; 3]) -> Option<(&MomentMaps, [i64; 3], usize)> {
        let mm = self.moments[q].as_ref()?;
        let f = self.factor.map(|v| v as i64);
        if (0..3).any(|d| corner[d] % f[d] != 0) {
            return None;
        }
        let ci: [i64; 3] = std::array::from_fn(|d| corner[d] / f[d]);
        let cls = mm.class_of(ci)?;
        Some((mm, ci, cls))
    }

    /// The local index of the child at `corner` of moment `q` when `members` is exactly the
    /// block of children `map` expects there, in order.
    fn first_child(
        m: &Moments,
        q: usize,
        corner: [i64; 3],
        map: &PositionMap,
        members: &[u32],
    ) -> Option<usize> {
        let e = m.ext[q];
        if (0..3).any(|d| corner[d] < 0 || corner[d] as usize >= e[d]) {
            return None;
        }
        let first = m.local_off[q] + m.linear(q, corner.map(|v| v as usize));
        (members.len() == map.children.len()
            && members
                .iter()
                .zip(&map.children)
                .all(|(&i, &o)| i as usize == first + o))
        .then_some(first)
    }

    /// The local index, in each moment `mm` reaches, of the position `corner` (the slots'
    /// offsets are relative to it).
    fn slot_bases(m: &Moments, mm: &MomentMaps, corner: [i64; 3], base: &mut Vec<i64>) {
        base.clear();
        base.extend(mm.moments_reached.iter().map(|&r| {
            let e = m.ext[r];
            m.local_off[r] as i64 + (corner[0] * e[1] as i64 + corner[1]) * e[2] as i64 + corner[2]
        }));
    }

    /// Prepares coarse row `(q, corner / f)` (its aggregate `members`, `corner` the first
    /// child's position): gathers `1 / D_o` at its slots into `scratch`, lists the slots
    /// that carry `C` corrections in `scratch.corrected`, and returns the row to hand to
    /// [`CoarseMaps::emit`]; `None` when the row must take the general route.
    #[allow(clippy::too_many_arguments)]
    pub(super) fn prepare<'s>(
        &'s self,
        m: &Moments,
        d_o: &[f64],
        q: usize,
        corner: [i64; 3],
        members: &[u32],
        scratch: &mut MapScratch,
    ) -> Option<MapRow<'s>> {
        let (mm, ci, cls) = self.locate(q, corner)?;
        let map = mm.maps[cls].as_ref()?;
        let first = Self::first_child(m, q, corner, map, members)?;
        let MapScratch {
            inv,
            base,
            corrected,
        } = scratch;
        Self::slot_bases(m, mm, corner, base);
        inv.clear();
        corrected.clear();
        for (s, (&r, &o)) in map.slot_moment.iter().zip(&map.slot_offset).enumerate() {
            let k = (base[r as usize] + o) as usize;
            if self.fixed_c[k] {
                corrected.push((k, map.slot_beta[s]));
            }
            inv.push(1.0 / d_o[k]);
        }
        Some(MapRow { map, ci, first })
    }

    /// Calls `add(column, value)` for the stencil part of a prepared row, in ascending
    /// column order, each column once.
    pub(super) fn emit(
        &self,
        row: &MapRow<'_>,
        d_e: &[f64],
        scratch: &MapScratch,
        mut add: impl FnMut(u32, f64),
    ) {
        let ci = row.ci;
        self.emit_terms(row, d_e, scratch, |k, v| {
            let t = row.map.terms[k];
            let e = self.coarse_ext[t.moment];
            let j = [0, 1, 2].map(|d| (ci[d] + t.delta[d]) as usize);
            let col = self.coarse_start[t.moment] + (j[0] * e[1] + j[1]) * e[2] + j[2];
            add(col as u32, v);
        });
    }

    /// Calls `add(term, value)` for the stencil part of a prepared row, `term` indexing its
    /// moment's [`CoarseMaps::terms`].
    pub(super) fn emit_class_terms(
        &self,
        row: &MapRow<'_>,
        d_e: &[f64],
        scratch: &MapScratch,
        mut add: impl FnMut(usize, f64),
    ) {
        self.emit_terms(row, d_e, scratch, |k, v| {
            add(row.map.class_term[k] as usize, v)
        });
    }

    /// The terms every row of kept moment `q` may have (column moment, coarse shift), sorted;
    /// `None` when the moment has no maps.
    pub(super) fn terms(&self, q: usize) -> Option<&[(usize, [i64; 3])]> {
        self.moments[q].as_ref().map(|m| m.terms.as_slice())
    }

    /// First coarse unknown and coarse extent of kept moment `q`.
    pub(super) fn coarse_box(&self, q: usize) -> (usize, [usize; 3]) {
        (self.coarse_start[q], self.coarse_ext[q])
    }

    /// The aggregation factor per axis.
    pub(super) fn factor(&self) -> [usize; 3] {
        self.factor
    }

    /// `add(k, value)` for the map's term `k` of a prepared row.
    fn emit_terms(
        &self,
        row: &MapRow<'_>,
        d_e: &[f64],
        scratch: &MapScratch,
        mut add: impl FnMut(usize, f64),
    ) {
        let MapRow { map, first, .. } = *row;
        let inv = &scratch.inv;
        for k in 0..map.terms.len() {
            let (lo, hi) = (map.ptr[k] as usize, map.ptr[k + 1] as usize);
            let mut v = dot_gathered(&map.slot[lo..hi], &map.gamma[lo..hi], inv);
            if map.diag == Some(k) {
                v += map.children.iter().map(|&o| d_e[first + o]).sum::<f64>();
            }
            add(k, v);
        }
    }
}

/// Rows computed at once by [`CoarseMaps::emit_lanes`].
pub(super) const LANES: usize = 4;

impl CoarseMaps {
    /// The stencil parts of [`LANES`] rows of kept moment `q` that follow each other along
    /// z, the first with its first child at `corner` and aggregate `members[0]`: calls
    /// `add(term, values)` (`term` indexing [`CoarseMaps::terms`], one value per row) and
    /// returns `true` when the rows share one position map, listing in
    /// `scratch.corrected[l]` the slots of row `l` with `C` corrections (as
    /// [`CoarseMaps::prepare`] does for one row: the caller adds the corrections); else
    /// returns `false`, adding nothing (the caller takes the rows one by one). The
    /// multiply-adds of the rows run side by side: the same `γ` times `1 / D_o` `f_z`
    /// positions apart.
    #[allow(clippy::too_many_arguments)]
    pub(super) fn emit_lanes(
        &self,
        m: &Moments,
        d_e: &[f64],
        d_o: &[f64],
        q: usize,
        corner: [i64; 3],
        members: [&[u32]; LANES],
        scratch: &mut LaneScratch,
        mut add: impl FnMut(usize, [f64; LANES]),
    ) -> bool {
        let Some((mm, ci, cls)) = self.locate(q, corner) else {
            return false;
        };
        let Some(map) = mm.maps[cls].as_ref() else {
            return false;
        };
        let fz = self.factor[2];
        let mut first = [0usize; LANES];
        for (l, mem) in members.iter().enumerate() {
            let c = [ci[0], ci[1], ci[2] + l as i64];
            let corner_l = [corner[0], corner[1], corner[2] + (fz * l) as i64];
            match Self::first_child(m, q, corner_l, map, mem) {
                Some(f0) if mm.class_of(c) == Some(cls) => first[l] = f0,
                _ => return false,
            }
        }
        let LaneScratch {
            inv,
            base,
            corrected,
        } = scratch;
        Self::slot_bases(m, mm, corner, base);
        inv.clear();
        corrected.iter_mut().for_each(Vec::clear);
        for (s, (&r, &o)) in map.slot_moment.iter().zip(&map.slot_offset).enumerate() {
            let k = (base[r as usize] + o) as usize;
            let mut v = [0.0; LANES];
            for (l, v) in v.iter_mut().enumerate() {
                let kl = k + fz * l;
                if self.fixed_c[kl] {
                    corrected[l].push((kl, map.slot_beta[s]));
                }
                *v = 1.0 / d_o[kl];
            }
            inv.push(v);
        }
        for k in 0..map.terms.len() {
            let (lo, hi) = (map.ptr[k] as usize, map.ptr[k + 1] as usize);
            let mut v = [0.0; LANES];
            for (&s, &g) in map.slot[lo..hi].iter().zip(&map.gamma[lo..hi]) {
                let x = &inv[s as usize];
                for l in 0..LANES {
                    v[l] += g * x[l];
                }
            }
            if map.diag == Some(k) {
                for l in 0..LANES {
                    v[l] += map.children.iter().map(|&o| d_e[first[l] + o]).sum::<f64>();
                }
            }
            add(map.class_term[k] as usize, v);
        }
        true
    }
}

/// Per-task scratch of [`CoarseMaps::emit_lanes`].
#[derive(Default)]
pub(super) struct LaneScratch {
    inv: Vec<[f64; LANES]>,
    base: Vec<i64>,
    /// Each row's slots with `C` corrections: odd-local index and `β`.
    pub(super) corrected: [Vec<(usize, f64)>; LANES],
}

/// A coarse row prepared by [`CoarseMaps::prepare`].
#[derive(Clone, Copy)]
pub(super) struct MapRow<'a> {
    map: &'a PositionMap,
    ci: [i64; 3],
    first: usize,
}

impl MomentMaps {
    /// The maps of kept moment `q` (coarse extent `cext`) for the aggregation factors `f`;
    /// `None` when too many positions are near a face.
    fn new(
        m: &Moments,
        b: &StencilBlock,
        c: &StencilBlock,
        q: usize,
        f: [usize; 3],
        cext: [usize; 3],
    ) -> Option<Self> {
        let fi = f.map(|v| v as i64);
        let ext = |p: usize| m.ext[p].map(|v| v as i64);
        let t = Template::new(b, c, q, fi);
        // Mid box: every child inside q's grid and every position `f·I + u` reached
        // inside its moment's grid.
        let eq = ext(q);
        let mut lo = [0i64; 3];
        let mut hi: [i64; 3] = std::array::from_fn(|d| eq[d].div_euclid(fi[d]));
        let mut within = |u: [i64; 3], e: [i64; 3]| {
            for d in 0..3 {
                lo[d] = lo[d].max(-(u[d].div_euclid(fi[d])));
                hi[d] = hi[d].min((e[d] - 1 - u[d]).div_euclid(fi[d]) + 1);
            }
        };
        for &(r, u) in &t.slots {
            within(u, ext(r));
        }
        for tr in &t.triples {
            within(tr.3, ext(tr.2));
        }
        let special: [Vec<i64>; 3] = std::array::from_fn(|d| {
            (0..cext[d] as i64)
                .filter(|&i| i < lo[d] || i >= hi[d])
                .collect()
        });
        let n: [usize; 3] = std::array::from_fn(|d| special[d].len() + 1);
        if n.iter().product::<usize>() > MAX_CLASSES {
            return None;
        }
        let mut moments_reached: Vec<usize> = t.slots.iter().map(|s| s.0).collect();
        moments_reached.dedup();
        let mut maps = Vec::with_capacity(n.iter().product());
        for cx in 0..n[0] {
            for cy in 0..n[1] {
                for cz in 0..n[2] {
                    let cls = [cx, cy, cz];
                    // A representative coarse position of the class.
                    let pos: Option<[i64; 3]> = (0..3)
                        .map(|d| match cls[d] {
                            0 => (lo[d] < hi[d]).then_some(lo[d]),
                            k => Some(special[d][k - 1]),
                        })
                        .collect::<Option<Vec<i64>>>()
                        .map(|v| [v[0], v[1], v[2]]);
                    maps.push(pos.map(|p| t.at(m, q, fi, p, &moments_reached)));
                }
            }
        }
        let mut terms: Vec<(usize, [i64; 3])> = maps
            .iter()
            .flatten()
            .flat_map(|m| m.terms.iter().map(|t| (t.moment, t.delta)))
            .collect();
        terms.sort_unstable();
        terms.dedup();
        for m in maps.iter_mut().flatten() {
            m.class_term = m
                .terms
                .iter()
                .map(|t| terms.binary_search(&(t.moment, t.delta)).unwrap_or(0) as u32)
                .collect();
        }
        Some(Self {
            lo,
            hi,
            special,
            moments_reached,
            maps,
            terms,
        })
    }

    /// Index of the class combination of coarse position `ci`.
    fn class_of(&self, ci: [i64; 3]) -> Option<usize> {
        let mut k = 0;
        for (d, (&i, special)) in ci.iter().zip(&self.special).enumerate() {
            let c = if i >= self.lo[d] && i < self.hi[d] {
                0
            } else {
                1 + special.iter().position(|&s| s == i)?
            };
            k = k * (special.len() + 1) + c;
        }
        Some(k)
    }
}

impl Template {
    /// The triples of kept moment `q` for the aggregation factors `f`.
    fn new(b: &StencilBlock, c: &StencilBlock, q: usize, f: [i64; 3]) -> Self {
        let children: Vec<[i64; 3]> = (0..f[0])
            .flat_map(|x| (0..f[1]).flat_map(move |y| (0..f[2]).map(move |z| [x, y, z])))
            .collect();
        let coarse_shift =
            |v: [i64; 3]| -> [i64; 3] { std::array::from_fn(|d| v[d].div_euclid(f[d])) };
        let mut slot_of: BTreeMap<(usize, [i64; 3]), usize> = BTreeMap::new();
        let mut coarse: BTreeMap<(usize, [i64; 3]), usize> = BTreeMap::new();
        coarse.insert((q, [0; 3]), 0);
        for ch in &children {
            for t1 in &b.terms[q] {
                let u = add(*ch, t1.delta);
                slot_of.insert((t1.moment, u), 0);
                for t2 in &c.terms[t1.moment] {
                    coarse.insert((t2.moment, coarse_shift(add(u, t2.delta))), 0);
                }
            }
        }
        for (k, v) in coarse.values_mut().enumerate() {
            *v = k;
        }
        for (k, v) in slot_of.values_mut().enumerate() {
            *v = k;
        }
        let (mut reach, mut triples) = (Vec::new(), Vec::new());
        for (ci, ch) in children.iter().enumerate() {
            for t1 in &b.terms[q] {
                let u = add(*ch, t1.delta);
                let s = slot_of[&(t1.moment, u)];
                reach.push((ci, s, t1.weight));
                for t2 in &c.terms[t1.moment] {
                    let v = add(u, t2.delta);
                    let k = coarse[&(t2.moment, coarse_shift(v))];
                    triples.push((ci, s, t2.moment, v, k, -t1.weight * t2.weight));
                }
            }
        }
        // By term, then slot: a map merges the runs of one (term, slot).
        triples.sort_by_key(|t| (t.4, t.1));
        Self {
            children,
            slots: slot_of.into_keys().collect(),
            reach,
            triples,
            terms: coarse
                .into_keys()
                .map(|(moment, delta)| CoarseTerm { moment, delta })
                .collect(),
        }
    }

    /// The map at coarse position `ci` of moment `q` (the triples whose child, slot and
    /// column lie inside their grids there).
    fn at(
        &self,
        m: &Moments,
        q: usize,
        f: [i64; 3],
        ci: [i64; 3],
        moments_reached: &[usize],
    ) -> PositionMap {
        let corner: [i64; 3] = std::array::from_fn(|d| f[d] * ci[d]);
        let inside = |p: usize, u: [i64; 3]| {
            (0..3).all(|d| corner[d] + u[d] >= 0 && corner[d] + u[d] < m.ext[p][d] as i64)
        };
        let child_ok: Vec<bool> = self.children.iter().map(|&c| inside(q, c)).collect();
        let slot_ok: Vec<bool> = self.slots.iter().map(|&(r, u)| inside(r, u)).collect();
        // Compact numbering of the slots inside the grids.
        let mut new_slot = vec![u32::MAX; self.slots.len()];
        let (mut slot_moment, mut slot_offset) = (Vec::new(), Vec::new());
        for (s, &(r, u)) in self.slots.iter().enumerate() {
            if slot_ok[s] {
                new_slot[s] = slot_moment.len() as u32;
                let e = m.ext[r].map(|v| v as i64);
                slot_moment.push(moments_reached.binary_search(&r).unwrap_or(0) as u16);
                slot_offset.push((u[0] * e[1] + u[1]) * e[2] + u[2]);
            }
        }
        let mut slot_beta = vec![0.0; slot_moment.len()];
        for &(c, s, w) in &self.reach {
            if child_ok[c] && slot_ok[s] {
                slot_beta[new_slot[s] as usize] += w;
            }
        }
        // Merged runs of one (term, slot) in the triples' order (term, then slot).
        let mut merged: Vec<(usize, u32, f64)> = Vec::new();
        for &(c, s, p, v, k, w) in &self.triples {
            if !(child_ok[c] && slot_ok[s] && inside(p, v)) {
                continue;
            }
            let ns = new_slot[s];
            match merged.last_mut() {
                Some(last) if last.0 == k && last.1 == ns => last.2 += w,
                _ => merged.push((k, ns, w)),
            }
        }
        let diag = self
            .terms
            .iter()
            .position(|t| t.moment == q && t.delta == [0; 3]);
        let eq = m.ext[q].map(|v| v as i64);
        let children = self
            .children
            .iter()
            .zip(&child_ok)
            .filter(|(_, &ok)| ok)
            .map(|(ch, _)| ((ch[0] * eq[1] + ch[1]) * eq[2] + ch[2]) as usize)
            .collect();
        let (mut terms, mut ptr, mut slot, mut gamma) =
            (Vec::new(), vec![0u32], Vec::new(), Vec::new());
        let mut new_diag = None;
        let mut at = 0;
        for k in 0..self.terms.len() {
            let run = merged[at..].iter().take_while(|e| e.0 == k).count();
            if run == 0 && Some(k) != diag {
                continue;
            }
            if Some(k) == diag {
                new_diag = Some(terms.len());
            }
            terms.push(self.terms[k]);
            for &(_, s, g) in &merged[at..at + run] {
                slot.push(s);
                gamma.push(g);
            }
            at += run;
            ptr.push(slot.len() as u32);
        }
        PositionMap {
            children,
            slot_moment,
            slot_offset,
            slot_beta,
            terms,
            diag: new_diag,
            ptr,
            slot,
            gamma,
            class_term: Vec::new(),
        }
    }
}

/// `Σ_k gamma[k] · x[slot[k]]` with four independent partial sums (the terms' sums are
/// short, and one running sum would wait on each addition).
#[inline]
fn dot_gathered(slot: &[u32], gamma: &[f64], x: &[f64]) -> f64 {
    let mut acc = [0.0f64; 4];
    let (sc, gc) = (slot.chunks_exact(4), gamma.chunks_exact(4));
    let (sr, gr) = (sc.remainder(), gc.remainder());
    for (s, g) in sc.zip(gc) {
        for l in 0..4 {
            acc[l] += g[l] * x[s[l] as usize];
        }
    }
    for (&s, &g) in sr.iter().zip(gr) {
        acc[0] += g * x[s as usize];
    }
    (acc[0] + acc[1]) + (acc[2] + acc[3])
}

#[inline]
fn add(a: [i64; 3], b: [i64; 3]) -> [i64; 3] {
    [a[0] + b[0], a[1] + b[1], a[2] + b[2]]
}
