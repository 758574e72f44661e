//! The one support module of the runtime's integration tests: an independent P_N stencil
//! built from quadrature, not from the CAS ([`QuadKernel`]); the built-in problems, solver
//! options, the StaRMAP references and the relative difference the tests bound; the FLD
//! test problems ([`fld`]); the Marshak tests' slab ([`marshak`]).
//!
//! The quadrature stencil's equations are docs/design.md §2.2,
//! `Σ_d M^d ∂_d L + (σ_t − σ_s λ_l p_l) L_l^m = Q_l^m`, with
//! `M^d_{(l,m),(l',m')} = ∫ ω_d Y_l^m Y_l'^m' dω` computed by Gauss–Legendre × uniform-φ
//! quadrature (docs/design.md §2.3) in the real basis of docs/design.md §2. Placement
//! follows the rule of docs/design.md §3; a derivative along d becomes
//! `(u[+½e_d] − u[−½e_d])/h_d` (staggered) or `(u[+e_d] − u[−e_d])/(2h_d)` (collocated).
//! For P_1 this is exactly the hand check of docs/design.md §2.2.
#![allow(dead_code)]

pub mod fld;
pub mod marshak;

use pn_stencil::{Dim, FieldContext, FieldRef, MomentPlacement, StencilKernel, TermPattern};
use std::f64::consts::PI;

/// Gauss–Legendre nodes and weights on [−1, 1].
fn gauss_legendre(n: usize) -> Vec<(f64, f64)> {
    (0..n)
        .map(|i| {
            let mut x = (PI * (i as f64 + 0.75) / (n as f64 + 0.5)).cos();
            let mut dp = 0.0;
            for _ in 0..100 {
                let (mut p0, mut p1) = (1.0, x);
                for k in 2..=n {
                    let p2 = ((2 * k - 1) as f64 * x * p1 - (k - 1) as f64 * p0) / k as f64;
                    p0 = p1;
                    p1 = p2;
                }
                dp = n as f64 * (x * p1 - p0) / (x * x - 1.0);
                let dx = p1 / dp;
                x -= dx;
                if dx.abs() < 1e-16 {
                    break;
                }
            }
            (x, 2.0 / ((1.0 - x * x) * dp * dp))
        })
        .collect()
}

/// Associated Legendre P_l^m(x) without the Condon–Shortley phase, m ≥ 0.
fn assoc_legendre(l: i32, m: i32, x: f64) -> f64 {
    let s = (1.0 - x * x).max(0.0).sqrt();
    let mut pmm = 1.0;
    for k in 1..=m {
        pmm *= (2 * k - 1) as f64 * s;
    }
    if l == m {
        return pmm;
    }
    let mut pm1 = x * (2 * m + 1) as f64 * pmm;
    if l == m + 1 {
        return pm1;
    }
    let mut pm0 = pmm;
    for ll in (m + 2)..=l {
        let p = ((2 * ll - 1) as f64 * x * pm1 - (ll + m - 1) as f64 * pm0) / (ll - m) as f64;
        pm0 = pm1;
        pm1 = p;
    }
    pm1
}

fn factorial(n: i32) -> f64 {
    (1..=n).map(|k| k as f64).product()
}

/// Real spherical harmonic of docs/design.md §2 at (cosθ, φ).
pub fn real_ylm(l: i32, m: i32, mu: f64, phi: f64) -> f64 {
    let am = m.abs();
    let k = ((2 * l + 1) as f64 / (4.0 * PI) * factorial(l - am) / factorial(l + am)).sqrt();
    let p = assoc_legendre(l, am, mu);
    match m.signum() {
        1 => 2f64.sqrt() * k * p * (am as f64 * phi).cos(),
        -1 => 2f64.sqrt() * k * p * (am as f64 * phi).sin(),
        _ => k * p,
    }
}

