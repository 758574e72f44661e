//! The expression tree.
//!
//! One enum, [`Expr`], holds everything the derivation and the discretizer need: exact
//! numbers, symbols, indices, the imaginary unit, Kronecker deltas, fields of position,
//! direction components, spherical-harmonic basis functions and coefficients, sums,
//! products, powers, integrals over the unit sphere and partial derivatives.
//!
//! Conventions that every pass relies on:
//! * `Add` and `Mul` are n-ary; subtraction is `Add` with a `Mul(-1, …)`, division is
//!   `Mul` with `Pow(…, -1)`.
//! * Spherical-harmonic indices (`l`, `m`) are expressions: concrete (`Expr::Int`) or
//!   symbolic (`Expr::Index`).
//! * Positions are implicit: a [`Expr::Field`] or [`Expr::Coeff`] is a function of the
//!   spatial position `x`; the discretizer resolves it against its offset stack.

use crate::number::Surd;

/// A spatial axis.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Axis {
    /// The x axis (index 0).
    X,
    /// The y axis (index 1).
    Y,
    /// The z axis (index 2).
    Z,
}

impl Axis {
    /// All three axes in order x, y, z.
    pub const ALL: [Axis; 3] = [Axis::X, Axis::Y, Axis::Z];
    /// 0 for x, 1 for y, 2 for z.
    pub fn index(self) -> usize {
        match self {
            Axis::X => 0,
            Axis::Y => 1,
            Axis::Z => 2,
        }
    }
}

/// Which direction variable a direction-dependent node refers to: the outgoing
/// direction `ω` of the RTE or the incoming direction `ω'` of the scattering integral.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum DirVar {
    /// The outgoing direction `ω`.
    Omega,
    /// The incoming direction `ω'` of the scattering integral.
    OmegaPrime,
}

/// Complex spherical harmonics (with Condon–Shortley phase) or the real basis of
/// docs/design.md §2.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum ShKind {
    /// Complex spherical harmonics `Y_l^m` with the Condon–Shortley phase.
    Complex,
    /// The real basis.
    Real,
}

/// Named scalar fields of position (material properties and derived quantities).
#[derive(Clone, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum FieldName {
    /// Extinction coefficient σ_t(x).
    SigmaT,
    /// Scattering coefficient σ_s(x).
    SigmaS,
    /// Absorption coefficient σ_a(x) = σ_t − σ_s.
    SigmaA,
    /// Funk–Hecke factor λ_l p_l(x) of the phase function for band `l`
    /// (isotropic: 1 for l = 0, else 0; Henyey–Greenstein: g^l).
    PhaseMoment(Box<Expr>),
    /// A diffusion coefficient field D(x) (used by CDA/FLD input PDEs).
    Diffusion,
    /// Any other user field, by name.
    Named(String),
}

