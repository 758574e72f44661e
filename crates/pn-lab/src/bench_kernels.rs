//! `pn bench`'s comparison of compiled and interpreted stencils (issue 19: "compiled kernels
//! for the orders users pick, or an interpreter within 1.5× of compiled speed").
//!
//! For every P_N order the build compiled (3D, staggered), the same stencil is also derived
//! and run through the interpreter ([`pn_stencil::InterpretedKernel`]), and both are timed on
//! the point source's problem in the same run:
//! * **eval**: [`StencilKernel::eval_row`] over every row of the layout on one thread (the
//!   kernel alone: weights and right-hand side from the scene's fields), median of
//!   [`EVAL_REPEATS`] passes;
//! * **assembly**: [`pn_runtime::assemble::assemble`] of the whole CSR system on all threads
//!   (the kernel plus the boundary closure, sorting and the CSR build), median of
//!   [`ASSEMBLE_REPEATS`].
//!
//! The ratio interpreted / compiled of each is what the issue asks about. Orders above the
//! compiled set are timed interpreted only (their rows say so), so the table also shows how
//! the interpreter's cost per term grows with N.

use anyhow::Context;
use pn_codegen::discretize::{pn_ir_for_order, pn_name};
use pn_formats::Table;
use pn_kernels::{compiled, Dim, Staggering};
use pn_runtime::assemble::assemble;
use pn_runtime::problem::Problem;
use pn_runtime::scenes::{builtin, BuiltinOptions};
use pn_runtime::Layout;
use pn_runtime::RowContext;
use pn_stencil::{InterpretedKernel, StencilKernel, TreeWalk};
use std::time::Instant;

/// Passes over all rows per eval timing (the median is reported).
pub const EVAL_REPEATS: usize = 5;
/// Assemblies per assembly timing (the median is reported).
pub const ASSEMBLE_REPEATS: usize = 3;

/// Columns of `kernels.csv`.
pub const CSV_HEADER: &str = "stencil,order,kind,resolution,rows,terms,eval_ns_per_row,eval_ns_per_term,assemble_seconds,eval_ratio_to_compiled,assemble_ratio_to_compiled";

/// One timed stencil.
#[derive(Clone, Debug)]
pub struct KernelRow {
    /// Stencil name (`p5_3d_staggered`).
    pub stencil: String,
    /// P_N order.
    pub order: usize,
    /// `compiled`, `interpreted` (flat row programs) or `tree-walk` (the former interpreter).
    pub kind: &'static str,
    /// Cells per axis of the point-source grid.
    pub resolution: usize,
    /// Rows of the system.
    pub rows: usize,
    /// Stencil terms over all rows (the non-zeros before the boundary closure).
    pub terms: usize,
    /// Median time of `eval_row` per row, one thread, ns.
    pub eval_ns_per_row: f64,
    /// Median assembly time, all threads, s.
    pub assemble_seconds: f64,
    /// Interpreted / compiled eval time of the same stencil (1 for the compiled row; empty
    /// where nothing was compiled).
    pub eval_ratio: Option<f64>,
    /// The same for the assembly.
    pub assemble_ratio: Option<f64>,
}

impl KernelRow {
    fn csv(&self) -> String {
        self.cells().join(",")
    }

    /// The cells of [`KernelRow::csv`], one per column of [`CSV_HEADER`].
    fn cells(&self) -> Vec<String> {
        let opt = |v: Option<f64>| v.map(|x| format!("{x:.3}")).unwrap_or_default();
        vec![
            self.stencil.clone(),
            self.order.to_string(),
            self.kind.to_string(),
            self.resolution.to_string(),
            self.rows.to_string(),
            self.terms.to_string(),
            format!("{:.1}", self.eval_ns_per_row),
            format!(
                "{:.2}",
                self.eval_ns_per_row * self.rows as f64 / self.terms.max(1) as f64
            ),
            format!("{:.4}", self.assemble_seconds),
            opt(self.eval_ratio),
            opt(self.assemble_ratio),
        ]
    }
}

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

/// Median seconds of one `eval_row` pass over all rows of `layout` on this thread, and the
/// number of terms evaluated per pass. Fails on invalid coefficients like assembly does.
fn time_eval(
    problem: &Problem,
    kernel: &dyn StencilKernel,
    layout: &Layout,
) -> anyhow::Result<(f64, usize)> {
    let mut weights = Vec::new();
    let mut ctx = RowContext::new(problem, [0; 3]);
    let mut times = Vec::with_capacity(EVAL_REPEATS);
    let mut terms = 0;
    let mut sink = 0.0;
    for _ in 0..EVAL_REPEATS {
        terms = 0;
        let t = Instant::now();
        for g in 0..layout.len() {
            let (q, idx) = layout.locate(g);
            ctx.set_row(layout.half_coord(q, idx));
            let n = kernel.pattern(q).len();
            weights.clear();
            weights.resize(n, 0.0);
            sink += kernel.eval_row(q, &ctx, &mut weights);
            sink += weights.first().copied().unwrap_or(0.0);
            terms += n;
        }
        times.push(t.elapsed().as_secs_f64());
        if let Some(err) = ctx.take_error() {
            return Err(err).context("invalid scene coefficients");
        }
    }
    // Keep the sums observable so the passes are not optimised away.
    anyhow::ensure!(sink.is_finite(), "non-finite stencil weights");
    Ok((median(times), terms))
}

