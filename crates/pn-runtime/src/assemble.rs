//! Assembly of `A u = Q` from a stencil kernel: one row per (moment, position), in parallel.
//!
//! Each row evaluates the kernel's weights with a [`RowContext`] at the row's absolute
//! position, maps every term's offset to a storage index through the boundary closure
//! ([`Layout::resolve`]), merges duplicate columns (Neumann clamping can map two references
//! to the same unknown) and drops exact zeros off the diagonal.

use crate::context::RowContext;
use crate::layout::Layout;
use crate::marshak::{MarshakRows, DEFAULT_FACE_VALUE};
use crate::problem::Problem;
use crate::robin::RobinFaces;
use anyhow::Context;
use pn_stencil::StencilKernel;
use rayon::prelude::*;
use sprs::CsMat;

/// The assembled linear system.
pub struct System {
    /// Square sparse matrix in CSR form.
    pub matrix: CsMat<f64>,
    /// Right-hand side.
    pub rhs: Vec<f64>,
}

/// Rows per parallel work item.
pub(crate) const CHUNK: usize = 2048;

/// Consecutive assembled rows: entries per row, then the rows' columns and values
/// (columns sorted and unique within a row) and right-hand sides.
pub(crate) struct Chunk {
    pub(crate) row_nnz: Vec<usize>,
    pub(crate) cols: Vec<usize>,
    pub(crate) vals: Vec<f64>,
    pub(crate) rhs: Vec<f64>,
}

/// Checks that the kernel fits the problem and the layout (dimension, parity of offsets).
pub fn check_kernel(
    problem: &Problem,
    kernel: &dyn StencilKernel,
    layout: &Layout,
) -> anyhow::Result<()> {
    anyhow::ensure!(
        kernel.dim() == problem.grid.dim,
        "stencil {} is {:?} but the problem is {:?}",
        kernel.name(),
        kernel.dim(),
        problem.grid.dim
    );
    for row in 0..kernel.moments().len() {
        for t in kernel.pattern(row) {
            anyhow::ensure!(
                t.moment < kernel.moments().len(),
                "stencil row {row} references moment {}",
                t.moment
            );
            layout.check_parity(row, t.moment, t.offset)?;
        }
    }
    Ok(())
}

/// Assembles the system of `kernel` for `problem` on `layout`.
pub fn assemble(
    problem: &Problem,
    kernel: &dyn StencilKernel,
    layout: &Layout,
) -> anyhow::Result<System> {
    check_kernel(problem, kernel, layout)?;
    let (robin, marshak) = face_closures(problem, kernel, layout)?;
    let n = layout.len();
    let n_chunks = n.div_ceil(CHUNK);
    let chunks: Vec<Chunk> = (0..n_chunks)
        .into_par_iter()
        .map(|c| {
            let rows = c * CHUNK..((c + 1) * CHUNK).min(n);
            assemble_rows(
                problem,
                kernel,
                layout,
                marshak.as_ref(),
                robin.as_ref(),
                rows,
            )
        })
        .collect::<anyhow::Result<_>>()?;

    let nnz: usize = chunks.iter().map(|c| c.cols.len()).sum();
    let mut indptr = Vec::with_capacity(n + 1);
    let mut indices = Vec::with_capacity(nnz);
    let mut data = Vec::with_capacity(nnz);
    let mut rhs = Vec::with_capacity(n);
    let mut row_end = 0usize;
    indptr.push(row_end);
    for c in chunks {
        for k in c.row_nnz {
            row_end += k;
            indptr.push(row_end);
        }
        indices.extend(c.cols);
        data.extend(c.vals);
        rhs.extend(c.rhs);
    }
    let matrix = CsMat::try_new((n, n), indptr, indices, data)
        .map_err(|e| anyhow::anyhow!("internal error building the CSR matrix: {}", e.3))?;
    Ok(System { matrix, rhs })
}

/// Rows of `A u = Q` for a subset of the unknowns, as a domain-decomposed solve assembles
/// the rows its process owns (and the eliminated rows next to them): `indptr` has
/// `rows.len() + 1` entries, the columns of each row are global storage indices in
/// ascending order (the order [`assemble`] stores them in, so that a row's products sum
/// in the same order on any number of processes).
#[derive(Clone, Debug, Default)]
pub struct RowSet {
    /// Start of each row's entries in `cols`/`vals`, then the total.
    pub indptr: Vec<usize>,
    /// Global column of each entry.
    pub cols: Vec<usize>,
    /// Value of each entry.
    pub vals: Vec<f64>,
    /// Right-hand side of each row.
    pub rhs: Vec<f64>,
}