/// `M^d` for the given moments by quadrature; `[d][row][col]`.
pub fn coupling_matrices(moments: &[(i32, i32)]) -> Vec<Vec<Vec<f64>>> {
    let gl = gauss_legendre(16);
    let nphi = 32;
    let n = moments.len();
    let mut out = vec![vec![vec![0.0; n]; n]; 3];
    for &(mu, wmu) in &gl {
        let st = (1.0 - mu * mu).sqrt();
        for k in 0..nphi {
            let phi = 2.0 * PI * (k as f64 + 0.5) / nphi as f64;
            let w = wmu * 2.0 * PI / nphi as f64;
            let omega = [st * phi.cos(), st * phi.sin(), mu];
            let y: Vec<f64> = moments
                .iter()
                .map(|&(l, m)| real_ylm(l, m, mu, phi))
                .collect();
            for d in 0..3 {
                for a in 0..n {
                    for b in 0..n {
                        out[d][a][b] += w * omega[d] * y[a] * y[b];
                    }
                }
            }
        }
    }
    out
}

/// Placement rule of docs/design.md §3.
pub fn placement(l: i32, m: i32) -> [u8; 3] {
    let x = (m > 0 && m % 2 == 1) || (m < 0 && m % 2 == 0);
    let y = m < 0;
    let z = (l + m).rem_euclid(2) == 1;
    [x as u8, y as u8, z as u8]
}

enum Coef {
    /// σ_t − σ_s λ_l p_l at the row position.
    Collision(u32),
    /// `c / h_d`.
    Transport(f64, usize),
}

/// A P_N stencil from quadrature.
pub struct QuadKernel {
    name: String,
    dim: Dim,
    moments: Vec<MomentPlacement>,
    patterns: Vec<Vec<TermPattern>>,
    coefs: Vec<Vec<Coef>>,
}

impl QuadKernel {
    /// P_N on the staggered (or collocated) grid.
    pub fn new(order: i32, dim: Dim, staggered: bool) -> Self {
        let mut lm = Vec::new();
        for l in 0..=order {
            for m in -l..=l {
                if dim == Dim::Three || (l + m) % 2 == 0 {
                    lm.push((l, m));
                }
            }
        }
        let mats = coupling_matrices(&lm);
        let moments: Vec<MomentPlacement> = lm
            .iter()
            .map(|&(l, m)| MomentPlacement {
                l,
                m,
                shift: if staggered { placement(l, m) } else { [0; 3] },
            })
            .collect();
        let mut patterns = Vec::new();
        let mut coefs = Vec::new();
        for (r, &(l, _)) in lm.iter().enumerate() {
            let mut p = vec![TermPattern {
                moment: r,
                offset: [0; 3],
            }];
            let mut c = vec![Coef::Collision(l as u32)];
            for d in 0..dim.axes() {
                for q in 0..lm.len() {
                    let v = mats[d][r][q];
                    if v.abs() < 1e-12 {
                        continue;
                    }
                    let step = if staggered {
                        assert_ne!(
                            moments[r].shift[d], moments[q].shift[d],
                            "placement rule violated"
                        );
                        1
                    } else {
                        2
                    };
                    let scale = if staggered { v } else { v / 2.0 };
                    for sign in [1i32, -1] {
                        let mut off = [0; 3];
                        off[d] = sign * step;
                        p.push(TermPattern {
                            moment: q,
                            offset: off,
                        });
                        c.push(Coef::Transport(sign as f64 * scale, d));
                    }
                }
            }
            patterns.push(p);
            coefs.push(c);
        }
        let name = format!(
            "quad_p{order}_{}_{}",
            dim.axes(),
            if staggered { "staggered" } else { "collocated" }
        );
        Self {
            name,
            dim,
            moments,
            patterns,
            coefs,
        }
    }
}

