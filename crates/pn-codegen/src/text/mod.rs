//! Linear PDE systems written as text, parsed into `cas` expressions and then placed and
//! discretized by the same pipeline as the derived P_N equations (docs/pde-text.md).
//!
//! # Grammar
//!
//! One statement per line (a line continues while parentheses are open or when it ends with
//! an operator); `#` starts a comment.
//!
//! ```text
//! pde NAME                              name of the system (stencil `pde_NAME_3d`)
//! param NAME = EXPR                     a number; `--pde-param NAME=VALUE` overrides it
//! let NAME = EXPR                       a definition, substituted where NAME is used
//! let NAME(a, b) = EXPR                 a definition with arguments
//! unknown NAME [= L(l, m)] [at (sx, sy, sz)]
//!                                       an unknown; `= L(l, m)` says it is that radiance
//!                                       moment, `at` fixes its half-cell shifts (else they
//!                                       are derived from the couplings, docs/design.md §3)
//! equation TARGET: LHS = RHS            the equation located at TARGET (a name or L(l, m))
//! add TARGET: EXPR                      adds EXPR to the left-hand side of TARGET's equation
//! boundary KIND TARGET: LHS = RHS       a boundary condition of kind KIND (`marshak`: what
//!                                       `--bc marshak` applies) stated for the unknown
//!                                       TARGET, linear in the unknowns' face values and
//!                                       their outward normal derivatives `dn(e)`
//! eliminate TARGET                      solves TARGET's equation (c·TARGET + terms without
//!                                       it = 0, TARGET not differentiated, c free of
//!                                       unknowns) for TARGET and substitutes it into every
//!                                       other equation; TARGET leaves the system
//! include pn(N)                         the derived real P_N unknowns L(l, m), l ≤ N, and
//!                                       their equations
//! for v = LO..HI [, w = LO..HI]: STMT   repeats STMT (unknown, equation, add, boundary,
//!                                       eliminate or for)
//! ```
//!
//! Expressions: numbers (decimals are exact rationals), `+ - * / ^`, parentheses;
//! `sigma_t`, `sigma_s`, `sigma_a`, `phase(l)` (λ_l p_l of the phase function, `g^l` for
//! Henyey–Greenstein), `Q(l, m)` (the source's real-basis moment), `L(l, m)`, unknown names,
//! `pi`; `dx(e)`, `dy(e)`, `dz(e)`, `grad(e)`, `div(v)`, `lap(e)`; `sum(k = LO..HI, e)`;
//! `exp`, `ln`, `sqrt`, `sin`, `cos`, `abs` of constants. Indices (`l`, `m`, loop bounds)
//! must evaluate to integers.
//!
//! Boundary conditions are square like the system: once a kind has a condition, every
//! unknown has exactly one of that kind, each `Σ a_j u_j + Σ b_k dn(u_k) = 0` with
//! coefficients free of unknowns ([`TextPde::boundary`], applied by the runtime's
//! `robin` module to the faces of that kind).
//!
//! Unknowns without `= L(l, m)` are auxiliary: they get moment labels no radiance moment
//! uses (in storage slots beyond the highest band, with l+m even so that the 2D reduction
//! keeps them) and are reported by name.

mod lex;
mod lower;
mod parse;

pub use lex::Pos;

use crate::discretize;
use crate::pde::PdeSystem;
use crate::placement;
use pn_stencil::{Dim, MomentPlacement, StencilError, StencilIr};

/// A parse, lowering or placement error with its position in the source.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct PdeTextError {
    /// Line (1-based; 0 when the error concerns the whole file).
    pub line: usize,
    /// Column (1-based; 0 when the error concerns the whole file).
    pub col: usize,
    /// What is wrong.
    pub message: String,
}

impl PdeTextError {
    /// An error at `pos`.
    pub fn at(pos: Pos, message: impl Into<String>) -> PdeTextError {
        PdeTextError {
            line: pos.line,
            col: pos.col,
            message: message.into(),
        }
    }
}

impl std::fmt::Display for PdeTextError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        if self.line == 0 {
            write!(f, "{}", self.message)
        } else {
            write!(
                f,
                "line {}, column {}: {}",
                self.line, self.col, self.message
            )
        }
    }
}

impl std::error::Error for PdeTextError {}

