//! `pn stencil`: prints a discretized stencil (placement of every unknown, and every row's
//! terms with their offsets and weight expressions), readably or as JSON.
//!
//! Offsets are in half cells: 0 = cell centre, 1 = shifted half a cell toward +axis.
use anyhow::Context;
use pn_codegen::discretize;
use pn_stencil::{Dim, StencilIr};
use serde_json::json;
use std::io::Write;

use pn_kernels::Staggering;

/// Which stencil `pn stencil` prints, and how.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct StencilRequest {
    /// P_N order.
    pub order: usize,
    /// Spatial dimension.
    pub dim: Dim,
    /// Every moment at the cell centre (unknowns interpolated) instead of staggered.
    pub collocated: bool,
    /// The classical-diffusion (CDA) stencil instead of P_N.
    pub cda: bool,
    /// The diffusion stencil with D as a field (FLD Picard steps) instead of P_N.
    pub diffusion: bool,
    /// JSON: `{"moments":[{"l","m","offset":[x,y,z]}], "rows":[…]}`.
    pub json: bool,
}

impl Default for StencilRequest {
    /// The staggered 3D P_1 stencil, readable.
    fn default() -> Self {
        Self {
            order: 1,
            dim: Dim::Three,
            collocated: false,
            cda: false,
            diffusion: false,
            json: false,
        }
    }
}

/// The IR selected by the arguments.
fn build_ir(args: &StencilRequest) -> anyhow::Result<StencilIr> {
    let dim = args.dim;
    if args.cda {
        return discretize::cda_ir(dim).context("building the CDA stencil");
    }
    if args.diffusion {
        return discretize::diffusion_ir(dim).context("building the diffusion stencil");
    }
    anyhow::ensure!(
        (1..=pn_kernels::MAX_ORDER).contains(&args.order),
        "--order {} is outside 1..={}",
        args.order,
        pn_kernels::MAX_ORDER
    );
    let layout = if args.collocated {
        Staggering::Collocated
    } else {
        Staggering::Staggered
    };
    discretize::pn_ir_for_order(args.order, dim, layout)
        .with_context(|| format!("building the P_{} stencil", args.order))
}

fn moment_name(ir: &StencilIr, q: usize) -> String {
    let p = &ir.moments[q];
    format!("L_{}^{}", p.l, p.m)
}

/// The JSON form of a stencil.
pub fn to_json(ir: &StencilIr) -> serde_json::Value {
    let moments: Vec<_> = ir
        .moments
        .iter()
        .map(|p| json!({"l": p.l, "m": p.m, "offset": p.shift}))
        .collect();
    let rows: Vec<_> = ir
        .rows
        .iter()
        .map(|row| {
            let p = &ir.moments[row.moment];
            let terms: Vec<_> = row
                .terms
                .iter()
                .map(|t| {
                    let q = &ir.moments[t.moment];
                    json!({
                        "moment": t.moment,
                        "l": q.l,
                        "m": q.m,
                        "offset": t.offset,
                        "weight": t.weight.to_string(),
                    })
                })
                .collect();
            let rhs: Vec<String> = row.rhs.iter().map(|w| w.to_string()).collect();
            json!({
                "moment": row.moment,
                "l": p.l,
                "m": p.m,
                "offset": p.shift,
                "terms": terms,
                "rhs": rhs,
            })
        })
        .collect();
    json!({
        "name": ir.name,
        "dim": ir.dim.axes(),
        "offset_units": "half cells; 0 = cell centre, 1 = shifted half a cell toward +axis",
        "moments": moments,
        "rows": rows,
    })
}

/// The readable form of a stencil.
pub fn to_text(ir: &StencilIr) -> String {
    use std::fmt::Write;
    let mut s = String::new();
    let _ = writeln!(
        s,
        "stencil {} ({}D, unknowns per cell: {})\n\
         offsets in half cells: 0 = cell centre, 1 = shifted half a cell toward +axis;\n\
         field[ox,oy,oz] is a field at that offset from the row's position\n",
        ir.name,
        ir.dim.axes(),
        ir.moments.len()
    );
    let _ = writeln!(s, "moments:");
    for (q, p) in ir.moments.iter().enumerate() {
        let _ = writeln!(
            s,
            "  {q:3}  {:10} offset [{},{},{}]",
            moment_name(ir, q),
            p.shift[0],
            p.shift[1],
            p.shift[2]
        );
    }
    let _ = writeln!(s, "\nrows:");
    for row in &ir.rows {
        let _ = writeln!(
            s,
            "  row {} ({}, {} terms):",
            row.moment,
            moment_name(ir, row.moment),
            row.terms.len()
        );
        for t in &row.terms {
            let o = t.offset;
            let _ = writeln!(
                s,
                "    {:10} [{:+},{:+},{:+}]  × {}",
                moment_name(ir, t.moment),
                o[0],
                o[1],
                o[2],
                t.weight
            );
        }
        let rhs: Vec<String> = row.rhs.iter().map(|w| w.to_string()).collect();
        let _ = writeln!(
            s,
            "    = {}",
            if rhs.is_empty() {
                "0".into()
            } else {
                rhs.join(" + ")
            }
        );
    }
    s
}

/// Runs `pn stencil`, printing to `stdout`.
pub fn run(args: &StencilRequest, stdout: &mut dyn Write) -> anyhow::Result<()> {
    let ir = build_ir(args)?;
    if args.json {
        writeln!(stdout, "{}", serde_json::to_string_pretty(&to_json(&ir))?)?;
    } else {
        write!(stdout, "{}", to_text(&ir))?;
    }
    Ok(())
}
