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
    X,
    Y,
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
    Omega,
    OmegaPrime,
}

/// Complex spherical harmonics (with Condon–Shortley phase) or the real basis of
/// DESIGN.md §2.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum ShKind {
    Complex,
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
        kind: ShKind,
        l: Box<Expr>,
        m: Box<Expr>,
        dir: DirVar,
        conj: bool,
    },
    /// A spherical-harmonic coefficient field `name_l^m(x)`, e.g. the unknown `L_l^m(x)`
    /// (`name = "L"`) or the source `Q_l^m(x)` (`name = "Q"`), in the basis `kind`.
    Coeff {
        name: String,
        kind: ShKind,
        l: Box<Expr>,
        m: Box<Expr>,
    },
    /// `Σ_{index = lo}^{hi} body`; `hi = None` means ∞.
    Sum {
        index: String,
        lo: Box<Expr>,
        hi: Option<Box<Expr>>,
        body: Box<Expr>,
    },
    /// `∫_{S²} body dvar`.
    Integral { var: DirVar, body: Box<Expr> },
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
