//! The discretizer: a walk over the expression tree with a stack of offsets (docs/design.md §4),
//! followed by canonicalisation into the stencil IR.
//!
//! Every equation is discretized at a hypothetical row location carrying the equation's
//! own staggered shift. The walk keeps a stack of offsets (half cells, relative to the row):
//!
//! * `∂_d c` → `(c at top + e_d − c at top − e_d) · (1/h_d)`, each side evaluated by pushing
//!   its offset (one half cell each way, so the difference spans one cell h_d); nested
//!   derivatives compose, so `∂_x(D ∂_x L)` becomes the 3-point stencil with D at ±½ cell;
//! * a field node becomes [`Weight::Field`] at the top-of-stack offset (the runtime decides
//!   whether that is exact evaluation or an average of voxel data, docs/design.md §3);
//! * `Q_l^m` becomes the field [`FieldRef::Source`];
//! * `L_l^m` becomes a reference to the unknown at the top-of-stack offset; if that offset
//!   is not a position of the unknown's grid along some axis, the unknown is interpolated
//!   there as the average of the two neighbouring positions along each such axis (needed
//!   only for collocated layouts or user PDEs).
//!
//! The result is kept as a linear form `Σ poly × unknown[offset] + Σ poly`, where the
//! polynomials are normalised sums of monomials `c · Π atoms` (atoms: 1/h_d, fields at
//! offsets, reciprocals of polynomials). Duplicate (unknown, offset) terms are merged,
//! constant subtrees are folded into `f64` constants from the exact numbers, and zero terms
//! are dropped.

use std::collections::HashMap;

use cas::{Expr, FieldName};

use crate::derive::PnSystem;
use crate::pde::{self, as_unknown, PdeSystem};
use crate::placement;
use pn_stencil::Staggering;
use pn_stencil::{
    Dim, FieldRef, HalfOffset, MomentPlacement, StencilError, StencilIr, StencilRow, StencilTerm,
    Weight,
};

/// A non-constant factor of a monomial.
#[derive(Clone, Debug)]
enum Atom {
    InvH(usize),
    Field(FieldRef, HalfOffset),
    Recip(Poly),
}

impl Atom {
    fn key(&self) -> String {
        format!("{self:?}")
    }
}

/// A normalised sum of monomials `c · Π atoms` (atoms sorted, like monomials merged).
#[derive(Clone, Debug, Default)]
struct Poly {
    terms: Vec<(f64, Vec<Atom>)>,
}

