//! `pn stencil`: prints a discretized stencil (placement of every unknown, and every row's
//! terms with their offsets and weight expressions), readably or as JSON.
//!
//! Offsets are in half cells: 0 = cell centre, 1 = shifted half a cell toward +axis.
use anyhow::Context;
use clap::Args;
use pn_codegen::discretize;
use pn_stencil::{Dim, StencilIr};
use serde_json::json;

use pn_kernels::Staggering;

/// Arguments of `pn stencil`.
#[derive(Args, Debug)]
pub struct StencilArgs {
    /// P_N order.
    #[arg(long, default_value_t = 1)]
    pub order: usize,
    /// Spatial dimension (2 or 3).
    #[arg(long, default_value_t = 3, value_parser = clap::value_parser!(u8).range(2..=3))]
    pub dim: u8,
    /// Every moment at the cell centre (unknowns interpolated) instead of staggered.
    #[arg(long)]
    pub collocated: bool,
    /// The classical-diffusion (CDA) stencil instead of P_N.
    #[arg(long, conflicts_with_all = ["collocated", "diffusion"])]
    pub cda: bool,
    /// The diffusion stencil with D as a field (FLD Picard steps) instead of P_N.
    #[arg(long, conflicts_with = "collocated")]
    pub diffusion: bool,
    /// Print JSON: `{"moments":[{"l","m","offset":[x,y,z]}], "rows":[…]}`.
    #[arg(long)]
    pub json: bool,
}

/// The IR selected by the arguments.
fn build_ir(args: &StencilArgs) -> anyhow::Result<StencilIr> {
    let dim = if args.dim == 2 { Dim::Two } else { Dim::Three };
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

/// Runs `pn stencil`.
pub fn run(args: &StencilArgs) -> anyhow::Result<()> {
    let ir = build_ir(args)?;
    if args.json {
        println!("{}", serde_json::to_string_pretty(&to_json(&ir))?);
    } else {
        print!("{}", to_text(&ir));
    }
    Ok(())
}
