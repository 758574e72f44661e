//! The system from the statements: the unknowns labelled (the P_N ones at the include,
//! auxiliary ones beyond the highest radiance band), the equations and `add` terms lowered,
//! the eliminations solved and substituted, the boundary conditions attached.

use cas::Expr;

use super::eval::const_value;
use super::{Lowerer, ResolvedTarget};
use crate::pde::{PdeEquation, PdeSystem};
use crate::text::lex::Pos;
use crate::text::{PdeTextError, TextPde, TextUnknown};
use pn_stencil::Dim;

impl Lowerer {
    /// Labels the unknowns, lowers the equations and assembles the system.
    pub(super) fn finish(mut self) -> Result<TextPde, PdeTextError> {
        let mut unknowns = self.label_unknowns()?;
        let mut eqs = self.equations()?;
        self.eliminate(&mut eqs, &mut unknowns)?;
        let boundaries = self.lower_boundaries(&unknowns)?;
        // Systems order equations like their unknowns.
        let mut ordered = Vec::with_capacity(eqs.len());
        for u in &unknowns {
            if let Some(i) = eqs.iter().position(|(e, _)| (e.l, e.m) == u.label) {
                ordered.push(eqs.swap_remove(i));
            }
        }
        let params = self
            .params
            .iter()
            .map(|(n, e)| (n.clone(), const_value(e).unwrap_or(f64::NAN)))
            .collect();
        Ok(TextPde {
            system: PdeSystem {
                name: self.name.clone().unwrap_or_else(|| "user".into()),
                dim: Dim::Three,
                unknowns: unknowns.iter().map(|u| u.label).collect(),
                equations: ordered.iter().map(|(e, _)| e.clone()).collect(),
            },
            equation_pos: ordered.iter().map(|(_, p)| *p).collect(),
            unknowns,
            params,
            boundaries,
        })
    }

    /// The unknowns in declaration order, the P_N ones at the include, each with its label
    /// (auxiliary ones get free labels); fills `labels`.
    fn label_unknowns(&mut self) -> Result<Vec<TextUnknown>, PdeTextError> {
        // Unknowns in declaration order, the P_N ones at the include.
        let mut unknowns: Vec<TextUnknown> = Vec::new();
        let pn_unknowns: Vec<TextUnknown> = self
            .pn
            .as_ref()
            .map(|(sys, pos)| {
                sys.equations
                    .iter()
                    .map(|e| TextUnknown {
                        name: format!("L({}, {})", e.l, e.m),
                        label: (e.l, e.m),
                        radiance: true,
                        at: None,
                        pos: *pos,
                    })
                    .collect()
            })
            .unwrap_or_default();
        for (i, d) in self.decls.iter().enumerate() {
            if i == self.pn_at {
                unknowns.extend(pn_unknowns.iter().cloned());
            }
            if let Some(lm) = d.moment {
                if let Some(u) = unknowns.iter().find(|u| u.label == lm) {
                    return Err(PdeTextError::at(
                        d.pos,
                        format!(
                            "{} and {} both stand for L({}, {})",
                            d.name, u.name, lm.0, lm.1
                        ),
                    ));
                }
            }
            unknowns.push(TextUnknown {
                name: d.name.clone(),
                label: d.moment.unwrap_or((-1, 0)),
                radiance: d.moment.is_some(),
                at: d.at,
                pos: d.pos,
            });
        }
        if self.pn_at >= self.decls.len() {
            unknowns.extend(pn_unknowns.iter().cloned());
        }
        for u in &unknowns {
            if u.radiance {
                if let Some(d) = self
                    .decls
                    .iter()
                    .find(|d| d.moment == Some(u.label) && d.name != u.name)
                {
                    return Err(PdeTextError::at(
                        d.pos,
                        format!(
                            "{} stands for {}, which include pn already declares",
                            d.name, u.name
                        ),
                    ));
                }
            }
        }
        // Auxiliary labels: beyond the highest radiance band, l+m even (kept in 2D).
        let lmax = unknowns
            .iter()
            .filter(|u| u.radiance)
            .map(|u| u.label.0)
            .max()
            .unwrap_or(-1);
        let mut free = (lmax + 1..)
            .flat_map(|l| (-l..=l).map(move |m| (l, m)))
            .filter(|(l, m)| (l + m) % 2 == 0);
        for u in unknowns.iter_mut().filter(|u| !u.radiance) {
            u.label = free.next().unwrap_or((0, 0));
        }
        self.labels = unknowns.iter().map(|u| (u.name.clone(), u.label)).collect();
        Ok(unknowns)
    }

    /// Resolves a statement's target to its unknown's label (errors at `pos`).
    pub(super) fn label_of(
        &self,
        t: &ResolvedTarget,
        pos: Pos,
    ) -> Result<(i64, i64), PdeTextError> {
        match t {
            ResolvedTarget::Name(n) => self.labels.get(n).copied().ok_or_else(|| {
                PdeTextError::at(
                    pos,
                    format!("'{n}' is not an unknown (declare it with `unknown {n}`)"),
                )
            }),
            ResolvedTarget::Label(l, m) => {
                if self.labels.values().any(|&lm| lm == (*l, *m)) {
                    Ok((*l, *m))
                } else {
                    Err(PdeTextError::at(
                        pos,
                        format!("L({l}, {m}) is not an unknown of the system"),
                    ))
                }
            }
        }
    }

