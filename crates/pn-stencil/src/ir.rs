//! The stencil IR: the canonical discretized form of a PDE system on staggered grids,
//! and the [`StencilKernel`] trait through which the runtime evaluates it.
//!
//! ## Coordinates
//! All offsets are in **half cells**. A moment's `shift[d] == 1` means it is shifted half
//! a cell along axis `d`: it lives on the cell faces `a + s·h` (s = 0..=n, both domain faces
//! included), while `shift[d] == 0` means cell centres `a + (i+½)h` (i = 0..n-1). In absolute
//! half-cell coordinates measured from the domain minimum `a`, a centred position of index
//! `i` is `2i+1` and a face position of index `s` is `2s`.
//!
//! Row `r` of a stencil is the equation located at the position of moment `r` (the system is
//! square: one equation per moment). A term's `offset` and a field's `offset` are relative
//! to the row's own position, so a term of moment `q` at `offset` references the unknown of
//! moment `q` at absolute half-coordinate `row_pos + offset`; with a consistent placement
//! that coordinate has the parity of moment `q`'s shift on every axis.
//!
//! The sparsity pattern is the same for every row location; only the weights vary.

use serde::{Deserialize, Serialize};

/// An offset or position in half cells, per axis (x, y, z). Unused axes are 0.
pub type HalfOffset = [i32; 3];

/// Spatial dimension of a stencil.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub enum Dim {
    /// z-independent problems: only moments with l+m even, no ∂z terms.
    Two,
    /// Full 3D.
    Three,
}

impl Dim {
    /// Number of spatial axes (2 or 3).
    pub fn axes(self) -> usize {
        match self {
            Dim::Two => 2,
            Dim::Three => 3,
        }
    }
}

/// One unknown per cell: a moment and its staggered placement.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct MomentPlacement {
    /// Band l.
    pub l: i32,
    /// Order m (−l ≤ m ≤ l). For scalar PDEs such as CDA, (0, 0).
    pub m: i32,
    /// Half-cell shift per axis: 0 = cell centre, 1 = cell faces.
    pub shift: [u8; 3],
}

/// A scalar field the weights depend on, evaluated at a position.
#[derive(Clone, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub enum FieldRef {
    /// σ_t.
    SigmaT,
    /// σ_s.
    SigmaS,
    /// σ_a = σ_t − σ_s.
    SigmaA,
    /// λ_l p_l, the Funk–Hecke factor of the phase function for band l.
    PhaseMoment(u32),
    /// The real-basis source coefficient Q_l^m.
    Source {
        /// The band `l`.
        l: u32,
        /// The order `m`.
        m: i32,
    },
    /// A diffusion coefficient field D (CDA/FLD Picard steps).
    Diffusion,
}

/// A weight: a small expression in fields, 1/h and constants.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub enum Weight {
    /// A constant.
    Const(f64),
    /// 1 / h_axis (axis index 0, 1, 2).
    InvH(usize),
    /// A field evaluated at `offset` (half cells) from the row position.
    Field {
        /// The field.
        field: FieldRef,
        /// Where it is evaluated, in half cells from the row position.
        offset: HalfOffset,
    },
    /// Sum.
    Add(Vec<Weight>),
    /// Product.
    Mul(Vec<Weight>),
    /// 1 / x.
    Recip(Box<Weight>),
}

impl Weight {
    /// Evaluate with the given field context.
    pub fn eval(&self, ctx: &dyn FieldContext) -> f64 {
        match self {
            Weight::Const(c) => *c,
            Weight::InvH(axis) => ctx.inv_h(*axis),
            Weight::Field { field, offset } => ctx.field(field, *offset),
            Weight::Add(ws) => ws.iter().map(|w| w.eval(ctx)).sum(),
            Weight::Mul(ws) => ws.iter().map(|w| w.eval(ctx)).product(),
            Weight::Recip(w) => 1.0 / w.eval(ctx),
        }
    }
}

/// One term of a row: `weight × unknown(moment, row position + offset)`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct StencilTerm {
    /// Index into [`StencilIr::moments`].
    pub moment: usize,
    /// Offset in half cells from the row position.
    pub offset: HalfOffset,
    /// The weight expression.
    pub weight: Weight,
}

/// One equation: `Σ terms = rhs`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct StencilRow {
    /// The moment whose position this equation is located at.
    pub moment: usize,
    /// Left-hand-side terms.
    pub terms: Vec<StencilTerm>,
    /// Right-hand side (sum of weights; usually `Field(Source)` at offset 0).
    pub rhs: Vec<Weight>,
}