impl Poly {
    fn constant(c: f64) -> Poly {
        Poly {
            terms: vec![(c, Vec::new())],
        }
        .normalized()
    }
    fn atom(a: Atom) -> Poly {
        Poly {
            terms: vec![(1.0, vec![a])],
        }
    }
    fn is_zero(&self) -> bool {
        self.terms.is_empty()
    }
    /// The value if the polynomial is a constant.
    fn as_const(&self) -> Option<f64> {
        match self.terms.as_slice() {
            [] => Some(0.0),
            [(c, atoms)] if atoms.is_empty() => Some(*c),
            _ => None,
        }
    }
    fn normalized(self) -> Poly {
        let mut merged: Vec<(String, f64, Vec<Atom>)> = Vec::new();
        for (c, mut atoms) in self.terms {
            atoms.sort_by_cached_key(Atom::key);
            let key: String = atoms.iter().map(Atom::key).collect::<Vec<_>>().join("*");
            match merged.iter_mut().find(|(k, _, _)| *k == key) {
                Some(entry) => entry.1 += c,
                None => merged.push((key, c, atoms)),
            }
        }
        // Simpler monomials first (σ_t before σ_s·λp): only affects printing.
        merged.sort_by(|a, b| (a.2.len(), &a.0).cmp(&(b.2.len(), &b.0)));
        Poly {
            terms: merged
                .into_iter()
                .filter(|(_, c, _)| *c != 0.0)
                .map(|(_, c, a)| (c, a))
                .collect(),
        }
    }
    fn add(mut self, other: Poly) -> Poly {
        self.terms.extend(other.terms);
        self.normalized()
    }
    fn scale(mut self, s: f64) -> Poly {
        self.terms.iter_mut().for_each(|t| t.0 *= s);
        self.normalized()
    }
    fn mul(&self, other: &Poly) -> Poly {
        let mut terms = Vec::with_capacity(self.terms.len() * other.terms.len());
        for (ca, aa) in &self.terms {
            for (cb, ab) in &other.terms {
                let mut atoms = aa.clone();
                atoms.extend(ab.iter().cloned());
                terms.push((ca * cb, atoms));
            }
        }
        Poly { terms }.normalized()
    }
    fn recip(self) -> Result<Poly, StencilError> {
        match self.as_const() {
            Some(0.0) => Err(StencilError::Unsupported("division by zero".into())),
            Some(c) => Ok(Poly::constant(1.0 / c)),
            // Factor out the largest coefficient (preferring a positive one) so that
            // 1/(3σ_t − 3σ_s g) prints as (1/3)·1/(σ_t − σ_s g).
            None => {
                let c = self.terms.iter().map(|t| t.0).fold(0.0f64, |a, c| {
                    if c.abs() > a.abs() || (c.abs() == a.abs() && c > a) {
                        c
                    } else {
                        a
                    }
                });
                let inner = self.scale(1.0 / c);
                Ok(Poly::atom(Atom::Recip(inner)).scale(1.0 / c))
            }
        }
    }
    #[expect(clippy::expect_used, reason = "the pop is under fs.len() == 1")]
    fn to_weight(&self) -> Weight {
        fn atom_weight(a: &Atom) -> Weight {
            match a {
                Atom::InvH(d) => Weight::InvH(*d),
                Atom::Field(f, o) => Weight::Field {
                    field: f.clone(),
                    offset: *o,
                },
                Atom::Recip(p) => Weight::Recip(Box::new(p.to_weight())),
            }
        }
        let mono = |c: f64, atoms: &[Atom]| -> Weight {
            let mut fs: Vec<Weight> = Vec::new();
            if c != 1.0 || atoms.is_empty() {
                fs.push(Weight::Const(c));
            }
            fs.extend(atoms.iter().map(atom_weight));
            if fs.len() == 1 {
                fs.pop().expect("one factor")
            } else {
                Weight::Mul(fs)
            }
        };
        match self.terms.as_slice() {
            [] => Weight::Const(0.0),
            [(c, a)] => mono(*c, a),
            ts => Weight::Add(ts.iter().map(|(c, a)| mono(*c, a)).collect()),
        }
    }
}

/// Key of a linear-form term: the unknown (moment index, offset) or `None` for terms
/// without an unknown.
type TermKey = Option<(usize, HalfOffset)>;

/// `Σ poly × unknown` with merged keys.
#[derive(Clone, Debug, Default)]
struct Lin {
    terms: Vec<(TermKey, Poly)>,
}

impl Lin {
    fn poly(p: Poly) -> Lin {
        Lin {
            terms: if p.is_zero() {
                Vec::new()
            } else {
                vec![(None, p)]
            },
        }
    }
    fn add(mut self, other: Lin) -> Lin {
        for (k, p) in other.terms {
            match self.terms.iter_mut().find(|(kk, _)| *kk == k) {
                Some(entry) => entry.1 = std::mem::take(&mut entry.1).add(p),
                None => self.terms.push((k, p)),
            }
        }
        self.terms.retain(|(_, p)| !p.is_zero());
        self
    }
    fn scale(self, s: f64) -> Lin {
        self.mul_poly(&Poly::constant(s))
    }
    fn mul_poly(self, p: &Poly) -> Lin {
        Lin {
            terms: self
                .terms
                .into_iter()
                .map(|(k, q)| (k, q.mul(p)))
                .filter(|(_, q)| !q.is_zero())
                .collect(),
        }
    }
    /// The unknown-free part as a polynomial, if there are no unknowns.
    fn as_poly(&self) -> Option<Poly> {
        let mut acc = Poly::default();
        for (k, p) in &self.terms {
            if k.is_some() {
                return None;
            }
            acc = acc.add(p.clone());
        }
        Some(acc)
    }
    fn mul(self, other: Lin) -> Result<Lin, StencilError> {
        if let Some(p) = other.as_poly() {
            Ok(self.mul_poly(&p))
        } else if let Some(p) = self.as_poly() {
            Ok(other.mul_poly(&p))
        } else {
            Err(StencilError::Unsupported(
                "product of two unknowns (the PDE must be linear)".into(),
            ))
        }
    }
}

/// The tree walk for one equation.
struct Walker<'a> {
    moments: &'a [MomentPlacement],
    index: &'a HashMap<(i64, i64), usize>,
    dim: Dim,
    row_shift: [u8; 3],
    /// Offsets (half cells, relative to the row); the top is the current position.
    stack: Vec<HalfOffset>,
}

