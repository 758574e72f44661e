//! Rendering of derived equations: LaTeX (expanded system, general form, derivation
//! steps) and the JSON term list of `pn equations --json`.

use cas::print::latex::latex;
use cas::Expr;
use serde_json::{json, Value};

use super::general::GeneralEquation;
use super::pipeline::Step;
use super::terms::{factor_text, TermKind};
use super::{axis_name, PnEquation, PnSystem};

/// Preamble of a standalone document (only `amsmath`, so `texlive-latex-base` suffices).
pub const PREAMBLE: &str = "\\documentclass[10pt]{article}\n\\usepackage[margin=2cm]{geometry}\n\\usepackage{amsmath}\n\\allowdisplaybreaks\n";

/// Wraps a body into a complete document.
pub fn standalone(title: &str, body: &str) -> String {
    format!(
        "{PREAMBLE}\\title{{{title}}}\n\\date{{}}\n\\begin{{document}}\n\\maketitle\n{body}\\end{{document}}\n"
    )
}

/// `lhs = rhs` in an `align*` block, breaking the top-level sum of `lhs` every
/// `per_line` terms.
pub fn equation_block(lhs: &Expr, rhs: &Expr, per_line: usize) -> String {
    let terms: Vec<Expr> = match lhs {
        Expr::Add(ts) => ts.clone(),
        t => vec![t.clone()],
    };
    let mut lines: Vec<String> = Vec::new();
    for chunk in terms.chunks(per_line.max(1)) {
        let s = latex(&Expr::Add(chunk.to_vec()));
        let s = if lines.is_empty() {
            s
        } else if let Some(rest) = s.strip_prefix('-') {
            format!("\\quad - {rest}")
        } else {
            format!("\\quad + {s}")
        };
        lines.push(s);
    }
    let n = lines.len();
    let mut out = String::from("\\begin{align*}\n");
    for (k, line) in lines.iter().enumerate() {
        out.push_str("  & ");
        out.push_str(line);
        if k + 1 == n {
            out.push_str(&format!(" = {}\n", latex(rhs)));
        } else {
            out.push_str(" \\\\\n");
        }
    }
    out.push_str("\\end{align*}\n");
    out
}

/// The expanded system as LaTeX (one `align*` per equation).
pub fn system_latex(sys: &PnSystem) -> String {
    let mut out = format!(
        "% Real P_{0} equations ({1} moments), derived by pn-codegen (docs/design.md section 2).\n",
        sys.order,
        sys.equations.len()
    );
    for eq in &sys.equations {
        out.push_str(&format!("% (l, m) = ({}, {})\n", eq.l, eq.m));
        out.push_str(&equation_block(&eq.lhs, &eq.rhs, 4));
    }
    out
}

/// The general equations as LaTeX, one block per case.
pub fn general_latex(eqs: &[GeneralEquation]) -> String {
    let mut out = String::from(
        "% General real P_N equations for symbolic (l, m), derived by pn-codegen.\n\
         % Moments L_{l'}^{m'} with l' > N, l' < 0 or |m'| > l' are zero (P_N closure).\n",
    );
    for g in eqs {
        out.push_str(&format!("\\paragraph{{Case ${}$.}}\n", g.case.latex()));
        out.push_str(&equation_block(&g.lhs, &g.rhs, 2));
    }
    out.push_str(&coefficient_definitions());
    out
}

/// The closed forms of `a_{l,m}` … `f_{l,m}` (printed from the trees the passes use).
#[expect(
    clippy::expect_used,
    reason = "names lists exactly the six coefficients a…f that coefficient_definition knows"
)]
pub fn coefficient_definitions() -> String {
    let (l, m) = (Expr::index("l"), Expr::index("m"));
    let mut out = String::from("with\n\\begin{align*}\n");
    let names = ["a", "b", "c", "d", "e", "f"];
    for (k, n) in names.iter().enumerate() {
        let def = cas::passes::fold::fold(
            &cas::passes::sh_recursion::coefficient_definition(n, &l, &m).expect("known name"),
        );
        let f = Expr::Func((*n).into(), vec![l.clone(), m.clone()]);
        out.push_str(&format!("  {} &= {}", latex(&f), latex(&def)));
        out.push_str(if k + 1 < names.len() { " \\\\\n" } else { "\n" });
    }
    out.push_str("\\end{align*}\n");
    out
}

/// The recorded steps of a derivation as LaTeX.
pub fn steps_latex(steps: &[Step]) -> String {
    let mut out = String::new();
    for (k, s) in steps.iter().enumerate() {
        out.push_str(&format!(
            "\\paragraph{{Step {}: {}.}} {}\n",
            k + 1,
            s.title,
            s.description
        ));
        out.push_str(&equation_block(&s.lhs, &s.rhs, 1));
    }
    out
}

/// JSON of one equation: `{"l", "m", "terms": [...]}`, terms summing to zero (the source
/// enters with coefficient −1).
pub fn equation_json(eq: &PnEquation) -> Value {
    let terms: Vec<Value> = eq
        .terms
        .iter()
        .map(|t| {
            let c = if t.kind == TermKind::Source {
                t.coefficient.neg()
            } else {
                t.coefficient
            };
            let mut v = json!({
                "kind": t.kind.as_str(),
                "l": t.l,
                "m": t.m,
                "coefficient": c.to_f64(),
                "exact": c.to_text(),
                "factor": factor_text(t),
            });
            if let Some(a) = t.axis {
                v["axis"] = json!(axis_name(a));
            }
            v
        })
        .collect();
    json!({ "l": eq.l, "m": eq.m, "terms": terms })
}

/// JSON of a system: a list of equations.
pub fn system_json(sys: &PnSystem) -> Value {
    Value::Array(sys.equations.iter().map(equation_json).collect())
}

/// Plain-text form of one equation (for `pn equations` without `--json`), e.g.
/// `(1, 1): 1/3*sqrt(3)*dx(L[0,0]) + sigma_t*L[1,1] - sigma_s*lambda_1*p_1*L[1,1] = Q[1,1]`.
pub fn equation_text(eq: &PnEquation) -> String {
    let mut out = format!("({}, {}): ", eq.l, eq.m);
    for (k, t) in eq
        .terms
        .iter()
        .filter(|t| t.kind != TermKind::Source)
        .enumerate()
    {
        let what = match t.axis {
            Some(a) => format!("d{}(L[{},{}])", axis_name(a), t.l, t.m),
            None => format!("{}*L[{},{}]", factor_text(t), t.l, t.m),
        };
        let (neg, c) = if t.coefficient.is_negative() {
            (true, t.coefficient.neg())
        } else {
            (false, t.coefficient)
        };
        let sep = match (k, neg) {
            (0, false) => "",
            (0, true) => "-",
            (_, false) => " + ",
            (_, true) => " - ",
        };
        out.push_str(sep);
        if !c.is_one() {
            out.push_str(&format!("{}*", c.to_text()));
        }
        out.push_str(&what);
    }
    out.push_str(&format!(" = Q[{},{}]", eq.l, eq.m));
    out
}