/// A complete discretized system: placement of every unknown and one row per unknown.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct StencilIr {
    /// A short identifier, e.g. `p3_3d_staggered` or `cda_3d`.
    pub name: String,
    /// Dimension.
    pub dim: Dim,
    /// Unknowns per cell in storage order.
    pub moments: Vec<MomentPlacement>,
    /// `rows[r].moment == r`.
    pub rows: Vec<StencilRow>,
}

impl StencilIr {
    /// The highest band l of the source moments Q_l^m the system reads (`None` without a
    /// source term).
    pub fn max_source_band(&self) -> Option<u32> {
        let mut fields = Vec::new();
        for row in &self.rows {
            row.rhs.iter().for_each(|w| w.fields(&mut fields));
            row.terms.iter().for_each(|t| t.weight.fields(&mut fields));
        }
        fields
            .iter()
            .filter_map(|(f, _)| match f {
                FieldRef::Source { l, .. } => Some(*l),
                _ => None,
            })
            .max()
    }

    /// A 64-bit FNV-1a hash of the whole IR (name, placement, every term and weight, in
    /// `Debug` form, where floats print exactly). Compiled stencils carry the fingerprint
    /// of the IR they were generated from, so a text PDE edited after the build is not
    /// mistaken for its compiled version.
    pub fn fingerprint(&self) -> u64 {
        format!("{self:?}")
            .bytes()
            .fold(0xcbf2_9ce4_8422_2325u64, |h, b| {
                (h ^ u64::from(b)).wrapping_mul(0x0100_0000_01b3)
            })
    }
}

/// A boundary condition a PDE states for itself (module `robin`):
/// `Σ_j value_j u_j + Σ_k normal_k ∂_n u_k = 0` on a face, `∂_n` the outward normal
/// derivative, the coefficients read at the face point.
#[derive(Clone, Debug, PartialEq)]
pub struct RobinCondition {
    /// The unknown (index into the stencil's moments) the condition is stated for: the
    /// conditions are square, one per target.
    pub target: usize,
    /// `(moment index, coefficient)` of the face values.
    pub value: Vec<(usize, Weight)>,
    /// `(moment index, coefficient)` of the outward normal derivatives.
    pub normal: Vec<(usize, Weight)>,
}

/// A set of boundary conditions, applied on the faces whose kind it is stated for.
#[derive(Clone, Debug, PartialEq)]
pub struct RobinBoundary {
    /// The boundary kind the conditions implement (`marshak`: `--bc marshak`).
    pub kind: String,
    /// One condition per target unknown.
    pub conditions: Vec<RobinCondition>,
}

impl RobinBoundary {
    /// The index of the condition stated for moment `q`, if any.
    pub fn condition_of(&self, q: usize) -> Option<usize> {
        self.conditions.iter().position(|c| c.target == q)
    }
}

/// Field values and grid spacing for the row being evaluated.
///
/// The runtime implements this for one row location at a time; `offset` is relative to
/// that row position, in half cells.
pub trait FieldContext {
    /// Value of `field` at `offset` half cells from the row position.
    fn field(&self, field: &FieldRef, offset: HalfOffset) -> f64;
    /// 1 / h along `axis`.
    fn inv_h(&self, axis: usize) -> f64;
}

/// The structural part of one term, shared by all row locations.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct TermPattern {
    /// Index of the referenced moment.
    pub moment: usize,
    /// Offset in half cells from the row position.
    pub offset: HalfOffset,
}

/// What the runtime needs from a stencil, whether interpreted from a [`StencilIr`] or
/// generated as Rust code at build time.
pub trait StencilKernel: Send + Sync {
    /// Short identifier (same as the IR's `name`).
    fn name(&self) -> &str;
    /// Dimension.
    fn dim(&self) -> Dim;
    /// Unknowns per cell in storage order; one row per moment.
    fn moments(&self) -> &[MomentPlacement];
    /// The sparsity pattern of row `row`.
    fn pattern(&self, row: usize) -> &[TermPattern];
    /// Evaluates the weights of row `row` (in the order of [`StencilKernel::pattern`])
    /// into `weights` and returns the right-hand side.
    fn eval_row(&self, row: usize, ctx: &dyn FieldContext, weights: &mut [f64]) -> f64;
    /// Boundary conditions the PDE states for itself (a text PDE's `boundary` statements,
    /// module `robin`); `None` (the default) for the derived stencils, whose boundary is the
    /// runtime's.
    fn boundary_conditions(&self) -> Option<&RobinBoundary> {
        None
    }
}