impl Walker<'_> {
    #[expect(
        clippy::expect_used,
        reason = "the offset stack starts with one entry and pop never removes the last one"
    )]
    fn top(&self) -> HalfOffset {
        *self.stack.last().expect("the offset stack is never empty")
    }

    fn constant(&mut self, e: &Expr, what: &str) -> Result<f64, StencilError> {
        self.lin(e)?
            .as_poly()
            .and_then(|p| p.as_const())
            .ok_or_else(|| StencilError::Unsupported(format!("{what} must be a constant: {e:?}")))
    }

    fn lin(&mut self, e: &Expr) -> Result<Lin, StencilError> {
        if let Some(lm) = as_unknown(e) {
            return self.unknown(lm);
        }
        match e {
            Expr::Num(s) => Ok(Lin::poly(Poly::constant(s.to_f64()))),
            Expr::Int(n) => Ok(Lin::poly(Poly::constant(*n as f64))),
            Expr::Sym(s) if matches!(s.as_str(), "pi" | "\\pi" | "π") => {
                Ok(Lin::poly(Poly::constant(std::f64::consts::PI)))
            }
            Expr::Add(ts) => {
                let mut acc = Lin::default();
                for t in ts {
                    acc = acc.add(self.lin(t)?);
                }
                Ok(acc)
            }
            Expr::Mul(fs) => {
                let mut acc = Lin::poly(Poly::constant(1.0));
                for f in fs {
                    acc = acc.mul(self.lin(f)?)?;
                }
                Ok(acc)
            }
            Expr::Pow(b, x) => {
                let x = self.constant(x, "an exponent")?;
                let base = self.lin(b)?;
                if x == 1.0 {
                    return Ok(base);
                }
                let bp = base.as_poly().ok_or_else(|| {
                    StencilError::Unsupported(format!("power of an unknown: {e:?}"))
                })?;
                if let Some(c) = bp.as_const() {
                    return Ok(Lin::poly(Poly::constant(c.powf(x))));
                }
                if x.fract() == 0.0 && x != 0.0 && x.abs() <= 16.0 {
                    let mut p = Poly::constant(1.0);
                    for _ in 0..(x.abs() as usize) {
                        p = p.mul(&bp);
                    }
                    return Ok(Lin::poly(if x < 0.0 { p.recip()? } else { p }));
                }
                Err(StencilError::Unsupported(format!(
                    "non-integer power of a field: {e:?}"
                )))
            }
            Expr::Delta(a, b) => {
                let (a, b) = (
                    self.constant(a, "a delta index")?,
                    self.constant(b, "a delta index")?,
                );
                Ok(Lin::poly(Poly::constant(if a == b { 1.0 } else { 0.0 })))
            }
            Expr::Field(name) => {
                let f = field_ref(name)?;
                Ok(Lin::poly(Poly::atom(Atom::Field(f, self.top()))))
            }
            Expr::Coeff { name, l, m, .. } if name == "Q" => {
                let l = self.constant(l, "a source index")?;
                let m = self.constant(m, "a source index")?;
                if l < 0.0 {
                    return Err(StencilError::Unsupported(format!("source index l = {l}")));
                }
                let f = FieldRef::Source {
                    l: l as u32,
                    m: m as i32,
                };
                Ok(Lin::poly(Poly::atom(Atom::Field(f, self.top()))))
            }
            Expr::Deriv(axis, child) => {
                let d = axis.index();
                if d >= self.dim.axes() {
                    // z-independent problem: ∂z vanishes.
                    return Ok(Lin::default());
                }
                let mut plus = self.top();
                plus[d] += 1;
                let mut minus = self.top();
                minus[d] -= 1;
                self.stack.push(plus);
                let hi = self.lin(child);
                self.stack.pop();
                self.stack.push(minus);
                let lo = self.lin(child);
                self.stack.pop();
                Ok(hi?
                    .add(lo?.scale(-1.0))
                    .mul_poly(&Poly::atom(Atom::InvH(d))))
            }
            // Math functions of constants (from PDE text, e.g. a filter strength).
            Expr::Func(f, args) if args.len() == 1 => {
                let x = self.constant(&args[0], "the argument of a function")?;
                math(f, x)
                    .filter(|v| v.is_finite())
                    .map(|v| Lin::poly(Poly::constant(v)))
                    .ok_or_else(|| {
                        StencilError::Unsupported(format!("{f}({x}) has no finite value"))
                    })
            }
            other => Err(StencilError::Unsupported(format!(
                "node not allowed in an expanded equation: {other:?}"
            ))),
        }
    }

    /// The unknown `L_l^m` at the top-of-stack offset, interpolated along every axis on
    /// which that offset is not a position of its grid.
    fn unknown(&mut self, (l, m): (i64, i64)) -> Result<Lin, StencilError> {
        let Some(&q) = self.index.get(&(l, m)) else {
            if self.dim == Dim::Two && (l + m).rem_euclid(2) != 0 {
                // Odd under z → −z: vanishes for z-independent problems (docs/design.md §3).
                return Ok(Lin::default());
            }
            return Err(StencilError::Malformed(format!(
                "L_{l}^{m} is referenced but is not an unknown of the system"
            )));
        };
        let want = self.moments[q].shift;
        let mut points: Vec<(HalfOffset, f64)> = vec![(self.top(), 1.0)];
        for d in 0..self.dim.axes() {
            let parity = (i32::from(self.row_shift[d]) + self.top()[d]).rem_euclid(2);
            if parity != i32::from(want[d]) {
                points = points
                    .into_iter()
                    .flat_map(|(o, w)| {
                        let (mut a, mut b) = (o, o);
                        a[d] -= 1;
                        b[d] += 1;
                        [(a, 0.5 * w), (b, 0.5 * w)]
                    })
                    .collect();
            }
        }
        let mut acc = Lin::default();
        for (o, w) in points {
            acc = acc.add(Lin {
                terms: vec![(Some((q, o)), Poly::constant(w))],
            });
        }
        Ok(acc)
    }
}