impl StencilKernel for QuadKernel {
    fn name(&self) -> &str {
        &self.name
    }
    fn dim(&self) -> Dim {
        self.dim
    }
    fn moments(&self) -> &[MomentPlacement] {
        &self.moments
    }
    fn pattern(&self, row: usize) -> &[TermPattern] {
        &self.patterns[row]
    }
    fn eval_row(&self, row: usize, ctx: &dyn FieldContext, weights: &mut [f64]) -> f64 {
        for (w, c) in weights.iter_mut().zip(&self.coefs[row]) {
            *w = match c {
                Coef::Collision(l) => {
                    ctx.field(&FieldRef::SigmaT, [0; 3])
                        - ctx.field(&FieldRef::SigmaS, [0; 3])
                            * ctx.field(&FieldRef::PhaseMoment(*l), [0; 3])
                }
                Coef::Transport(v, d) => v * ctx.inv_h(*d),
            };
        }
        let mp = &self.moments[row];
        ctx.field(
            &FieldRef::Source {
                l: mp.l as u32,
                m: mp.m,
            },
            [0; 3],
        )
    }
}

/// A StaRMAP CSV (rows = x index, columns = y index) as x-slowest values, read by
/// `pn_runtime::reference::starmap::read_csv`; a missing or malformed file fails the test.
pub fn read_csv(path: &std::path::Path) -> Vec<f64> {
    pn_runtime::reference::starmap::read_csv(path).unwrap_or_else(|e| panic!("{e:#}"))
}

/// The checkerboard reference folder `tests/data/checkerboard` of the repository; a missing
/// file fails the test that needs it.
pub fn reference_dir() -> std::path::PathBuf {
    let d = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../tests/data/checkerboard");
    assert!(
        d.join("starmap_p1_n71.csv").is_file() && d.join("starmap_p5_n71.csv").is_file(),
        "checkerboard reference data missing in {}",
        d.display()
    );
    d
}

/// Assembles `problem` with the quadrature stencil of order `order` (staggered).
pub fn system(
    problem: &pn_runtime::problem::Problem,
    order: i32,
) -> (pn_runtime::Layout, pn_runtime::assemble::System) {
    let kernel = QuadKernel::new(order, problem.grid.dim, true);
    let layout = pn_runtime::Layout::new(&problem.grid, kernel.moments()).unwrap();
    let sys = pn_runtime::assemble::assemble(problem, &kernel, &layout).unwrap();
    (layout, sys)
}

/// The built-in scene `name` (`checkerboard`, `pointsource`) in `dim` with `res` cells per
/// axis (one number for all axes), with its default parameters.
pub fn builtin_problem(name: &str, dim: Dim, res: &[usize]) -> pn_runtime::problem::Problem {
    let o = pn_runtime::scenes::BuiltinOptions {
        dim: Some(dim),
        res: Some(res.to_vec()),
        ..Default::default()
    };
    pn_runtime::scenes::builtin(name, &o).unwrap().problem
}

/// The kernel of the shipped PDE file `pdes/<file>` with parameter overrides `params`.
pub fn pde_file_kernel(
    file: &str,
    params: &[(&str, String)],
    dim: Dim,
) -> pn_kernels::KernelChoice {
    let path = format!("{}/../../pdes/{file}", env!("CARGO_MANIFEST_DIR"));
    let src = std::fs::read_to_string(&path).unwrap();
    let params: Vec<(String, String)> = params
        .iter()
        .map(|(k, v)| (k.to_string(), v.clone()))
        .collect();
    let pde = pn_codegen::text::parse_pde(&src, &params).unwrap();
    pn_kernels::pde_kernel(&pde, dim).unwrap()
}

/// Solver options with tolerance `tol` and no progress bar.
pub fn opts(tol: f64) -> pn_runtime::solver::SolverOptions {
    pn_runtime::solver::SolverOptions {
        tol,
        ..Default::default()
    }
}

/// max|a − b| / max|b| over all entries; the two must have the same length.
pub fn rel_diff(a: &[f64], b: &[f64]) -> f64 {
    assert_eq!(a.len(), b.len());
    let m = b.iter().fold(0.0f64, |x, y| x.max(y.abs()));
    a.iter()
        .zip(b)
        .map(|(x, y)| (x - y).abs())
        .fold(0.0, f64::max)
        / m
}
