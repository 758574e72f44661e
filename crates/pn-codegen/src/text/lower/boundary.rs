//! Boundary conditions: each `boundary` statement lowered and split into its linear parts
//! `Σ a_j u_j + Σ b_k dn(u_k) = 0`, square per kind (one condition per unknown).

use cas::Expr;

use super::eval::const_value;
use super::{Lowerer, BOUNDARY_KINDS};
use crate::text::{PdeTextError, TextBoundary, TextUnknown};

impl Lowerer {
    /// Lowers the `boundary` statements: one linear condition per (kind, unknown), every
    /// unknown closed once a kind has conditions at all (they are square, like the system).
    pub(super) fn lower_boundaries(
        &self,
        unknowns: &[TextUnknown],
    ) -> Result<Vec<TextBoundary>, PdeTextError> {
        let mut out: Vec<TextBoundary> = Vec::new();
        for pb in &self.boundaries {
            let target = self.label_of(&pb.target, pb.target_pos)?;
            if !unknowns.iter().any(|u| u.label == target) {
                return Err(PdeTextError::at(
                    pb.target_pos,
                    format!(
                        "{} was eliminated: it has no boundary condition",
                        self.name_of(target)
                    ),
                ));
            }
            if let Some(b) = out.iter().find(|b| b.kind == pb.kind && b.target == target) {
                return Err(PdeTextError::at(
                    pb.pos,
                    format!(
                        "a second `boundary {}` condition for {} (the first is on line {})",
                        pb.kind,
                        self.name_of(target),
                        b.pos.line
                    ),
                ));
            }
            let lhs = self.scalar(&pb.lhs, &pb.scope, 0)?;
            let rhs = self.scalar(&pb.rhs, &pb.scope, 0)?;
            let form = split_boundary(&Expr::add(vec![lhs, rhs.neg()]), false)
                .map_err(|m| PdeTextError::at(pb.pos, m))?;
            if form.rest.iter().any(|e| const_value(e) != Some(0.0)) {
                return Err(PdeTextError::at(
                    pb.pos,
                    "a boundary condition must be homogeneous (every term a coefficient times an \
                     unknown or dn(unknown), = 0): it has a term without an unknown",
                ));
            }
            if form.normal.is_empty() {
                return Err(PdeTextError::at(
                    pb.pos,
                    "a boundary condition needs a normal derivative dn(…) of an unknown (it \
                     closes the flux across the face)",
                ));
            }
            out.push(TextBoundary {
                kind: pb.kind.clone(),
                target,
                value: form.value,
                normal: form.normal,
                pos: pb.pos,
            });
        }
        for kind in BOUNDARY_KINDS {
            let Some(first) = out.iter().find(|b| b.kind == kind) else {
                continue;
            };
            for u in unknowns {
                if !out.iter().any(|b| b.kind == kind && b.target == u.label) {
                    return Err(PdeTextError::at(
                        u.pos,
                        format!(
                            "unknown {} has no `boundary {kind}` condition (line {} states one; \
                             the conditions must be square: one per unknown)",
                            u.name, first.pos.line
                        ),
                    ));
                }
            }
        }
        Ok(out)
    }
}

/// A boundary expression split into `Σ value_j u_j + Σ normal_k dn(u_k) + Σ rest`.
#[derive(Default)]
struct BoundaryForm {
    value: Vec<((i64, i64), Expr)>,
    normal: Vec<((i64, i64), Expr)>,
    rest: Vec<Expr>,
}

impl BoundaryForm {
    fn add(mut self, o: BoundaryForm) -> BoundaryForm {
        self.value.extend(o.value);
        self.normal.extend(o.normal);
        self.rest.extend(o.rest);
        self
    }
    fn scale(self, c: &Expr) -> BoundaryForm {
        let sc = |v: Vec<((i64, i64), Expr)>| {
            v.into_iter()
                .map(|(lm, e)| (lm, Expr::mul(vec![c.clone(), e])))
                .collect()
        };
        BoundaryForm {
            value: sc(self.value),
            normal: sc(self.normal),
            rest: self
                .rest
                .into_iter()
                .map(|e| Expr::mul(vec![c.clone(), e]))
                .collect(),
        }
    }
}

/// Whether `e` mentions an unknown or `dn`.
fn mentions_unknown(e: &Expr) -> bool {
    e.any(&|x| crate::pde::as_unknown(x).is_some() || matches!(x, Expr::Func(f, _) if f == "dn"))
}

/// Splits a lowered boundary expression into its linear parts (coefficients are left as
/// `cas` expressions); `in_dn`: inside `dn(…)`.
fn split_boundary(e: &Expr, in_dn: bool) -> Result<BoundaryForm, String> {
    if let Some(lm) = crate::pde::as_unknown(e) {
        let one = vec![(lm, Expr::int(1))];
        return Ok(if in_dn {
            BoundaryForm {
                normal: one,
                ..Default::default()
            }
        } else {
            BoundaryForm {
                value: one,
                ..Default::default()
            }
        });
    }
    if !mentions_unknown(e) {
        if e.any(&|x| matches!(x, Expr::Deriv(..))) {
            return Err(derivative_message());
        }
        if in_dn {
            return Err(
                "dn(…) applies to unknowns (the normal derivative of a coefficient \
                        is not part of a boundary condition)"
                    .into(),
            );
        }
        return Ok(BoundaryForm {
            rest: vec![e.clone()],
            ..Default::default()
        });
    }
    match e {
        Expr::Add(ts) => {
            let mut acc = BoundaryForm::default();
            for t in ts {
                acc = acc.add(split_boundary(t, in_dn)?);
            }
            Ok(acc)
        }
        Expr::Mul(fs) => {
            let mut linear: Option<BoundaryForm> = None;
            let mut coeff = Vec::new();
            for f in fs {
                if mentions_unknown(f) {
                    if linear.is_some() {
                        return Err(
                            "a product of unknowns (a boundary condition must be linear)".into(),
                        );
                    }
                    linear = Some(split_boundary(f, in_dn)?);
                } else {
                    if f.any(&|x| matches!(x, Expr::Deriv(..))) {
                        return Err(derivative_message());
                    }
                    coeff.push(f.clone());
                }
            }
            let linear = linear.unwrap_or_default();
            Ok(linear.scale(&Expr::mul(coeff)))
        }
        Expr::Func(f, args) if f == "dn" && args.len() == 1 => {
            if in_dn {
                return Err(
                    "dn(dn(…)): a boundary condition takes first normal derivatives only".into(),
                );
            }
            let inner = split_boundary(&args[0], true)?;
            if inner.normal.iter().any(|(_, c)| const_value(c).is_none()) {
                return Err(
                    "dn(…) takes unknowns with constant coefficients (dn(c*u) with a \
                            field c is not c*dn(u)); write the coefficient outside: c*dn(u)"
                        .into(),
                );
            }
            if !inner.rest.is_empty() {
                return Err(
                    "dn(…) applies to unknowns (the normal derivative of a coefficient \
                            is not part of a boundary condition)"
                        .into(),
                );
            }
            Ok(inner)
        }
        Expr::Deriv(..) => Err(derivative_message()),
        _ => Err(
            "an unknown inside a power or function (a boundary condition must be linear)".into(),
        ),
    }
}

fn derivative_message() -> String {
    "derivatives in a boundary condition are written dn(…), the outward normal derivative \
     (dx, dy, dz, grad, div and lap are not allowed there)"
        .into()
}