/// The math functions of constants that equations may contain (`Expr::Func`, from PDE
/// text: `exp`, `ln`, `sin`, `cos`, `abs`).
pub(crate) fn math(f: &str, x: f64) -> Option<f64> {
    Some(match f {
        "exp" => x.exp(),
        "ln" => x.ln(),
        "sin" => x.sin(),
        "cos" => x.cos(),
        "abs" => x.abs(),
        _ => return None,
    })
}

/// The stencil field of a `cas` field name.
fn field_ref(name: &FieldName) -> Result<FieldRef, StencilError> {
    Ok(match name {
        FieldName::SigmaT => FieldRef::SigmaT,
        FieldName::SigmaS => FieldRef::SigmaS,
        FieldName::SigmaA => FieldRef::SigmaA,
        FieldName::Diffusion => FieldRef::Diffusion,
        FieldName::PhaseMoment(l) => match l.as_ref() {
            Expr::Int(l) if *l >= 0 => FieldRef::PhaseMoment(*l as u32),
            other => {
                return Err(StencilError::Unsupported(format!(
                    "phase moment with non-concrete band {other:?}"
                )))
            }
        },
        FieldName::Named(n) => {
            return Err(StencilError::Unsupported(format!(
                "user field `{n}` has no runtime counterpart"
            )))
        }
    })
}

/// The [`Weight`] of an unknown-free coefficient expression (fields, constants) with its
/// fields read at offset 0: the coefficients of a text PDE's boundary conditions
/// ([`pn_stencil::robin`]), evaluated at the face point. Derivatives are refused (a
/// coefficient is a pointwise quantity); a zero coefficient gives `None`.
pub(crate) fn coefficient_weight(e: &Expr, dim: Dim) -> Result<Option<Weight>, StencilError> {
    if e.any(&|x| matches!(x, Expr::Deriv(..))) {
        return Err(StencilError::Unsupported(
            "a coefficient of a boundary condition contains a derivative".into(),
        ));
    }
    let index = HashMap::new();
    let mut w = Walker {
        moments: &[],
        index: &index,
        dim,
        row_shift: [0; 3],
        stack: vec![[0; 3]],
    };
    let poly = w.lin(e)?.as_poly().ok_or_else(|| {
        StencilError::Unsupported(
            "a coefficient of a boundary condition contains an unknown".into(),
        )
    })?;
    Ok((!poly.is_zero()).then(|| poly.to_weight()))
}