/// One unknown of a text PDE.
#[derive(Clone, Debug, PartialEq)]
pub struct TextUnknown {
    /// The name it was declared with (`L(l,m)` for moments from `include pn`).
    pub name: String,
    /// The moment label `(l, m)` it is stored under.
    pub label: (i64, i64),
    /// Whether it is a radiance moment (`= L(l, m)` or from `include pn`); auxiliary
    /// unknowns are not.
    pub radiance: bool,
    /// An explicit placement from `at (…)`.
    pub at: Option<[u8; 3]>,
    /// Where it was declared.
    pub pos: Pos,
}

/// One `boundary` statement, lowered: `Σ value_j u_j + Σ normal_k ∂_n u_k = 0` with
/// `cas` coefficients (free of unknowns) and the unknowns by label.
#[derive(Clone, Debug, PartialEq)]
pub struct TextBoundary {
    /// The boundary kind (`marshak`).
    pub kind: String,
    /// The label of the unknown the condition is stated for.
    pub target: (i64, i64),
    /// `(label, coefficient)` of the face values.
    pub value: Vec<((i64, i64), cas::Expr)>,
    /// `(label, coefficient)` of the outward normal derivatives `dn(u)`.
    pub normal: Vec<((i64, i64), cas::Expr)>,
    /// Where the statement is.
    pub pos: Pos,
}

/// A parsed text PDE: the system in `cas` form plus what the placement and error messages
/// need.
#[derive(Clone, Debug, PartialEq)]
pub struct TextPde {
    /// The system (unknowns labelled as in [`TextUnknown::label`]); `name` is the text's
    /// `pde NAME`.
    pub system: PdeSystem,
    /// The unknowns, in the order of `system.unknowns`.
    pub unknowns: Vec<TextUnknown>,
    /// Where each equation (in the order of `system.equations`) was written.
    pub equation_pos: Vec<Pos>,
    /// The parameters and their values (after overrides), in declaration order.
    pub params: Vec<(String, f64)>,
    /// The `boundary` statements, in the order written.
    pub boundaries: Vec<TextBoundary>,
}

/// Parses `src` with parameter overrides `params` (each must be declared by `param`).
pub fn parse_pde(src: &str, params: &[(String, String)]) -> Result<TextPde, PdeTextError> {
    let tokens = lex::tokenize(src)?;
    let stmts = parse::parse(&tokens)?;
    let pde = lower::lower(&stmts, params)?;
    check_square(&pde)?;
    Ok(pde)
}

/// Every unknown has exactly one equation and every equation is located at an unknown
/// (the lowering already refused duplicates and unknown targets).
fn check_square(pde: &TextPde) -> Result<(), PdeTextError> {
    if pde.unknowns.is_empty() {
        return Err(PdeTextError {
            line: 0,
            col: 0,
            message: "the PDE declares no unknowns".into(),
        });
    }
    for u in &pde.unknowns {
        if !pde.system.equations.iter().any(|e| (e.l, e.m) == u.label) {
            return Err(PdeTextError::at(
                u.pos,
                format!(
                    "the system is not square: unknown {} has no equation ({} unknowns, {} equations)",
                    u.name,
                    pde.unknowns.len(),
                    pde.system.equations.len()
                ),
            ));
        }
    }
    Ok(())
}

impl TextPde {
    /// The stencil name, `pde_<name>_<d>d`.
    pub fn stencil_name(&self, dim: Dim) -> String {
        format!("pde_{}_{}d", self.system.name, dim.axes())
    }

    /// The system in dimension `dim` with the indices of the unknowns kept (2D: the
    /// reduction of docs/design.md §3, [`PdeSystem::reduce_2d`]).
    fn system_in(&self, dim: Dim) -> (PdeSystem, Vec<usize>) {
        match dim {
            Dim::Three => (self.system.clone(), (0..self.unknowns.len()).collect()),
            Dim::Two => {
                let sys = self.system.reduce_2d();
                let kept = sys
                    .unknowns
                    .iter()
                    .filter_map(|lm| self.unknowns.iter().position(|u| u.label == *lm))
                    .collect();
                (sys, kept)
            }
        }
    }