fn time_assembly(
    problem: &Problem,
    kernel: &dyn StencilKernel,
    layout: &Layout,
) -> anyhow::Result<f64> {
    let mut times = Vec::with_capacity(ASSEMBLE_REPEATS);
    for _ in 0..ASSEMBLE_REPEATS {
        let t = Instant::now();
        let sys = assemble(problem, kernel, layout)?;
        times.push(t.elapsed().as_secs_f64());
        drop(sys);
    }
    Ok(median(times))
}

/// Times the 3D staggered P_N stencils of `orders` on the point source at `res`³: compiled
/// and interpreted where the build compiled the order, interpreted only otherwise.
pub fn kernel_rows(orders: &[usize], res: usize) -> anyhow::Result<Vec<KernelRow>> {
    let opts = BuiltinOptions {
        res: Some(vec![res]),
        ..Default::default()
    };
    let scene = builtin("pointsource", &opts)?;
    let problem = &scene.problem;
    let mut out = vec![];
    for &order in orders {
        let name = pn_name(order, Dim::Three, Staggering::Staggered);
        let ir = pn_ir_for_order(order, Dim::Three, Staggering::Staggered)
            .with_context(|| format!("deriving the P_{order} stencil"))?;
        let interpreted = InterpretedKernel::new(ir);
        let layout = Layout::new(&problem.grid, interpreted.moments())?;
        let mut compiled_times = None;
        if let Some(k) = compiled::find(&name) {
            let (eval, terms) = time_eval(problem, k, &layout)?;
            let asm = time_assembly(problem, k, &layout)?;
            compiled_times = Some((eval, asm));
            out.push(KernelRow {
                stencil: name.clone(),
                order,
                kind: "compiled",
                resolution: res,
                rows: layout.len(),
                terms,
                eval_ns_per_row: eval * 1e9 / layout.len() as f64,
                assemble_seconds: asm,
                eval_ratio: Some(1.0),
                assemble_ratio: Some(1.0),
            });
            eprintln!(
                "bench: kernels {}",
                out.last().map(|r| r.csv()).unwrap_or_default()
            );
        }
        let tree = TreeWalk(&interpreted);
        let kinds: [(&'static str, &dyn StencilKernel); 2] =
            [("interpreted", &interpreted), ("tree-walk", &tree)];
        for (kind, kernel) in kinds {
            let (eval, terms) = time_eval(problem, kernel, &layout)?;
            let asm = time_assembly(problem, kernel, &layout)?;
            out.push(KernelRow {
                stencil: name.clone(),
                order,
                kind,
                resolution: res,
                rows: layout.len(),
                terms,
                eval_ns_per_row: eval * 1e9 / layout.len() as f64,
                assemble_seconds: asm,
                eval_ratio: compiled_times.map(|(e, _)| eval / e),
                assemble_ratio: compiled_times.map(|(_, a)| asm / a),
            });
            eprintln!(
                "bench: kernels {}",
                out.last().map(|r| r.csv()).unwrap_or_default()
            );
        }
    }
    Ok(out)
}

/// The table of `kernels.csv`.
pub fn table(rows: &[KernelRow]) -> anyhow::Result<Table> {
    let mut t = Table::new(&CSV_HEADER.split(',').collect::<Vec<_>>());
    for r in rows {
        t.push_row(r.cells())?;
    }
    Ok(t)
}

/// The Markdown section.
pub fn markdown(rows: &[KernelRow]) -> anyhow::Result<String> {
    let mut md = String::from("\n## Compiled against interpreted stencils\n\n");
    md.push_str(
        "The 3D staggered P_N stencil on the point source's grid, generated code (`build.rs`, \
         the orders in `PN_ORDERS`) against the same derivation run by the interpreter, in \
         this run, and the interpreter's former tree walk (`tree-walk`). *eval*: `eval_row` over all rows on one thread (median of 5 passes); \
         *assembly*: the whole CSR system on all threads (median of 3). Ratios are \
         interpreted / compiled; orders not compiled in have no ratio.\n\n",
    );
    let mut t = Table::new(&[
        "stencil",
        "kind",
        "resolution",
        "rows",
        "ns / row",
        "ns / term",
        "eval ratio",
        "assembly s",
        "assembly ratio",
    ]);
    for r in rows {
        let opt = |v: Option<f64>| v.map(|x| format!("{x:.2}")).unwrap_or_else(|| "–".into());
        t.push_row([
            r.stencil.clone(),
            r.kind.to_string(),
            format!("{}³", r.resolution),
            r.rows.to_string(),
            format!("{:.0}", r.eval_ns_per_row),
            format!(
                "{:.1}",
                r.eval_ns_per_row * r.rows as f64 / r.terms.max(1) as f64
            ),
            opt(r.eval_ratio),
            format!("{:.3}", r.assemble_seconds),
            opt(r.assemble_ratio),
        ])?;
    }
    md += &t.to_markdown();
    Ok(md)
}