/// A node of the expression tree.
#[derive(Clone, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Expr {
    /// Exact number `r·√s`.
    Num(Surd),
    /// A concrete integer index value (e.g. `l = 3`).
    Int(i64),
    /// A free symbol such as `h`, `g` or `\pi`.
    Sym(String),
    /// A symbolic summation index such as `l`, `m`, `l'`, `m'`.
    Index(String),
    /// The imaginary unit.
    I,
    /// n-ary sum.
    Add(Vec<Expr>),
    /// n-ary product.
    Mul(Vec<Expr>),
    /// `base ^ exponent`.
    Pow(Box<Expr>, Box<Expr>),
    /// Complex conjugate.
    Conj(Box<Expr>),
    /// Kronecker delta δ_{a,b}.
    Delta(Box<Expr>, Box<Expr>),
    /// A scalar field of position, e.g. σ_t(x).
    Field(FieldName),
    /// A generic named function of position and/or direction, e.g. `L(x, ω)`, `Q(x, ω)`,
    /// `p(ω'·ω)`; arguments are kept for printing and matching.
    Func(String, Vec<Expr>),
    /// Component `d` of a direction variable, e.g. ω_x.
    DirComp(DirVar, Axis),
    /// Spherical-harmonic basis function `Y_l^m(dir)`, possibly conjugated.
    Sh {
        /// Complex or real basis.
        kind: ShKind,
        /// The band `l`.
        l: Box<Expr>,
        /// The order `m` (`−l ≤ m ≤ l`).
        m: Box<Expr>,
        /// The direction it is evaluated at.
        dir: DirVar,
        /// Whether it is conjugated.
        conj: bool,
    },
    /// A spherical-harmonic coefficient field `name_l^m(x)`, e.g. the unknown `L_l^m(x)`
    /// (`name = "L"`) or the source `Q_l^m(x)` (`name = "Q"`), in the basis `kind`.
    Coeff {
        /// The field's name, e.g. `"L"` or `"Q"`.
        name: String,
        /// The basis of the expansion.
        kind: ShKind,
        /// The band `l`.
        l: Box<Expr>,
        /// The order `m`.
        m: Box<Expr>,
    },
    /// `Σ_{index = lo}^{hi} body`; `hi = None` means ∞.
    Sum {
        /// The summation index.
        index: String,
        /// The lower bound (inclusive).
        lo: Box<Expr>,
        /// The upper bound (inclusive); `None` means ∞.
        hi: Option<Box<Expr>>,
        /// The summand.
        body: Box<Expr>,
    },
    /// `∫_{S²} body dvar`.
    Integral {
        /// The direction integrated over.
        var: DirVar,
        /// The integrand.
        body: Box<Expr>,
    },
    /// Partial derivative `∂_axis body` with respect to position.
    Deriv(Axis, Box<Expr>),
}

impl Expr {
    /// An exact rational number `p/q`.
    pub fn rational(p: i64, q: i64) -> Expr {
        Expr::Num(Surd::rational(p, q))
    }
    /// An exact integer as a number (not an index).
    pub fn int(n: i64) -> Expr {
        Expr::rational(n, 1)
    }
    /// Sum of the given terms.
    pub fn add(terms: Vec<Expr>) -> Expr {
        Expr::Add(terms)
    }
    /// Product of the given factors.
    pub fn mul(factors: Vec<Expr>) -> Expr {
        Expr::Mul(factors)
    }
    /// `-self`.
    #[allow(clippy::should_implement_trait)]
    pub fn neg(self) -> Expr {
        Expr::Mul(vec![Expr::int(-1), self])
    }
    /// `self^e`.
    pub fn pow(self, e: Expr) -> Expr {
        Expr::Pow(Box::new(self), Box::new(e))
    }
    /// `1/self`.
    pub fn recip(self) -> Expr {
        self.pow(Expr::int(-1))
    }
    /// `√self`.
    pub fn sqrt(self) -> Expr {
        self.pow(Expr::rational(1, 2))
    }
    /// `∂_axis self`.
    pub fn deriv(self, axis: Axis) -> Expr {
        Expr::Deriv(axis, Box::new(self))
    }
    /// A field node.
    pub fn field(name: FieldName) -> Expr {
        Expr::Field(name)
    }
    /// The real-basis unknown `L_l^m(x)` with concrete indices.
    pub fn moment(l: i64, m: i64) -> Expr {
        Expr::Coeff {
            name: "L".into(),
            kind: ShKind::Real,
            l: Box::new(Expr::Int(l)),
            m: Box::new(Expr::Int(m)),
        }
    }
    /// The real-basis source coefficient `Q_l^m(x)` with concrete indices.
    pub fn source(l: i64, m: i64) -> Expr {
        Expr::Coeff {
            name: "Q".into(),
            kind: ShKind::Real,
            l: Box::new(Expr::Int(l)),
            m: Box::new(Expr::Int(m)),
        }
    }
}