    /// The staggered placement in `dim`: derived from the couplings (docs/design.md §3),
    /// with every connected component moved so that its explicitly placed unknowns sit
    /// where `at (…)` says. Errors name the equation whose coupling cannot be satisfied.
    pub fn placement(&self, dim: Dim) -> Result<Vec<MomentPlacement>, PdeTextError> {
        let (sys, kept) = self.system_in(dim);
        let mut placed = match placement::derive_staggered(&sys) {
            Ok(p) => p,
            Err(e) => return Err(self.locate_placement_error(&sys, e)),
        };
        // Connected components of the coupling graph.
        let n = sys.unknowns.len();
        let mut comp: Vec<usize> = (0..n).collect();
        fn root(c: &mut [usize], i: usize) -> usize {
            let mut r = i;
            while c[r] != r {
                r = c[r];
            }
            c[i] = r;
            r
        }
        for eq in &sys.equations {
            let Some(r) = sys.unknowns.iter().position(|&u| u == (eq.l, eq.m)) else {
                continue;
            };
            let mut cs = Vec::new();
            placement::couplings(&eq.lhs, &mut cs);
            placement::couplings(&eq.rhs, &mut cs);
            for (lm, _) in cs {
                if let Some(q) = sys.unknowns.iter().position(|&u| u == lm) {
                    let (a, b) = (root(&mut comp, r), root(&mut comp, q));
                    comp[a] = b;
                }
            }
        }
        let mut xor: Vec<Option<([u8; 3], usize)>> = vec![None; n];
        for (i, &k) in kept.iter().enumerate() {
            let u = &self.unknowns[k];
            let Some(mut want) = u.at else { continue };
            if dim == Dim::Two && want[2] != 0 {
                return Err(PdeTextError::at(
                    u.pos,
                    format!("{} is placed at a z shift, but the problem is 2D", u.name),
                ));
            }
            if dim == Dim::Two {
                want[2] = 0;
            }
            let s = placed[i].shift;
            let x = [want[0] ^ s[0], want[1] ^ s[1], want[2] ^ s[2]];
            let c = root(&mut comp, i);
            match xor[c] {
                None => xor[c] = Some((x, k)),
                Some((x0, k0)) if x0 != x => {
                    let other = &self.unknowns[k0];
                    let derived_here = [s[0] ^ x0[0], s[1] ^ x0[1], s[2] ^ x0[2]];
                    return Err(PdeTextError::at(
                        u.pos,
                        format!(
                            "{} cannot be at {:?}: with {} at {:?} (line {}) the couplings place it at {:?}",
                            u.name,
                            want,
                            other.name,
                            other.at.unwrap_or_default(),
                            other.pos.line,
                            derived_here
                        ),
                    ));
                }
                Some(_) => {}
            }
        }
        for i in 0..n {
            if let Some((x, _)) = xor[root(&mut comp, i)] {
                let s = &mut placed[i].shift;
                for d in 0..3 {
                    s[d] ^= x[d];
                }
            }
        }
        Ok(placed)
    }

    /// Finds the first equation after which the placement constraints become inconsistent.
    fn locate_placement_error(&self, sys: &PdeSystem, err: StencilError) -> PdeTextError {
        let message = self.rename(&err.to_string());
        for k in 1..=sys.equations.len() {
            let partial = PdeSystem {
                equations: sys.equations[..k].to_vec(),
                ..sys.clone()
            };
            if placement::derive_staggered(&partial).is_err() {
                let eq = &sys.equations[k - 1];
                let pos = self
                    .system
                    .equations
                    .iter()
                    .position(|e| (e.l, e.m) == (eq.l, eq.m))
                    .map(|i| self.equation_pos[i])
                    .unwrap_or_default();
                return PdeTextError::at(
                    pos,
                    format!(
                        "the unknowns cannot be placed consistently on the staggered grid: {message} \
                         (an even number of derivatives must join unknowns on the same grid, an odd \
                         number unknowns half a cell apart)"
                    ),
                );
            }
        }
        PdeTextError {
            line: 0,
            col: 0,
            message,
        }
    }

    /// Replaces `L_l^m` labels in a message by the unknowns' names.
    fn rename(&self, msg: &str) -> String {
        let mut out = msg.to_string();
        for u in &self.unknowns {
            let (l, m) = u.label;
            out = out.replace(&format!("L_{l}^{m} "), &format!("{} ", u.name));
            out = out.replace(&format!("L_{l}^{m})"), &format!("{})", u.name));
            out = out.replace(&format!("L_{l}^{m},"), &format!("{},", u.name));
        }
        out
    }

