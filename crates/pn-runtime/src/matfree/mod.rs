//! Matrix-free products with the discretized system: `A x` and `Aᵀ x` cell by cell from the
//! stencil, without storing `A` (docs/design.md §3 layout and boundary closure, §5 solvers).
//!
//! **What is stored.** The stencil's weights are evaluated once per row through the kernel
//! ([`StencilKernel::eval_row`], so compiled and interpreted stencils both work). A term
//! whose weight is the same in every row (all transport terms, `±c/h`, and the collision
//! terms of a homogeneous medium) is kept as one number; a term whose weight varies (the
//! collision diagonal `σ_t − σ_s λ_l p_l` in a heterogeneous medium) keeps one value per row.
//! Column indices are never stored: a term of moment `p` at half-cell offset `o` from a row
//! of moment `q` at position index `i` references position `i + (o + s_p − s_q)/2` of `p`
//! (`s` the half-cell shifts; exact by the parity check of [`check_kernel`]).
//!
//! **Boundaries.** References whose raw index is outside the moment's range are closed as
//! in assembly ([`Layout::resolve`]): dropped under Dirichlet, clamped under Neumann. The
//! clamped ones (a surface's worth) are kept as an explicit list of `(row, column, weight)`
//! and added after the regular part, so the interior loops carry no branches per term.
//!
//! **Parallelism.** `A x` is computed per output slab: one slab is one plane of the slowest
//! storage axis (x, see [`Layout`]) of one moment — planes of a 3D grid, rows of a 2D one.
//! `Aᵀ x` gathers instead of scattering: for an output position it visits the rows that
//! reference it (regular part), so it is slab-parallel too; the clamped list is applied
//! serially. Sums are taken in another order than the CSR product, so results agree with
//! it to rounding (~1e-16 relative), not bit for bit.

use crate::assemble::check_kernel;
use crate::context::RowContext;
use crate::layout::Layout;
use crate::problem::Problem;
use anyhow::Context;
use pn_krylov::operator::LinearOperator;
use pn_stencil::StencilKernel;
use rayon::prelude::*;

/// One stencil term with its index shift and its weight table.
#[derive(Clone, Debug)]
struct Term {
    /// Referenced moment.
    moment: usize,
    /// Position-index shift from the row to the referenced unknown, per axis.
    delta: [i64; 3],
    /// Constant weight, or the slot in the row's varying-weight record.
    weight: TermWeight,
}

#[derive(Clone, Copy, Debug)]
enum TermWeight {
    Const(f64),
    Varying(usize),
}

/// Per row moment: its terms and the varying weights, `nv` per row, row-major.
#[derive(Clone, Debug)]
struct RowBlock {
    terms: Vec<Term>,
    nv: usize,
    varying: Vec<f64>,
}

/// `A` of a stencil on a layout, applied without assembling it.
pub struct MatFreeOperator {
    layout: Layout,
    blocks: Vec<RowBlock>,
    /// For each column moment `p`: the (row moment, term) pairs referencing `p`.
    incoming: Vec<Vec<(usize, usize)>>,
    /// Neumann-clamped references: `(row, column, weight)`.
    clamped: Vec<(usize, usize, f64)>,
    rhs: Vec<f64>,
    max_weight: f64,
}

/// What one x-plane of one moment produced in the second setup pass.
struct PlaneOut {
    clamped: Vec<(usize, usize, f64)>,
}