/// Errors of placement, discretization and code generation.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum StencilError {
    /// The coupling structure admits no staggered placement (docs/design.md §3).
    InconsistentPlacement(String),
    /// The expression tree contains something the discretizer cannot handle.
    Unsupported(String),
    /// The system is malformed (missing or duplicate equations, unknown moments).
    Malformed(String),
    /// Deriving the P_N system failed.
    Derive(String),
    /// Invalid configuration (e.g. a bad `PN_ORDERS` value).
    Config(String),
    /// Generated code failed to parse or could not be written.
    Codegen(String),
}

impl std::fmt::Display for StencilError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            StencilError::InconsistentPlacement(s) => write!(f, "inconsistent placement: {s}"),
            StencilError::Unsupported(s) => write!(f, "cannot discretize: {s}"),
            StencilError::Malformed(s) => write!(f, "malformed system: {s}"),
            StencilError::Derive(s) => write!(f, "derivation failed: {s}"),
            StencilError::Config(s) => write!(f, "{s}"),
            StencilError::Codegen(s) => write!(f, "code generation failed: {s}"),
        }
    }
}

impl std::error::Error for StencilError {}

impl std::fmt::Display for FieldRef {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            FieldRef::SigmaT => write!(f, "sigma_t"),
            FieldRef::SigmaS => write!(f, "sigma_s"),
            FieldRef::SigmaA => write!(f, "sigma_a"),
            FieldRef::PhaseMoment(l) => write!(f, "phase_{l}"),
            FieldRef::Source { l, m } => write!(f, "Q_{l}^{m}"),
            FieldRef::Diffusion => write!(f, "D"),
        }
    }
}

/// Readable form: fields as `name[ox,oy,oz]` (offset in half cells), `1/h_x` etc.; a
/// leading constant −1 is written as a minus sign.
impl std::fmt::Display for Weight {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        /// `(negative, |w|)` with a leading negative constant pulled out.
        #[expect(clippy::expect_used, reason = "the pop is under rest.len() == 1")]
        fn signed(w: &Weight) -> (bool, Weight) {
            match w {
                Weight::Const(c) if *c < 0.0 => (true, Weight::Const(-c)),
                Weight::Mul(fs) => match fs.first() {
                    Some(Weight::Const(c)) if *c < 0.0 => {
                        let mut rest = fs[1..].to_vec();
                        if *c != -1.0 || rest.is_empty() {
                            rest.insert(0, Weight::Const(-c));
                        }
                        let w = if rest.len() == 1 {
                            rest.pop().expect("one factor")
                        } else {
                            Weight::Mul(rest)
                        };
                        (true, w)
                    }
                    _ => (false, w.clone()),
                },
                _ => (false, w.clone()),
            }
        }
        /// Writes `w`, parenthesised if it is a sum.
        fn factor(f: &mut std::fmt::Formatter<'_>, w: &Weight) -> std::fmt::Result {
            match w {
                Weight::Add(_) => write!(f, "({w})"),
                _ => write!(f, "{w}"),
            }
        }
        const AXES: [&str; 3] = ["x", "y", "z"];
        match self {
            Weight::Const(c) => write!(f, "{c}"),
            Weight::InvH(a) => write!(f, "1/h_{}", AXES.get(*a).copied().unwrap_or("?")),
            Weight::Field { field, offset } => {
                write!(f, "{field}[{},{},{}]", offset[0], offset[1], offset[2])
            }
            Weight::Add(ws) => {
                for (i, w) in ws.iter().enumerate() {
                    let (neg, w) = signed(w);
                    match (i, neg) {
                        (0, false) => {}
                        (0, true) => write!(f, "-")?,
                        (_, false) => write!(f, " + ")?,
                        (_, true) => write!(f, " - ")?,
                    }
                    factor(f, &w)?;
                }
                Ok(())
            }
            Weight::Mul(ws) => {
                let (neg, w) = signed(self);
                if neg {
                    write!(f, "-")?;
                    return factor(f, &w);
                }
                for (i, w) in ws.iter().enumerate() {
                    if i > 0 {
                        write!(f, "*")?;
                    }
                    factor(f, w)?;
                }
                Ok(())
            }
            Weight::Recip(w) => match w.as_ref() {
                Weight::Add(_) | Weight::Mul(_) => write!(f, "1/({w})"),
                _ => write!(f, "1/{w}"),
            },
        }
    }
}

impl Weight {
    /// Every field reference (with its offset) that the weight reads.
    pub fn fields(&self, out: &mut Vec<(FieldRef, HalfOffset)>) {
        match self {
            Weight::Const(_) | Weight::InvH(_) => {}
            Weight::Field { field, offset } => out.push((field.clone(), *offset)),
            Weight::Add(ws) | Weight::Mul(ws) => ws.iter().for_each(|w| w.fields(out)),
            Weight::Recip(w) => w.fields(out),
        }
    }
}