    /// The equations, the derived P_N ones and then the written ones, with the `add` terms
    /// added to their left-hand sides.
    fn equations(&self) -> Result<Vec<(PdeEquation, Pos)>, PdeTextError> {
        // Equations: the derived P_N ones, then the written ones.
        let mut eqs: Vec<(PdeEquation, Pos)> = Vec::new();
        if let Some((sys, pos)) = &self.pn {
            for e in &sys.equations {
                eqs.push((
                    PdeEquation {
                        l: e.l,
                        m: e.m,
                        lhs: e.lhs.clone(),
                        rhs: e.rhs.clone(),
                    },
                    *pos,
                ));
            }
        }
        for pe in &self.equations {
            let (l, m) = self.label_of(&pe.target, pe.pos)?;
            if let Some((_, p)) = eqs.iter().find(|(e, _)| (e.l, e.m) == (l, m)) {
                return Err(PdeTextError::at(
                    pe.pos,
                    format!(
                        "a second equation located at {} (the first is on line {}): the system must have one equation per unknown",
                        self.name_of((l, m)),
                        p.line
                    ),
                ));
            }
            let lhs = self.scalar(&pe.lhs, &pe.scope, 0)?;
            let rhs = self.scalar(&pe.rhs, &pe.scope, 0)?;
            eqs.push((PdeEquation { l, m, lhs, rhs }, pe.pos));
        }
        for pa in &self.adds {
            let (l, m) = self.label_of(&pa.target, pa.pos)?;
            let term = self.scalar(&pa.term, &pa.scope, 0)?;
            let Some((eq, _)) = eqs.iter_mut().find(|(e, _)| (e.l, e.m) == (l, m)) else {
                return Err(PdeTextError::at(
                    pa.pos,
                    format!("add: {} has no equation to add to", self.name_of((l, m))),
                ));
            };
            eq.lhs = Expr::add(vec![eq.lhs.clone(), term]);
        }
        Ok(eqs)
    }

    /// Solves each eliminated unknown from its own equation and substitutes it into the
    /// others; the unknown and its equation leave the system.
    fn eliminate(
        &self,
        eqs: &mut Vec<(PdeEquation, Pos)>,
        unknowns: &mut Vec<TextUnknown>,
    ) -> Result<(), PdeTextError> {
        // Eliminations: each unknown solved from its own equation and substituted.
        for (target, pos) in &self.eliminations {
            let lm = self.label_of(target, *pos)?;
            let name = self.name_of(lm);
            let Some(k) = eqs.iter().position(|(e, _)| (e.l, e.m) == lm) else {
                return Err(PdeTextError::at(
                    *pos,
                    format!(
                        "eliminate: {name} has no equation to solve for it (eliminated twice?)"
                    ),
                ));
            };
            let (eq, eq_pos) = eqs.remove(k);
            let value = solve_for(&Expr::add(vec![eq.lhs, eq.rhs.neg()]), lm).map_err(|m| {
                PdeTextError::at(
                    *pos,
                    format!(
                        "eliminate {name}: {m} (its equation, line {}, must read c*{name} + \
                         terms without {name} = 0, c free of unknowns)",
                        eq_pos.line
                    ),
                )
            })?;
            let subst = |e: &Expr| {
                e.rewrite_bottom_up(&mut |x| {
                    if crate::pde::as_unknown(&x) == Some(lm) {
                        value.clone()
                    } else {
                        x
                    }
                })
            };
            for (e, _) in eqs.iter_mut() {
                e.lhs = subst(&e.lhs);
                e.rhs = subst(&e.rhs);
            }
            unknowns.retain(|u| u.label != lm);
        }
        Ok(())
    }
}

/// Solves the expression `e = 0` for the unknown `lm`: `e` must be `c·lm + rest` with `c`
/// and `rest` free of `lm` and `lm` not under a derivative; returns `−rest / c`.
fn solve_for(e: &Expr, lm: (i64, i64)) -> Result<Expr, String> {
    /// The terms of `e` with `lm` (their coefficients) and without it.
    fn split(e: &Expr, lm: (i64, i64)) -> Result<(Vec<Expr>, Vec<Expr>), String> {
        let has = |x: &Expr| x.any(&|y| crate::pde::as_unknown(y) == Some(lm));
        if crate::pde::as_unknown(e) == Some(lm) {
            return Ok((vec![Expr::int(1)], Vec::new()));
        }
        if !has(e) {
            return Ok((Vec::new(), vec![e.clone()]));
        }
        match e {
            Expr::Add(ts) => {
                let (mut c, mut r) = (Vec::new(), Vec::new());
                for t in ts {
                    let (ct, rt) = split(t, lm)?;
                    c.extend(ct);
                    r.extend(rt);
                }
                Ok((c, r))
            }
            Expr::Mul(fs) => {
                let mut inner = None;
                let mut others = Vec::new();
                for f in fs {
                    if has(f) {
                        if inner.is_some() {
                            return Err("it appears in a product with itself".into());
                        }
                        inner = Some(split(f, lm)?);
                    } else {
                        others.push(f.clone());
                    }
                }
                let (c, r) = inner.unwrap_or_default();
                let scale = |v: Vec<Expr>| -> Vec<Expr> {
                    v.into_iter()
                        .map(|x| {
                            let mut fs = others.clone();
                            fs.push(x);
                            Expr::mul(fs)
                        })
                        .collect()
                };
                Ok((scale(c), scale(r)))
            }
            Expr::Deriv(..) => Err("it is differentiated in its own equation".into()),
            _ => Err("it appears inside a power or function".into()),
        }
    }
    let (c, rest) = split(e, lm)?;
    if c.is_empty() {
        return Err("its own equation does not contain it".into());
    }
    let c = Expr::add(c);
    if c.any(&|y| crate::pde::as_unknown(y).is_some()) {
        return Err("its coefficient contains an unknown".into());
    }
    if const_value(&c) == Some(0.0) {
        return Err("its coefficient is zero".into());
    }
    Ok(Expr::mul(vec![Expr::add(rest).neg(), c.recip()]))
}