impl MatFreeOperator {
    /// Evaluates the stencil of `kernel` for `problem` on `layout` (two passes over the
    /// rows: one finds the terms whose weight varies, one stores them and the right-hand
    /// side). Fails on invalid coefficients and non-finite weights, like assembly.
    pub fn new(
        problem: &Problem,
        kernel: &dyn StencilKernel,
        layout: &Layout,
    ) -> anyhow::Result<Self> {
        check_kernel(problem, kernel, layout)?;
        anyhow::ensure!(
            !problem.boundary.has_marshak(problem.grid.dim.axes()),
            "the matrix-free solvers do not take the Marshak boundary (its face rows are not \
             stencil rows); use an assembled solver such as parity-cg, cgnr, lsqr or lsmr"
        );
        let nm = layout.moments.len();
        let mut rhs = vec![0.0; layout.len()];
        let mut blocks = Vec::with_capacity(nm);
        let mut clamped = Vec::new();
        let mut max_weight = 0.0f64;
        for q in 0..nm {
            let pattern = kernel.pattern(q);
            let nt = pattern.len();
            let e = layout.extents[q];
            let plane = e[1] * e[2];
            // Pass 1: which weights differ from those of the first row.
            let first = eval(problem, kernel, layout, q, [0, 0, 0], nt)?.0;
            let varies = (0..e[0])
                .into_par_iter()
                .map(|ix| -> anyhow::Result<Vec<bool>> {
                    let mut v = vec![false; nt];
                    let mut w = vec![0.0; nt];
                    let mut ctx = RowContext::new(problem, [0; 3]);
                    for iy in 0..e[1] {
                        for iz in 0..e[2] {
                            eval_into(&mut ctx, kernel, layout, q, [ix, iy, iz], &mut w)?;
                            for t in 0..nt {
                                v[t] |= w[t].to_bits() != first[t].to_bits();
                            }
                        }
                    }
                    Ok(v)
                })
                .try_reduce(
                    || vec![false; nt],
                    |a, b| Ok(a.iter().zip(&b).map(|(x, y)| *x || *y).collect()),
                )?;
            let mut nv = 0;
            let terms: Vec<Term> = pattern
                .iter()
                .enumerate()
                .map(|(t, tp)| {
                    let sq = layout.moments[q].shift;
                    let sp = layout.moments[tp.moment].shift;
                    let delta = [0, 1, 2]
                        .map(|d| (tp.offset[d] as i64 + sp[d] as i64 - sq[d] as i64).div_euclid(2));
                    let weight = if varies[t] {
                        nv += 1;
                        TermWeight::Varying(nv - 1)
                    } else {
                        max_weight = max_weight.max(first[t].abs());
                        TermWeight::Const(first[t])
                    };
                    Term {
                        moment: tp.moment,
                        delta,
                        weight,
                    }
                })
                .collect();
            // Pass 2: varying weights, right-hand side and the clamped references.
            // With no varying term each plane still needs a (dummy, 1-value) chunk to zip with.
            let chunk = (plane * nv).max(1);
            let mut varying = vec![0.0; e[0] * chunk];
            let rhs_q = &mut rhs[layout.offsets[q]..layout.offsets[q + 1]];
            let outs: Vec<PlaneOut> = rhs_q
                .par_chunks_mut(plane.max(1))
                .zip(varying.par_chunks_mut(chunk))
                .enumerate()
                .map(|(ix, (rhs_p, var_p))| {
                    let mut w = vec![0.0; nt];
                    let mut ctx = RowContext::new(problem, [0; 3]);
                    let mut out = PlaneOut {
                        clamped: Vec::new(),
                    };
                    for iy in 0..e[1] {
                        for iz in 0..e[2] {
                            let idx = [ix, iy, iz];
                            let local = iy * e[2] + iz;
                            rhs_p[local] = eval_into(&mut ctx, kernel, layout, q, idx, &mut w)?;
                            let row = layout.index(q, idx);
                            let pos = layout.half_coord(q, idx);
                            for (t, term) in terms.iter().enumerate() {
                                if let TermWeight::Varying(k) = term.weight {
                                    var_p[local * nv + k] = w[t];
                                }
                                let ep = layout.extents[term.moment];
                                let inside = (0..3).all(|d| {
                                    let r = idx[d] as i64 + term.delta[d];
                                    r >= 0 && r < ep[d] as i64
                                });
                                if !inside {
                                    let half =
                                        [0, 1, 2].map(|d| pos[d] + pattern[t].offset[d] as i64);
                                    if let Some(col) =
                                        layout.resolve(term.moment, half, problem.boundary)
                                    {
                                        out.clamped.push((row, col, w[t]));
                                    }
                                }
                            }
                        }
                    }
                    Ok(out)
                })
                .collect::<anyhow::Result<_>>()?;
            if nv == 0 {
                varying = Vec::new();
            }
            max_weight = varying.iter().fold(max_weight, |m, v| m.max(v.abs()));
            for o in outs {
                clamped.extend(o.clamped);
            }
            blocks.push(RowBlock { terms, nv, varying });
        }
        let mut incoming = vec![Vec::new(); nm];
        for (q, b) in blocks.iter().enumerate() {
            for (t, term) in b.terms.iter().enumerate() {
                incoming[term.moment].push((q, t));
            }
        }
        Ok(Self {
            layout: layout.clone(),
            blocks,
            incoming,
            clamped,
            rhs,
            max_weight,
        })
    }

