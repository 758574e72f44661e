//! `pn stencil`: prints a discretized stencil (placement of every unknown, and every row's
//! terms with their offsets and weight expressions), readably or as JSON.
//!
//! Offsets are in half cells: 0 = cell centre, 1 = shifted half a cell toward +axis.
use anyhow::Context;
use pn_codegen::discretize;
use pn_stencil::marshak::{marshak_closure, MarshakClosure};
use pn_stencil::{Dim, StencilIr};
use serde_json::json;
use std::io::Write;

use pn_kernels::Staggering;

/// Which stencil `pn stencil` prints, and how.
#[derive(Clone, Debug, PartialEq, Eq)]
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
    /// Also print the Marshak vacuum conditions of every axis, derived from the half-range
    /// Gram matrix ([`pn_stencil::marshak`]; staggered P_N with odd N).
    pub marshak: bool,
    /// A PDE text file (docs/pde-text.md) instead of P_N.
    pub pde: Option<std::path::PathBuf>,
    /// `NAME=VALUE` overrides of the PDE file's `param`s.
    pub pde_params: Vec<(String, String)>,
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
            marshak: false,
            pde: None,
            pde_params: Vec::new(),
        }
    }
}

/// The IR selected by the arguments.
fn build_ir(args: &StencilRequest) -> anyhow::Result<StencilIr> {
    let dim = args.dim;
    if let Some(path) = &args.pde {
        let pde = crate::pde_text::load(path, &args.pde_params)?;
        return pde
            .ir(dim)
            .map_err(|e| anyhow::anyhow!("{}: {e}", path.display()));
    }
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

/// The Marshak closures of every axis of `ir` (docs/design.md §3, "Domain and boundary").
fn marshak_closures(ir: &StencilIr) -> anyhow::Result<Vec<MarshakClosure>> {
    let order = ir.moments.iter().map(|m| m.l).max().unwrap_or(0);
    anyhow::ensure!(
        ir.moments.len() > 1 && order % 2 == 1,
        "--marshak needs a staggered P_N stencil of odd order (got {} with N = {order})",
        ir.name
    );
    (0..ir.dim.axes())
        .map(|d| marshak_closure(&ir.moments, d).map_err(|e| anyhow::anyhow!("{e}")))
        .collect()
}

/// The Marshak conditions as JSON: per axis, `{axis, conditions: [{moment, l, m, terms:
/// [{moment, l, m, coefficient}]}]}` for the min face (the max face negates every coefficient).
fn marshak_json(ir: &StencilIr, closures: &[MarshakClosure]) -> serde_json::Value {
    let axes: Vec<_> = closures
        .iter()
        .map(|c| {
            let conds: Vec<_> = c
                .conditions
                .iter()
                .flatten()
                .map(|cond| {
                    let p = &ir.moments[cond.moment];
                    let terms: Vec<_> = cond
                        .terms
                        .iter()
                        .map(|&(e, v)| {
                            let q = &ir.moments[e];
                            json!({"moment": e, "l": q.l, "m": q.m, "coefficient": v})
                        })
                        .collect();
                    json!({"moment": cond.moment, "l": p.l, "m": p.m, "terms": terms})
                })
                .collect();
            let axis = ["x", "y", "z"][c.axis];
            json!({"axis": axis, "conditions": conds})
        })
        .collect();
    json!(axes)
}

/// The Marshak conditions, readable.
fn marshak_text(ir: &StencilIr, closures: &[MarshakClosure]) -> String {
    use std::fmt::Write;
    let mut s = String::from(
        "\nMarshak vacuum conditions on the min face of each axis (the max face negates every \
         coefficient; the even moments are those half a cell inside, extrapolated to the face):\n",
    );
    for c in closures {
        let _ = writeln!(
            s,
            "  axis {}: {} conditions",
            ["x", "y", "z"][c.axis],
            c.count()
        );
        for cond in c.conditions.iter().flatten() {
            let mut line = moment_name(ir, cond.moment);
            for &(e, v) in &cond.terms {
                let sign = if v < 0.0 { '-' } else { '+' };
                let _ = write!(line, " {sign} {:.12} {}", v.abs(), moment_name(ir, e));
            }
            let _ = writeln!(s, "    {line} = 0");
        }
    }
    s
}

/// A text PDE's `boundary marshak` conditions, readable: one line per condition, the
/// coefficients as weight expressions at the face point.
fn boundary_text(ir: &StencilIr, b: &pn_stencil::RobinBoundary) -> String {
    use std::fmt::Write;
    let mut s = format!(
        "\nboundary {} conditions (the PDE's own; dn = outward normal derivative, fields at \
         the face point, face values extrapolated from the two nearest centres):\n",
        b.kind
    );
    for c in &b.conditions {
        let terms: Vec<String> = c
            .value
            .iter()
            .map(|(q, w)| format!("({w})*{}", moment_name(ir, *q)))
            .chain(
                c.normal
                    .iter()
                    .map(|(q, w)| format!("({w})*dn({})", moment_name(ir, *q))),
            )
            .collect();
        let _ = writeln!(
            s,
            "  at {}: {} = 0",
            moment_name(ir, c.target),
            terms.join(" + ")
        );
    }
    s
}

/// The JSON form of a text PDE's boundary conditions.
fn boundary_json(ir: &StencilIr, b: &pn_stencil::RobinBoundary) -> serde_json::Value {
    let terms = |ts: &[(usize, pn_stencil::Weight)]| -> Vec<serde_json::Value> {
        ts.iter()
            .map(
                |(q, w)| json!({"moment": q, "name": moment_name(ir, *q), "weight": w.to_string()}),
            )
            .collect()
    };
    json!({
        "kind": b.kind,
        "conditions": b.conditions.iter().map(|c| json!({
            "target": c.target,
            "value": terms(&c.value),
            "normal_derivative": terms(&c.normal),
        })).collect::<Vec<_>>(),
    })
}

/// Runs `pn stencil`, printing to `stdout`.
pub fn run(args: &StencilRequest, stdout: &mut dyn Write) -> anyhow::Result<()> {
    let ir = build_ir(args)?;
    let boundary = match &args.pde {
        Some(path) => crate::pde_text::load(path, &args.pde_params)?
            .boundary(args.dim, "marshak")
            .map_err(|e| anyhow::anyhow!("{}: {e}", path.display()))?,
        None => None,
    };
    // A PDE that states its Marshak conditions prints those; P_N prints the derived ones.
    let closures = if args.marshak && boundary.is_none() {
        Some(marshak_closures(&ir)?)
    } else {
        None
    };
    if args.json {
        let mut v = to_json(&ir);
        if let (Some(c), Some(obj)) = (&closures, v.as_object_mut()) {
            obj.insert("marshak".into(), marshak_json(&ir, c));
        }
        if let (Some(b), Some(obj)) = (&boundary, v.as_object_mut()) {
            obj.insert("boundary".into(), boundary_json(&ir, b));
        }
        writeln!(stdout, "{}", serde_json::to_string_pretty(&v)?)?;
    } else {
        if let Some(path) = &args.pde {
            let pde = crate::pde_text::load(path, &args.pde_params)?;
            writeln!(
                stdout,
                "PDE {} from {}: unknowns {}",
                pde.system.name,
                path.display(),
                crate::pde_text::describe_unknowns(&pde)
            )?;
        }
        write!(stdout, "{}", to_text(&ir))?;
        if let Some(c) = &closures {
            write!(stdout, "{}", marshak_text(&ir, c))?;
        }
        if let Some(b) = &boundary {
            write!(stdout, "{}", boundary_text(&ir, b))?;
        }
    }
    Ok(())
}
