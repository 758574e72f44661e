//! The derivation proper: project the RTE onto a real basis function `Y_{l,m}` and apply
//! the `cas` passes until no angular variable is left (docs/design.md §2, §2.1).
//!
//! Steps (each recorded with its expression tree when asked to):
//! 1. the RTE with all terms on the left;
//! 2. projection onto `Y_{l,m}(ω)`: `∫ Y_{l,m} (…) dω`;
//! 3. substitution of the truncated real expansions of `L(x,ω)`, `L(x,ω')` and of `Q`;
//! 4. linearity: expand, split integrals/sums/derivatives, pull constants out;
//! 5. Funk–Hecke for the scattering integral;
//! 6. real → complex basis for basis functions with known sign of `m` (the test function);
//! 7. the recursion relations for `ω_d Y_l^m`;
//! 8. the recursion coefficients' closed forms;
//! 9. complex → real basis;
//! 10. orthonormality of the real basis;
//! 11. Kronecker-delta collapse of the expansion sums;
//! 12. collecting like terms (the imaginary unit must cancel).

use cas::index::Assumptions;
use cas::passes::{
    collect::collect, delta::collapse_deltas, funk_hecke::funk_hecke, normalize,
    orthonormality::orthonormality, sh_convert, sh_recursion, subst::replace,
};
use cas::{DirVar, Expr, ShKind};

use super::rte;

/// One recorded step of a derivation.
#[derive(Clone, Debug)]
pub struct Step {
    /// Short title, e.g. "Orthonormality".
    pub title: String,
    /// What was done, in a sentence (LaTeX allowed).
    pub description: String,
    /// Left-hand side after the step.
    pub lhs: Expr,
    /// Right-hand side after the step.
    pub rhs: Expr,
}

/// Options of one derivation run.
pub struct Setup {
    /// Band of the test function (concrete `Int` or symbolic `Index`).
    pub l: Expr,
    /// Order of the test function.
    pub m: Expr,
    /// Upper bound of the expansion of `L` (`None`: untruncated, general form).
    pub order: Option<Expr>,
    /// Sign assumptions on symbolic indices.
    pub assume: Assumptions,
    /// Whether the recursion coefficients are replaced by their closed forms.
    pub define_coefficients: bool,
    /// Record the intermediate steps.
    pub record: bool,
}

/// Result: the final sides and, if recorded, the steps.
pub struct Derived {
    /// Final left-hand side.
    pub lhs: Expr,
    /// Final right-hand side.
    pub rhs: Expr,
    /// Recorded steps (empty unless `Setup::record`).
    pub steps: Vec<Step>,
}

struct Recorder {
    on: bool,
    steps: Vec<Step>,
}

impl Recorder {
    fn push(&mut self, title: &str, description: &str, lhs: &Expr, rhs: &Expr) {
        if self.on {
            self.steps.push(Step {
                title: title.into(),
                description: description.into(),
                lhs: lhs.clone(),
                rhs: rhs.clone(),
            });
        }
    }
}

/// Applies `f` to both sides.
fn both(lhs: &mut Expr, rhs: &mut Expr, f: &dyn Fn(&Expr) -> Expr) {
    *lhs = f(lhs);
    *rhs = f(rhs);
}

/// Runs the derivation for one test function.
pub fn derive(setup: &Setup) -> Derived {
    let mut rec = Recorder {
        on: setup.record,
        steps: Vec::new(),
    };
    let mut lhs = Expr::Add(rte::lhs_terms().to_vec());
    let mut rhs = rte::emission();
    rec.push(
        "Radiative transfer equation",
        "All terms of $(\\omega\\cdot\\nabla) L = -\\sigma_t L + \\sigma_s \\int p L' + Q$ except the emission moved to the left.",
        &lhs,
        &rhs,
    );

    project_and_expand(setup, (&mut lhs, &mut rhs), &mut rec);
    separate_the_angles(setup, (&mut lhs, &mut rhs), &mut rec);
    back_to_real_moments(setup, (&mut lhs, &mut rhs), &mut rec);

    Derived {
        lhs,
        rhs,
        steps: rec.steps,
    }
}