    /// The right-hand side `Q` of the system.
    pub fn rhs(&self) -> &[f64] {
        &self.rhs
    }

    /// The unknown layout.
    pub fn layout(&self) -> &Layout {
        &self.layout
    }

    /// Largest |weight| of the operator (for the magnitude check before solving).
    pub fn max_weight(&self) -> f64 {
        self.max_weight
    }

    /// Bytes held by the operator's tables (varying weights and the clamped list; the
    /// right-hand side not included).
    pub fn memory_bytes(&self) -> usize {
        let var: usize = self.blocks.iter().map(|b| b.varying.len() * 8).sum();
        var + self.clamped.len() * std::mem::size_of::<(usize, usize, f64)>()
    }

    /// Number of stored position-dependent weights (constant terms are stored once and
    /// not counted): what the operator keeps instead of the CSR's non-zeros.
    pub fn stored_weights(&self) -> usize {
        self.blocks.iter().map(|b| b.varying.len()).sum::<usize>() + self.clamped.len()
    }

    /// The moments as boxes of the output vector for [`for_planes_across`]: `(moment,
    /// values, values per x-plane)`.
    fn boxes(&self) -> impl Iterator<Item = (usize, usize, usize)> + '_ {
        self.layout
            .extents
            .iter()
            .enumerate()
            .map(|(q, e)| (q, e.iter().product(), e[1] * e[2]))
    }
}

/// Evaluates row `(q, idx)` with a fresh context: `(weights, rhs)`.
fn eval(
    problem: &Problem,
    kernel: &dyn StencilKernel,
    layout: &Layout,
    q: usize,
    idx: [usize; 3],
    nt: usize,
) -> anyhow::Result<(Vec<f64>, f64)> {
    let mut ctx = RowContext::new(problem, [0; 3]);
    let mut w = vec![0.0; nt];
    let r = eval_into(&mut ctx, kernel, layout, q, idx, &mut w)?;
    Ok((w, r))
}

/// Evaluates the weights of row `(q, idx)` into `w` and returns its right-hand side.
fn eval_into(
    ctx: &mut RowContext,
    kernel: &dyn StencilKernel,
    layout: &Layout,
    q: usize,
    idx: [usize; 3],
    w: &mut [f64],
) -> anyhow::Result<f64> {
    ctx.set_row(layout.half_coord(q, idx));
    let rhs = kernel.eval_row(q, ctx, w);
    if let Some(err) = ctx.take_error() {
        return Err(err).context("invalid scene coefficients");
    }
    anyhow::ensure!(
        rhs.is_finite() && w.iter().all(|v| v.is_finite()),
        "non-finite stencil weight in row of moment ({},{}) at {:?}",
        layout.moments[q].l,
        layout.moments[q].m,
        ctx.point([0; 3])
    );
    Ok(rhs)
}

/// Fewest output values per parallel task of [`for_planes_across`] (2D planes are one short
/// line: 71 values on the checkerboard).
const MIN_PLANE_TASK_VALUES: usize = 8192;