/// Assembles the rows `rows` (global storage indices, in that order) of `kernel` for
/// `problem` on `layout`: the same rows, entry for entry, as [`assemble`] stores for them.
pub fn assemble_row_subset(
    problem: &Problem,
    kernel: &dyn StencilKernel,
    layout: &Layout,
    rows: &[usize],
) -> anyhow::Result<RowSet> {
    check_kernel(problem, kernel, layout)?;
    if let Some(&g) = rows.iter().find(|&&g| g >= layout.len()) {
        anyhow::bail!(
            "row {g} is outside the {} unknowns of the layout",
            layout.len()
        );
    }
    let (robin, marshak) = face_closures(problem, kernel, layout)?;
    let chunks: Vec<Chunk> = rows
        .par_chunks(CHUNK)
        .map(|c| {
            assemble_rows(
                problem,
                kernel,
                layout,
                marshak.as_ref(),
                robin.as_ref(),
                c.iter().copied(),
            )
        })
        .collect::<anyhow::Result<_>>()?;
    let mut set = RowSet {
        indptr: Vec::with_capacity(rows.len() + 1),
        ..RowSet::default()
    };
    set.indptr.push(0);
    for c in chunks {
        for k in c.row_nnz {
            let end = set.indptr[set.indptr.len() - 1] + k;
            set.indptr.push(end);
        }
        set.cols.extend(c.cols);
        set.vals.extend(c.vals);
        set.rhs.extend(c.rhs);
    }
    Ok(set)
}

/// The closures of the Marshak faces: the PDE's own conditions when the kernel states them
/// ([`RobinFaces`], ghost elimination), else P_N's face rows ([`MarshakRows`]); at most one
/// of the two is `Some`.
pub(crate) fn face_closures<'a>(
    problem: &Problem,
    kernel: &'a dyn StencilKernel,
    layout: &Layout,
) -> anyhow::Result<(Option<RobinFaces<'a>>, Option<MarshakRows>)> {
    let robin = RobinFaces::new(problem, layout, kernel)?;
    let marshak = if robin.is_some() {
        None
    } else {
        MarshakRows::new(problem, layout, DEFAULT_FACE_VALUE)?
    };
    if marshak.is_some() {
        crate::marshak::check_pn_structure(kernel)?;
    }
    Ok((robin, marshak))
}

/// Assembles the rows `rows` (storage indices, in the order given: the chunk's rows follow
/// it) into a [`Chunk`]; the rows on Marshak faces (when `marshak` is given) are the Marshak
/// conditions, and references across a Marshak face closed by the PDE's own conditions
/// (when `robin` is given) are their ghost values.
pub(crate) fn assemble_rows(
    problem: &Problem,
    kernel: &dyn StencilKernel,
    layout: &Layout,
    marshak: Option<&MarshakRows>,
    robin: Option<&RobinFaces<'_>>,
    rows: impl ExactSizeIterator<Item = usize>,
) -> anyhow::Result<Chunk> {
    let len = rows.len();
    let mut out = Chunk {
        row_nnz: Vec::with_capacity(len),
        cols: Vec::with_capacity(len * 8),
        vals: Vec::with_capacity(len * 8),
        rhs: Vec::with_capacity(len),
    };
    let mut weights = Vec::new();
    let mut entries: Vec<(usize, f64)> = Vec::new();
    let mut ctx = RowContext::new(problem, [0; 3]);
    for g in rows {
        let (q, idx) = layout.locate(g);
        if let Some((m, face)) = marshak.and_then(|m| Some((m, m.face_of(q, idx)?))) {
            entries.clear();
            m.row(layout, q, idx, face, &mut entries);
            entries.sort_unstable_by_key(|e| e.0);
            out.row_nnz.push(entries.len());
            out.cols.extend(entries.iter().map(|e| e.0));
            out.vals.extend(entries.iter().map(|e| e.1));
            out.rhs.push(0.0);
            continue;
        }
        let pos = layout.half_coord(q, idx);
        ctx.set_row(pos);
        let pattern = kernel.pattern(q);
        weights.clear();
        weights.resize(pattern.len(), 0.0);
        let rhs = kernel.eval_row(q, &ctx, &mut weights);
        if let Some(err) = ctx.take_error() {
            return Err(err).context("invalid scene coefficients");
        }
        anyhow::ensure!(
            rhs.is_finite() && weights.iter().all(|w| w.is_finite()),
            "non-finite stencil weight in row of moment ({},{}) at {:?}",
            layout.moments[q].l,
            layout.moments[q].m,
            ctx.point([0; 3])
        );
        entries.clear();
        for (t, &w) in pattern.iter().zip(&weights) {
            let half = [0, 1, 2].map(|d| pos[d] + t.offset[d] as i64);
            if let Some(r) = robin {
                if let Some(face) = r.crossing(layout, t.moment, half) {
                    r.ghost(problem, layout, t.moment, half, face, w, &mut entries)?;
                    continue;
                }
            }
            if let Some(col) = layout.resolve(t.moment, half, problem.boundary) {
                entries.push((col, w));
            }
        }
        entries.sort_unstable_by_key(|e| e.0);
        let start = out.cols.len();
        for &(col, w) in &entries {
            // Entries are sorted by column: a repeat of this row's last column adds to it.
            match (out.cols[start..].last(), out.vals[start..].last_mut()) {
                (Some(&last), Some(v)) if last == col => *v += w,
                _ => {
                    out.cols.push(col);
                    out.vals.push(w);
                }
            }
        }
        // Drop exact zeros (e.g. a difference whose two ends were clamped to one unknown).
        let mut k = start;
        for j in start..out.cols.len() {
            if out.vals[j] != 0.0 || out.cols[j] == g {
                out.cols[k] = out.cols[j];
                out.vals[k] = out.vals[j];
                k += 1;
            }
        }
        out.cols.truncate(k);
        out.vals.truncate(k);
        out.row_nnz.push(k - start);
        out.rhs.push(rhs);
    }
    Ok(out)
}