impl Expr {
    /// A symbolic index such as `l` or `m'`.
    pub fn index(name: &str) -> Expr {
        Expr::Index(name.into())
    }
    /// A free symbol.
    pub fn sym(name: &str) -> Expr {
        Expr::Sym(name.into())
    }
    /// The exact number `s`.
    pub fn num(s: Surd) -> Expr {
        Expr::Num(s)
    }
    /// Kronecker delta δ_{a,b}.
    pub fn delta(a: Expr, b: Expr) -> Expr {
        Expr::Delta(Box::new(a), Box::new(b))
    }
    /// A spherical-harmonic basis function `Y_l^m(dir)` (not conjugated).
    pub fn sh(kind: ShKind, l: Expr, m: Expr, dir: DirVar) -> Expr {
        Expr::Sh {
            kind,
            l: Box::new(l),
            m: Box::new(m),
            dir,
            conj: false,
        }
    }
    /// A coefficient field `name_l^m(x)` in basis `kind`.
    pub fn coeff(name: &str, kind: ShKind, l: Expr, m: Expr) -> Expr {
        Expr::Coeff {
            name: name.into(),
            kind,
            l: Box::new(l),
            m: Box::new(m),
        }
    }
    /// `Σ_{index=lo}^{hi} body` (`hi = None` for ∞).
    pub fn sum(index: &str, lo: Expr, hi: Option<Expr>, body: Expr) -> Expr {
        Expr::Sum {
            index: index.into(),
            lo: Box::new(lo),
            hi: hi.map(Box::new),
            body: Box::new(body),
        }
    }
    /// `∫_{S²} body dvar`.
    pub fn integral(var: DirVar, body: Expr) -> Expr {
        Expr::Integral {
            var,
            body: Box::new(body),
        }
    }
    /// The symbol standing for a direction variable in function arguments (`ω`, `ω'`).
    pub fn dir_sym(var: DirVar) -> Expr {
        match var {
            DirVar::Omega => Expr::sym("\\omega"),
            DirVar::OmegaPrime => Expr::sym("\\omega'"),
        }
    }
    /// The symbol standing for the position in function arguments (`x`).
    pub fn pos_sym() -> Expr {
        Expr::sym("x")
    }

    /// The exact number held by a `Num` or an `Int` node.
    pub fn as_number(&self) -> Option<Surd> {
        match self {
            Expr::Num(s) => Some(*s),
            Expr::Int(n) => Some(Surd::from_int(*n)),
            _ => None,
        }
    }
    /// True for a numeric zero (`Num(0)` or `Int(0)`).
    pub fn is_zero(&self) -> bool {
        self.as_number().is_some_and(|s| s.is_zero())
    }
    /// True for a numeric one.
    pub fn is_one(&self) -> bool {
        self.as_number().is_some_and(|s| s.is_one())
    }

    /// Applies `f` to every direct child, rebuilding the node.
    pub fn map_children(&self, f: &mut dyn FnMut(&Expr) -> Expr) -> Expr {
        let b = |e: &Expr, f: &mut dyn FnMut(&Expr) -> Expr| Box::new(f(e));
        match self {
            Expr::Num(_)
            | Expr::Int(_)
            | Expr::Sym(_)
            | Expr::Index(_)
            | Expr::I
            | Expr::DirComp(..) => self.clone(),
            Expr::Add(v) => Expr::Add(v.iter().map(&mut *f).collect()),
            Expr::Mul(v) => Expr::Mul(v.iter().map(&mut *f).collect()),
            Expr::Pow(a, e) => Expr::Pow(b(a, f), b(e, f)),
            Expr::Conj(a) => Expr::Conj(b(a, f)),
            Expr::Delta(x, y) => Expr::Delta(b(x, f), b(y, f)),
            Expr::Field(FieldName::PhaseMoment(l)) => Expr::Field(FieldName::PhaseMoment(b(l, f))),
            Expr::Field(_) => self.clone(),
            Expr::Func(n, args) => Expr::Func(n.clone(), args.iter().map(&mut *f).collect()),
            Expr::Sh {
                kind,
                l,
                m,
                dir,
                conj,
            } => Expr::Sh {
                kind: *kind,
                l: b(l, f),
                m: b(m, f),
                dir: *dir,
                conj: *conj,
            },
            Expr::Coeff { name, kind, l, m } => Expr::Coeff {
                name: name.clone(),
                kind: *kind,
                l: b(l, f),
                m: b(m, f),
            },
            Expr::Sum {
                index,
                lo,
                hi,
                body,
            } => Expr::Sum {
                index: index.clone(),
                lo: b(lo, f),
                hi: hi.as_ref().map(|h| b(h, f)),
                body: b(body, f),
            },
            Expr::Integral { var, body } => Expr::Integral {
                var: *var,
                body: b(body, f),
            },
            Expr::Deriv(a, body) => Expr::Deriv(*a, b(body, f)),
        }
    }