/// Runs `f(id, ix, first, plane)` in parallel over the x-planes of consecutive boxes of `v`
/// (each of `boxes` is `(id, values, values per x-plane)`; `first` is the plane's index in
/// `v`), x-plane by x-plane across the boxes: the source planes one box's plane reads (the
/// other boxes at `x − 1 … x + 1`) are still in cache when the next box's plane reads them.
/// At least [`MIN_PLANE_TASK_VALUES`] values per parallel task, so that scheduling does not
/// dominate. Used by the stencil `S` ([`crate::solver::parity::stencil_s`], boxes = moments)
/// and the coarse levels stored as stencils
/// ([`crate::solver::multigrid::stencil_level`], boxes = classes).
pub(crate) fn for_planes_across<T: Send>(
    v: &mut [T],
    boxes: impl IntoIterator<Item = (usize, usize, usize)>,
    f: impl Fn(usize, usize, usize, &mut [T]) + Sync,
) {
    let values = v.len();
    let mut planes = Vec::new();
    let mut rest = v;
    let mut at = 0;
    for (id, len, plane) in boxes {
        let (mine, tail) = rest.split_at_mut(len);
        rest = tail;
        let plane = plane.max(1);
        for (ix, s) in mine.chunks_mut(plane).enumerate() {
            planes.push((id, ix, at + ix * plane, s));
        }
        at += len;
    }
    // Stable: the boxes stay in order within an x-plane.
    planes.sort_by_key(|p| p.1);
    let min_len = (MIN_PLANE_TASK_VALUES * planes.len())
        .div_ceil(values.max(1))
        .max(1);
    planes
        .into_par_iter()
        .with_min_len(min_len)
        .for_each(|(id, ix, first, s)| f(id, ix, first, s));
}

/// `lo..hi` of `i` in `0..n` with `i + d` in `0..m` (also the index ranges of the stencil
/// `S`, [`crate::solver::parity::stencil_s`]).
pub(crate) fn range(n: usize, m: usize, d: i64) -> std::ops::Range<usize> {
    let lo = (-d).max(0) as usize;
    let hi = (m as i64 - d).clamp(0, n as i64) as usize;
    lo.min(hi)..hi
}

/// The y-lines of an output plane of extent `e` (its y and z) whose references at shift
/// `(dy, dz)` lie in a source plane of extent `ep` starting at `src_plane`: for each line,
/// the range of output positions within the plane and the source index of the first
/// (the walk of the ∂z-type stencil terms, line by line, in
/// [`crate::solver::parity::stencil_s`] and the multigrid's stencil levels).
pub(crate) fn shifted_lines(
    e: [usize; 3],
    ep: [usize; 3],
    src_plane: usize,
    dy: i64,
    dz: i64,
) -> impl Iterator<Item = (std::ops::Range<usize>, usize)> {
    let zs = range(e[2], ep[2], dz);
    let ys = if zs.is_empty() {
        0..0
    } else {
        range(e[1], ep[1], dy)
    };
    ys.map(move |iy| {
        let iyr = (iy as i64 + dy) as usize;
        let first = (src_plane as i64 + (iyr * ep[2]) as i64 + zs.start as i64 + dz) as usize;
        (iy * e[2] + zs.start..iy * e[2] + zs.end, first)
    })
}

/// `line[idx.start + k] += w_k · xs[k]` for `k` over `idx`, where `w_k` is the constant
/// weight or the varying weight of row `wrow + k` of `b`.
#[inline]
fn accumulate(
    line: &mut [f64],
    idx: std::ops::Range<usize>,
    xs: &[f64],
    weight: TermWeight,
    wrow: usize,
    b: &RowBlock,
) {
    let line = &mut line[idx];
    let xs = &xs[..line.len()];
    match weight {
        TermWeight::Const(w) => line.iter_mut().zip(xs).for_each(|(y, x)| *y += w * x),
        TermWeight::Varying(s) => {
            let ws = b.varying[wrow * b.nv..].iter().skip(s).step_by(b.nv);
            line.iter_mut()
                .zip(xs)
                .zip(ws)
                .for_each(|((y, x), w)| *y += w * x)
        }
    }
}

impl LinearOperator for MatFreeOperator {
    fn rows(&self) -> usize {
        self.layout.len()
    }
    fn cols(&self) -> usize {
        self.layout.len()
    }