    /// The discretized stencil in `dim` on the (derived or explicit) staggered placement.
    /// A term the discretizer cannot handle (a product of unknowns, a non-integer power of a
    /// field) is reported at the equation it is in.
    pub fn ir(&self, dim: Dim) -> Result<StencilIr, PdeTextError> {
        let moments = self.placement(dim)?;
        let (sys, _) = self.system_in(dim);
        discretize::discretize(&sys, moments.clone(), self.stencil_name(dim))
            .map_err(|e| self.locate_discretize_error(&sys, &moments, e))
    }

    /// Discretizes one equation at a time (the others replaced by `u = 0`) to find the
    /// equation a discretization error comes from.
    fn locate_discretize_error(
        &self,
        sys: &PdeSystem,
        moments: &[MomentPlacement],
        err: StencilError,
    ) -> PdeTextError {
        let message = self.rename(&err.to_string());
        for (k, eq) in sys.equations.iter().enumerate() {
            let mut trial = sys.clone();
            for (j, e) in trial.equations.iter_mut().enumerate() {
                if j != k {
                    e.lhs = cas::Expr::moment(e.l, e.m);
                    e.rhs = cas::Expr::int(0);
                }
            }
            if discretize::discretize(&trial, moments.to_vec(), "probe").is_err() {
                let pos = self
                    .system
                    .equations
                    .iter()
                    .position(|e| (e.l, e.m) == (eq.l, eq.m))
                    .map(|i| self.equation_pos[i])
                    .unwrap_or_default();
                return PdeTextError::at(pos, message);
            }
        }
        PdeTextError {
            line: 0,
            col: 0,
            message,
        }
    }

    /// The boundary conditions of kind `kind` in `dim`, with the unknowns indexed as in
    /// [`TextPde::ir`]'s moments and the coefficients as [`pn_stencil::Weight`]s read at the
    /// face point; `None` when the PDE states none of that kind. In 2D, unknowns the
    /// reduction drops (l+m odd moments) are dropped from the conditions too, with their own
    /// conditions. A coefficient that cannot be evaluated (a derivative, an unknown) is
    /// reported at its statement.
    pub fn boundary(
        &self,
        dim: Dim,
        kind: &str,
    ) -> Result<Option<pn_stencil::robin::RobinBoundary>, PdeTextError> {
        use pn_stencil::robin::{RobinBoundary, RobinCondition};
        let (sys, _) = self.system_in(dim);
        let index = |lm: (i64, i64)| sys.unknowns.iter().position(|&u| u == lm);
        let mut conditions = Vec::new();
        for b in self.boundaries.iter().filter(|b| b.kind == kind) {
            let Some(target) = index(b.target) else {
                continue;
            };
            let weights = |terms: &[((i64, i64), cas::Expr)]| {
                let mut merged: Vec<(usize, Vec<cas::Expr>)> = Vec::new();
                for (lm, c) in terms {
                    let Some(q) = index(*lm) else { continue };
                    match merged.iter_mut().find(|(k, _)| *k == q) {
                        Some((_, cs)) => cs.push(c.clone()),
                        None => merged.push((q, vec![c.clone()])),
                    }
                }
                let mut out = Vec::new();
                for (q, cs) in merged {
                    let w = discretize::coefficient_weight(&cas::Expr::add(cs), dim)
                        .map_err(|e| PdeTextError::at(b.pos, self.rename(&e.to_string())))?;
                    if let Some(w) = w {
                        out.push((q, w));
                    }
                }
                Ok::<_, PdeTextError>(out)
            };
            conditions.push(RobinCondition {
                target,
                value: weights(&b.value)?,
                normal: weights(&b.normal)?,
            });
        }
        Ok((!conditions.is_empty()).then(|| RobinBoundary {
            kind: kind.to_string(),
            conditions,
        }))
    }

    /// Whether the unknown labelled `(l, m)` is a radiance moment.
    pub fn is_radiance(&self, l: i64, m: i64) -> bool {
        self.unknowns
            .iter()
            .any(|u| u.label == (l, m) && u.radiance)
    }
}