    /// Calls `f` on every direct child.
    pub fn for_each_child(&self, f: &mut dyn FnMut(&Expr)) {
        match self {
            Expr::Num(_)
            | Expr::Int(_)
            | Expr::Sym(_)
            | Expr::Index(_)
            | Expr::I
            | Expr::DirComp(..)
            | Expr::Field(_) => {
                if let Expr::Field(FieldName::PhaseMoment(l)) = self {
                    f(l)
                }
            }
            Expr::Add(v) | Expr::Mul(v) | Expr::Func(_, v) => v.iter().for_each(f),
            Expr::Pow(a, b) | Expr::Delta(a, b) => {
                f(a);
                f(b)
            }
            Expr::Conj(a) | Expr::Integral { body: a, .. } | Expr::Deriv(_, a) => f(a),
            Expr::Sh { l, m, .. } | Expr::Coeff { l, m, .. } => {
                f(l);
                f(m)
            }
            Expr::Sum { lo, hi, body, .. } => {
                f(lo);
                if let Some(h) = hi {
                    f(h)
                }
                f(body)
            }
        }
    }

    /// True if `pred` holds for this node or any node below it.
    pub fn any(&self, pred: &dyn Fn(&Expr) -> bool) -> bool {
        if pred(self) {
            return true;
        }
        let mut found = false;
        self.for_each_child(&mut |c| found = found || c.any(pred));
        found
    }

    /// Rewrites bottom-up: children first, then `f` on the rebuilt node.
    pub fn rewrite_bottom_up(&self, f: &mut dyn FnMut(Expr) -> Expr) -> Expr {
        self.clone().rewrite_owned(f)
    }

    /// Like [`Expr::rewrite_bottom_up`] but consumes the tree, reusing its allocations.
    pub fn rewrite_owned(self, f: &mut dyn FnMut(Expr) -> Expr) -> Expr {
        let node = self.map_children_owned(&mut |c| c.rewrite_owned(f));
        f(node)
    }

    /// Applies `f` to every direct child of an owned node, reusing boxes and vectors.
    pub fn map_children_owned(self, f: &mut dyn FnMut(Expr) -> Expr) -> Expr {
        fn bx(mut b: Box<Expr>, f: &mut dyn FnMut(Expr) -> Expr) -> Box<Expr> {
            let inner = std::mem::replace(b.as_mut(), Expr::I);
            *b = f(inner);
            b
        }
        match self {
            Expr::Add(v) => Expr::Add(v.into_iter().map(&mut *f).collect()),
            Expr::Mul(v) => Expr::Mul(v.into_iter().map(&mut *f).collect()),
            Expr::Func(n, v) => Expr::Func(n, v.into_iter().map(&mut *f).collect()),
            Expr::Pow(a, e) => Expr::Pow(bx(a, f), bx(e, f)),
            Expr::Conj(a) => Expr::Conj(bx(a, f)),
            Expr::Delta(x, y) => Expr::Delta(bx(x, f), bx(y, f)),
            Expr::Field(FieldName::PhaseMoment(l)) => Expr::Field(FieldName::PhaseMoment(bx(l, f))),
            Expr::Sh {
                kind,
                l,
                m,
                dir,
                conj,
            } => Expr::Sh {
                kind,
                l: bx(l, f),
                m: bx(m, f),
                dir,
                conj,
            },
            Expr::Coeff { name, kind, l, m } => Expr::Coeff {
                name,
                kind,
                l: bx(l, f),
                m: bx(m, f),
            },
            Expr::Sum {
                index,
                lo,
                hi,
                body,
            } => Expr::Sum {
                index,
                lo: bx(lo, f),
                hi: hi.map(|h| bx(h, f)),
                body: bx(body, f),
            },
            Expr::Integral { var, body } => Expr::Integral {
                var,
                body: bx(body, f),
            },
            Expr::Deriv(a, body) => Expr::Deriv(a, bx(body, f)),
            leaf => leaf,
        }
    }