    fn apply(&self, x: &[f64], y: &mut [f64]) {
        assert_eq!(x.len(), self.layout.len());
        assert_eq!(y.len(), self.layout.len());
        let l = &self.layout;
        for_planes_across(y, self.boxes(), |q, ix, _, ys| {
            ys.fill(0.0);
            let e = l.extents[q];
            let b = &self.blocks[q];
            for term in &b.terms {
                let p = term.moment;
                let ep = l.extents[p];
                let [dx, dy, dz] = term.delta;
                let ixr = ix as i64 + dx;
                if ixr < 0 || ixr >= ep[0] as i64 {
                    continue;
                }
                let plane = l.offsets[p] + ixr as usize * ep[1] * ep[2];
                if e[2] == 1 && ep[2] == 1 {
                    // One position in z (2D): the slab is one x-row, contiguous along y.
                    let iys = range(e[1], ep[1], dy);
                    let first = (plane as i64 + iys.start as i64 + dy) as usize;
                    let wrow = ix * e[1] + iys.start;
                    accumulate(ys, iys, &x[first..], term.weight, wrow, b);
                    continue;
                }
                for iy in range(e[1], ep[1], dy) {
                    let iyr = (iy as i64 + dy) as usize;
                    let zs = range(e[2], ep[2], dz);
                    let first =
                        (plane as i64 + (iyr * ep[2]) as i64 + zs.start as i64 + dz) as usize;
                    let wrow = (ix * e[1] + iy) * e[2] + zs.start;
                    let line = &mut ys[iy * e[2]..(iy + 1) * e[2]];
                    accumulate(line, zs, &x[first..], term.weight, wrow, b);
                }
            }
        });
        for &(r, c, w) in &self.clamped {
            y[r] += w * x[c];
        }
    }

    fn apply_transpose(&self, x: &[f64], y: &mut [f64]) {
        assert_eq!(x.len(), self.layout.len());
        assert_eq!(y.len(), self.layout.len());
        let l = &self.layout;
        for_planes_across(y, self.boxes(), |p, ix, _, ys| {
            ys.fill(0.0);
            let ep = l.extents[p];
            for &(q, t) in &self.incoming[p] {
                let b = &self.blocks[q];
                let term = &b.terms[t];
                let eq = l.extents[q];
                let [dx, dy, dz] = term.delta;
                // Row index = column index − delta.
                let ixq = ix as i64 - dx;
                if ixq < 0 || ixq >= eq[0] as i64 {
                    continue;
                }
                let plane = ixq as usize * eq[1] * eq[2];
                if ep[2] == 1 && eq[2] == 1 {
                    let iys = range(ep[1], eq[1], -dy);
                    let first = (plane as i64 + iys.start as i64 - dy) as usize;
                    accumulate(ys, iys, &x[l.offsets[q] + first..], term.weight, first, b);
                    continue;
                }
                for iy in range(ep[1], eq[1], -dy) {
                    let iyq = (iy as i64 - dy) as usize;
                    let zs = range(ep[2], eq[2], -dz);
                    let first =
                        (plane as i64 + (iyq * eq[2]) as i64 + zs.start as i64 - dz) as usize;
                    let line = &mut ys[iy * ep[2]..(iy + 1) * ep[2]];
                    accumulate(line, zs, &x[l.offsets[q] + first..], term.weight, first, b);
                }
            }
        });
        for &(r, c, w) in &self.clamped {
            y[c] += w * x[r];
        }
    }

    /// The compulsory traffic of one product, a lower bound (the roofline model of
    /// [`crate::bandwidth`]): `x` read and `y` written once (`16·n`; the stencil's shifted
    /// reads of `x` are assumed to hit cache after the first, and each output slab stays in
    /// cache while its terms accumulate), the position-dependent weights once
    /// (`8·`[`MatFreeOperator::stored_weights`] less the clamped list) and the clamped
    /// references (`(row, column, weight)`, 24 bytes each). Constant weights and the term
    /// tables are a few hundred bytes and not counted.
    fn bytes_per_application(&self) -> Option<u64> {
        let varying: usize = self.blocks.iter().map(|b| b.varying.len()).sum();
        let clamped = self.clamped.len() * std::mem::size_of::<(usize, usize, f64)>();
        Some((16 * self.layout.len() + 8 * varying + clamped) as u64)
    }
}
