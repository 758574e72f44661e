//! Energy balance: source power against absorbed power plus boundary outflow.
//!
//! In units of the fluence φ = √(4π) L_0^0 (docs/design.md §2), per unit length in z for 2D:
//! * source power   `P_Q = √(4π) Σ_cells V Q_0^0(centre)`,
//! * absorbed power `P_A = √(4π) Σ_cells V σ_a(centre) L_0^0`,
//! * outflow        `P_B = ∮ J·n dA` with `J_d = √(4π/3) L_1^{(d)}` (L_1^1 ↔ x, L_1^{−1} ↔ y,
//!   L_1^0 ↔ z). On the staggered grid L_1^{(d)} lives on the d-faces, domain faces
//!   included, so P_B is read directly off the solution ("faces"). For stencils without
//!   face-located first moments (collocated, CDA) the outflow is the telescoped divergence
//!   of the l = 0 row: `√(4π) Σ V ((A u)_{0,0} − σ_a L_0^0)` ("stencil").
//!
//! Integrating the l = 0 equation over the domain gives `P_Q = P_A + P_B`; the reported
//! relative imbalance `|P_Q − P_A − P_B| / P_Q` is small when the l = 0 row is the discrete
//! continuity equation and the solve converged.

use crate::layout::Layout;
use crate::problem::Problem;
use pn_krylov::linalg::spmv;
use sprs::CsMat;

/// The balance terms.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct EnergyBalance {
    /// Source power P_Q.
    pub source_power: f64,
    /// Absorbed power P_A.
    pub absorbed_power: f64,
    /// Boundary outflow P_B.
    pub boundary_outflow: f64,
    /// |P_Q − P_A − P_B| / P_Q (0 when P_Q = 0).
    pub relative_imbalance: f64,
    /// `faces` or `stencil` (see module docs).
    pub outflow_method: String,
}

/// Computes the balance of solution `u`. Returns `None` when the stencil has no
/// centred (0,0) moment, or has no L_1 face moments and `a` (needed for the stencil route
/// of the outflow) is not given.
pub fn energy_balance(
    problem: &Problem,
    layout: &Layout,
    a: Option<&CsMat<f64>>,
    u: &[f64],
) -> Option<EnergyBalance> {
    let grid = &problem.grid;
    let q0 = layout
        .moments
        .iter()
        .position(|m| m.l == 0 && m.m == 0 && m.shift == [0, 0, 0])?;
    let vol = grid.cell_volume();
    let s4pi = (4.0 * std::f64::consts::PI).sqrt();
    let res = grid.res;
    let mut source = 0.0;
    let mut absorbed = 0.0;
    let mut sigma_a = Vec::with_capacity(grid.cells());
    for i in 0..res[0] {
        for j in 0..res[1] {
            for k in 0..res[2] {
                let idx = [i, j, k];
                let half = layout.half_coord(q0, idx);
                let p = [0, 1, 2].map(|d| grid.coord(d, half[d]));
                let c = problem.coefficients(p).ok()?;
                let sa = c.sigma_t - c.sigma_s;
                sigma_a.push(sa);
                source += vol * problem.source(0, 0, p).ok()?;
                absorbed += vol * sa * u[layout.index(q0, idx)];
            }
        }
    }
    source *= s4pi;
    absorbed *= s4pi;

    let axes = grid.dim.axes();
    let first_moment = |d: usize| {
        let m = [1, -1, 0][d];
        let mut shift = [0u8; 3];
        shift[d] = 1;
        layout
            .moments
            .iter()
            .position(|mp| mp.l == 1 && mp.m == m && mp.shift == shift)
    };
    let faces: Option<Vec<usize>> = (0..axes).map(first_moment).collect();
    let (outflow, method) = match faces {
        Some(qs) => {
            let mut total = 0.0;
            for (d, &q) in qs.iter().enumerate() {
                let area: f64 = (0..axes).filter(|&e| e != d).map(|e| grid.h(e)).product();
                let e = layout.extents[q];
                let mut sum = 0.0;
                for a_ in 0..e[(d + 1) % 3] {
                    for b_ in 0..e[(d + 2) % 3] {
                        let mut lo = [0usize; 3];
                        lo[(d + 1) % 3] = a_;
                        lo[(d + 2) % 3] = b_;
                        let mut hi = lo;
                        hi[d] = e[d] - 1;
                        sum += u[layout.index(q, hi)] - u[layout.index(q, lo)];
                    }
                }
                total += area * sum;
            }
            ((4.0 * std::f64::consts::PI / 3.0).sqrt() * total, "faces")
        }
        None => {
            let mut au = vec![0.0; u.len()];
            spmv(a?, u, &mut au);
            let mut div = 0.0;
            let mut c = 0usize;
            for i in 0..res[0] {
                for j in 0..res[1] {
                    for k in 0..res[2] {
                        let g = layout.index(q0, [i, j, k]);
                        div += au[g] - sigma_a[c] * u[g];
                        c += 1;
                    }
                }
            }
            (s4pi * vol * div, "stencil")
        }
    };
    let imbalance = if source != 0.0 {
        (source - absorbed - outflow).abs() / source.abs()
    } else {
        0.0
    };
    Some(EnergyBalance {
        source_power: source,
        absorbed_power: absorbed,
        boundary_outflow: outflow,
        relative_imbalance: imbalance,
        outflow_method: method.into(),
    })
}