    /// True if the index `name` occurs free (a `Sum` over `name` binds it).
    pub fn contains_index(&self, name: &str) -> bool {
        match self {
            Expr::Index(n) => n == name,
            Expr::Sum {
                index,
                lo,
                hi,
                body,
            } => {
                lo.contains_index(name)
                    || hi.as_ref().is_some_and(|h| h.contains_index(name))
                    || (index != name && body.contains_index(name))
            }
            _ => {
                let mut found = false;
                self.for_each_child(&mut |c| found = found || c.contains_index(name));
                found
            }
        }
    }

    /// True if the expression depends on the direction variable `var` (free occurrence).
    pub fn depends_on_dir(&self, var: DirVar) -> bool {
        match self {
            Expr::DirComp(v, _) => *v == var,
            Expr::Sh { dir, l, m, .. } => {
                *dir == var || l.depends_on_dir(var) || m.depends_on_dir(var)
            }
            Expr::Func(_, args) => args
                .iter()
                .any(|a| *a == Expr::dir_sym(var) || a.depends_on_dir(var)),
            Expr::Integral { var: v, body } => *v != var && body.depends_on_dir(var),
            _ => {
                let mut found = false;
                self.for_each_child(&mut |c| found = found || c.depends_on_dir(var));
                found
            }
        }
    }

    /// True if the expression depends on the position `x`.
    pub fn depends_on_position(&self) -> bool {
        match self {
            Expr::Field(_) | Expr::Coeff { .. } | Expr::Deriv(..) => true,
            Expr::Func(_, args) => args
                .iter()
                .any(|a| *a == Expr::pos_sym() || a.depends_on_position()),
            _ => {
                let mut found = false;
                self.for_each_child(&mut |c| found = found || c.depends_on_position());
                found
            }
        }
    }
}

/// Vector calculus on top of [`Expr::Deriv`]: gradients and divergences are sums of
/// partial derivatives, so every pass and the discretizer handle them without new nodes.
impl Expr {
    /// `∇u` as its three components `∂_x u, ∂_y u, ∂_z u`.
    pub fn gradient(u: &Expr) -> [Expr; 3] {
        Axis::ALL.map(|a| u.clone().deriv(a))
    }
    /// `∇·v = ∂_x v_x + ∂_y v_y + ∂_z v_z` (axes with `None` are skipped, e.g. in 2D).
    pub fn divergence(v: [Option<Expr>; 3]) -> Expr {
        Expr::Add(
            Axis::ALL
                .iter()
                .zip(v)
                .filter_map(|(a, c)| c.map(|c| c.deriv(*a)))
                .collect(),
        )
    }
    /// `∇·(k ∇u)` over the given axes.
    pub fn div_k_grad(k: &Expr, u: &Expr, axes: &[Axis]) -> Expr {
        Expr::Add(
            axes.iter()
                .map(|a| Expr::Mul(vec![k.clone(), u.clone().deriv(*a)]).deriv(*a))
                .collect(),
        )
    }
}