/// Discretizes `sys` with the unknowns placed as in `moments` (same order as
/// `sys.unknowns`) into a stencil IR named `name`.
pub fn discretize(
    sys: &PdeSystem,
    moments: Vec<MomentPlacement>,
    name: impl Into<String>,
) -> Result<StencilIr, StencilError> {
    if moments.len() != sys.unknowns.len() {
        return Err(StencilError::Malformed(
            "placement and unknowns differ in length".into(),
        ));
    }
    let index: HashMap<(i64, i64), usize> = sys
        .unknowns
        .iter()
        .enumerate()
        .map(|(i, &lm)| (lm, i))
        .collect();
    if index.len() != sys.unknowns.len() {
        return Err(StencilError::Malformed("duplicate unknowns".into()));
    }
    let mut rows: Vec<Option<StencilRow>> = vec![None; sys.unknowns.len()];
    for eq in &sys.equations {
        let r = *index.get(&(eq.l, eq.m)).ok_or_else(|| {
            StencilError::Malformed(format!("equation at L_{}^{} has no unknown", eq.l, eq.m))
        })?;
        if rows[r].is_some() {
            return Err(StencilError::Malformed(format!(
                "two equations located at L_{}^{}",
                eq.l, eq.m
            )));
        }
        let mut w = Walker {
            moments: &moments,
            index: &index,
            dim: sys.dim,
            row_shift: moments[r].shift,
            stack: vec![[0; 3]],
        };
        // lhs − rhs = 0: unknown terms on the left, the rest (negated) on the right.
        let form = w.lin(&eq.lhs)?.add(w.lin(&eq.rhs)?.scale(-1.0));
        let mut terms = Vec::new();
        let mut rhs = Vec::new();
        for (key, poly) in form.terms {
            match key {
                Some((moment, offset)) => terms.push(StencilTerm {
                    moment,
                    offset,
                    weight: poly.to_weight(),
                }),
                None => rhs.push(poly.scale(-1.0).to_weight()),
            }
        }
        terms.sort_by_key(|t| (t.moment, t.offset));
        rows[r] = Some(StencilRow {
            moment: r,
            terms,
            rhs,
        });
    }
    let rows = rows
        .into_iter()
        .enumerate()
        .map(|(r, row)| {
            row.ok_or_else(|| {
                let (l, m) = sys.unknowns[r];
                StencilError::Malformed(format!("no equation for L_{l}^{m}"))
            })
        })
        .collect::<Result<Vec<_>, _>>()?;
    Ok(StencilIr {
        name: name.into(),
        dim: sys.dim,
        moments,
        rows,
    })
}

/// Name of a P_N stencil, e.g. `p3_3d_staggered`.
pub fn pn_name(order: usize, dim: Dim, layout: Staggering) -> String {
    format!("p{order}_{}d_{}", dim.axes(), layout.as_str())
}

/// The stencil of a derived P_N system in `dim` with `layout`.
pub fn pn_ir(sys: &PnSystem, dim: Dim, layout: Staggering) -> Result<StencilIr, StencilError> {
    let pde = PdeSystem::pn(sys, dim);
    let moments = placement::place(&pde, layout)?;
    discretize(&pde, moments, pn_name(sys.order, dim, layout))
}

/// The real P_N system of order `order` ([`crate::derive::real_pn_system`]).
pub fn derive_pn(order: usize) -> Result<PnSystem, StencilError> {
    crate::derive::real_pn_system(order)
        .map_err(|e| StencilError::Derive(format!("P_{order}: {e}")))
}

/// The P_N stencil of order `order`, derived with [`derive_pn`].
pub fn pn_ir_for_order(
    order: usize,
    dim: Dim,
    layout: Staggering,
) -> Result<StencilIr, StencilError> {
    pn_ir(&derive_pn(order)?, dim, layout)
}

/// The CDA stencil (`cda_2d` / `cda_3d`), see [`pde::cda`].
pub fn cda_ir(dim: Dim) -> Result<StencilIr, StencilError> {
    let pde = pde::cda(dim);
    let moments = placement::derive_staggered(&pde)?;
    discretize(&pde, moments, format!("cda_{}d", dim.axes()))
}

/// The diffusion stencil with D as a field (`diffusion_2d` / `diffusion_3d`), see
/// [`pde::diffusion`].
pub fn diffusion_ir(dim: Dim) -> Result<StencilIr, StencilError> {
    let pde = pde::diffusion(dim);
    let moments = placement::derive_staggered(&pde)?;
    discretize(&pde, moments, format!("diffusion_{}d", dim.axes()))
}