/// Steps 2–3: projection onto the test function and the expansions of `L` and `Q`.
fn project_and_expand(setup: &Setup, (lhs, rhs): (&mut Expr, &mut Expr), rec: &mut Recorder) {
    let test = Expr::sh(
        ShKind::Real,
        setup.l.clone(),
        setup.m.clone(),
        DirVar::Omega,
    );
    both(lhs, rhs, &|e| {
        Expr::integral(DirVar::Omega, Expr::Mul(vec![test.clone(), e.clone()]))
    });
    rec.push(
        "Projection",
        "Multiply by the real basis function $Y_{l,m}(\\omega)$ and integrate over the sphere.",
        lhs,
        rhs,
    );

    let l_omega = rte::expansion("L", DirVar::Omega, setup.order.clone());
    let l_prime = rte::expansion("L", DirVar::OmegaPrime, setup.order.clone());
    let q_omega = rte::expansion("Q", DirVar::Omega, None);
    both(lhs, rhs, &|e| {
        replace(e, &|n| {
            if *n == rte::radiance(DirVar::Omega) {
                Some(l_omega.clone())
            } else if *n == rte::radiance(DirVar::OmegaPrime) {
                Some(l_prime.clone())
            } else if *n == rte::emission() {
                Some(q_omega.clone())
            } else {
                None
            }
        })
    });
    rec.push(
        "Spherical-harmonic expansion",
        "Substitute the truncated real expansion of the radiance (moments above $N$ are dropped) and the expansion of the emission.",
        lhs,
        rhs,
    );
}

/// Steps 4–8: linearity, Funk–Hecke, the complex basis, the recursion relations and (if
/// asked) the closed forms of their coefficients.
fn separate_the_angles(setup: &Setup, (lhs, rhs): (&mut Expr, &mut Expr), rec: &mut Recorder) {
    let assume = &setup.assume;
    both(lhs, rhs, &normalize);
    rec.push(
        "Linearity",
        "Expand products, split integrals, sums and derivatives over sums, move sums outwards and pull factors that do not depend on the integration variable (or summation index, or position) out.",
        lhs,
        rhs,
    );

    both(lhs, rhs, &|e| normalize(&funk_hecke(e)));
    rec.push(
        "Funk--Hecke",
        "$\\int p(\\omega'\\cdot\\omega) Y_{l',m'}(\\omega') \\,\\mathrm{d}\\omega' = \\lambda_{l'} p_{l'} Y_{l',m'}(\\omega)$.",
        lhs,
        rhs,
    );

    both(lhs, rhs, &|e| {
        normalize(&sh_convert::real_to_complex(e, assume))
    });
    rec.push(
        "Real to complex basis",
        "Write the test function in the complex basis with the Condon--Shortley phase (docs/design.md \\S 2).",
        lhs,
        rhs,
    );

    both(lhs, rhs, &|e| normalize(&sh_recursion::apply_recursion(e)));
    rec.push(
        "Recursion relations",
        "Replace $\\omega_d Y_l^m$ by the recursion relations (docs/design.md \\S 2.1).",
        lhs,
        rhs,
    );

    if setup.define_coefficients {
        both(lhs, rhs, &|e| {
            collect(&normalize(&sh_recursion::define_coefficients(e)))
        });
        rec.push(
            "Recursion coefficients",
            "Evaluate the coefficients $a_{l,m},\\dots,f_{l,m}$ exactly and collect like terms.",
            lhs,
            rhs,
        );
    }
}

/// Steps 9–12: back to the real basis, orthonormality, the Kronecker deltas and like terms.
fn back_to_real_moments(setup: &Setup, (lhs, rhs): (&mut Expr, &mut Expr), rec: &mut Recorder) {
    let assume = &setup.assume;
    both(lhs, rhs, &|e| {
        collect(&normalize(&sh_convert::complex_to_real(e, assume)))
    });
    rec.push(
        "Complex to real basis",
        "Write the complex basis functions in the real basis again and collect like terms.",
        lhs,
        rhs,
    );

    both(lhs, rhs, &|e| normalize(&orthonormality(e)));
    rec.push(
        "Orthonormality",
        "$\\int Y_{l,m} Y_{l',m'} \\,\\mathrm{d}\\omega = \\delta_{l,l'}\\delta_{m,m'}$.",
        lhs,
        rhs,
    );

    both(lhs, rhs, &|e| {
        let mut cur = e.clone();
        loop {
            let next = normalize(&collapse_deltas(&cur));
            if next == cur {
                return cur;
            }
            cur = next;
        }
    });
    rec.push(
        "Kronecker deltas",
        "Collapse the sums over $l'$ and $m'$ against the deltas; terms outside $0\\le l'\\le N$ vanish (P$_N$ closure).",
        lhs,
        rhs,
    );

    both(lhs, rhs, &collect);
    rec.push(
        "Collect like terms",
        "Add the coefficients of equal moments; the imaginary unit cancels.",
        lhs,
        rhs,
    );
}
