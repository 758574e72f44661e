//! Restriction, block averages, observed orders and Richardson estimates
//! (`pn_runtime::convergence`) on fields with known answers.
#![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)] // test code

use pn_runtime::convergence::{
    analyse, block_averages, check_nesting, observed_order, rel_l2_diff, restrict, richardson,
    solve_order, Level,
};
use pn_runtime::problem::Grid;
use pn_stencil::Dim;

/// Cell-centred samples of `f` on an `res` grid over [0,7]² (2D) or [0,7]³.
fn sample(res: [usize; 3], f: impl Fn([f64; 3]) -> f64) -> Vec<f64> {
    let h = res.map(|n| 7.0 / n as f64);
    let mut v = Vec::new();
    for i in 0..res[0] {
        for j in 0..res[1] {
            for k in 0..res[2] {
                v.push(f([
                    (i as f64 + 0.5) * h[0],
                    (j as f64 + 0.5) * h[1],
                    (k as f64 + 0.5) * h[2],
                ]));
            }
        }
    }
    v
}

/// Exact cell averages of u(x, y) = cos(0.9x)·e^{0.4y} on an `res` grid over [0,7]²
/// (restriction maps the fine averages exactly to the coarse ones, so a model built on them
/// has no sampling error of its own).
fn cell_avg_u(res: [usize; 3]) -> Vec<f64> {
    let h = res.map(|n| 7.0 / n as f64);
    let ix = |a: f64, b: f64| ((0.9 * b).sin() - (0.9 * a).sin()) / 0.9 / (b - a);
    let iy = |a: f64, b: f64| ((0.4 * b).exp() - (0.4 * a).exp()) / 0.4 / (b - a);
    let mut v = Vec::new();
    for i in 0..res[0] {
        for j in 0..res[1] {
            let (x0, y0) = (i as f64 * h[0], j as f64 * h[1]);
            v.push(ix(x0, x0 + h[0]) * iy(y0, y0 + h[1]));
        }
    }
    v
}

fn max_diff(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).fold(0.0, |m, (x, y)| m.max((x - y).abs()))
}

/// A constant and a linear field restrict exactly: the coarse cell mean of a linear function
/// sampled at the children's centres is its value at the coarse centre. 1e-13: a handful of
/// roundings on values of size ~10.
#[test]
fn restriction_of_constant_and_linear_fields_is_exact() {
    let lin = |p: [f64; 3]| 1.5 + 2.0 * p[0] - 0.7 * p[1] + 0.3 * p[2];
    for (fine, coarse) in [([42, 42, 1], [14, 14, 1]), ([12, 18, 6], [6, 6, 3])] {
        let c = restrict(&sample(fine, |_| 3.25), fine, coarse).unwrap();
        assert!(c.iter().all(|v| *v == 3.25));
        let c = restrict(&sample(fine, lin), fine, coarse).unwrap();
        assert!(max_diff(&c, &sample(coarse, lin)) < 1e-13);
    }
    // Ratio 1 is the identity; non-nesting grids are an error, not a panic.
    let v = sample([5, 5, 1], lin);
    assert_eq!(restrict(&v, [5, 5, 1], [5, 5, 1]).unwrap(), v);
    assert!(restrict(&v, [5, 5, 1], [2, 5, 1]).is_err());
    assert!(restrict(&v[1..], [5, 5, 1], [5, 5, 1]).is_err());
    assert!(check_nesting(&[[71, 71, 1], [142, 142, 1], [284, 284, 1]]).is_ok());
    assert!(check_nesting(&[[71, 71, 1], [100, 100, 1]]).is_err());
    assert!(check_nesting(&[[142, 142, 1], [71, 71, 1]]).is_err());
}

/// Block averages: on a grid that nests the blocks they equal the restriction; on one that
/// does not (cells cut by block faces) they conserve the integral and average a constant
/// exactly.
#[test]
fn block_averages_weight_cells_by_overlap() {
    let grid = |n: usize| Grid {
        dim: Dim::Two,
        min: [0.0; 3],
        max: [7.0; 3],
        res: [n, n, 1],
    };
    let f = |p: [f64; 3]| (p[0] * 1.3).sin() + p[1] * p[1];
    let v = sample([21, 21, 1], f);
    let b = block_averages(&v, &grid(21), [7, 7, 1]).unwrap();
    let r = restrict(&v, [21, 21, 1], [7, 7, 1]).unwrap();
    assert!(max_diff(&b, &r) < 1e-13);

    let v = sample([10, 10, 1], f);
    let b = block_averages(&v, &grid(10), [7, 7, 1]).unwrap();
    let cell = (0.7f64).powi(2);
    let total_cells: f64 = v.iter().sum::<f64>() * cell;
    let total_blocks: f64 = b.iter().sum::<f64>();
    assert!((total_cells - total_blocks).abs() < 1e-12 * total_cells);
    let c = block_averages(&vec![2.5; 100], &grid(10), [7, 7, 1]).unwrap();
    assert!(c.iter().all(|x| (x - 2.5).abs() < 1e-14));
    // Block (0,0) = [0,1]²: cell 0 ([0,0.7]) fully, cell 1 ([0.7,1.4]) for 0.3 of its 0.7.
    let w = [0.7, 0.3];
    let mut s = 0.0;
    for i in 0..2 {
        for j in 0..2 {
            s += w[i] * w[j] * v[i * 10 + j];
        }
    }
    assert!((b[0] - s).abs() < 1e-13);
}

/// A synthetic sequence u_h = ū + C h^p g + noise (ū: cell averages, g bilinear) on nested
/// grids whose faces include the block faces (n = 14, 28, 56; on grids that cut blocks the
/// block averages of cell values carry an O(h) error of their own): the observed order from
/// three levels recovers p. Noise of relative size 1e-4 of the smallest error moves
/// log(d12/d23)/log 2 by ≲ 1e-3, so 0.01 is a tolerance the estimate must meet.
#[test]
fn observed_order_recovers_a_known_order() {
    let g = |p: [f64; 3]| 1.0 + p[0] * p[1] / 49.0;
    // Deterministic pseudo-noise.
    let noise = |i: usize| ((i as f64 * 12.9898).sin() * 43758.5453).fract() - 0.5;
    for &order in &[1.0, 1.5, 2.0, 3.0] {
        let levels: Vec<Level> = [14usize, 28, 56]
            .iter()
            .map(|&n| {
                let h = 7.0 / n as f64;
                let amp = 0.3 * h.powf(order);
                let gs = sample([n, n, 1], g);
                let fluence = cell_avg_u([n, n, 1])
                    .iter()
                    .zip(&gs)
                    .enumerate()
                    .map(|(i, (v, gv))| {
                        v + amp * gv + 1e-4 * 0.3 * (7.0f64 / 56.0).powf(order) * noise(i)
                    })
                    .collect();
                Level {
                    res: [n, n, 1],
                    unknowns: n * n,
                    seconds: 0.0,
                    fluence,
                }
            })
            .collect();
        let domain = Grid {
            dim: Dim::Two,
            min: [0.0; 3],
            max: [7.0; 3],
            res: [14, 14, 1],
        };
        let t = analyse(&levels, &domain, Some([7, 7, 1])).unwrap();
        let p = t.rows[2].order_successive.unwrap();
        assert!((p - order).abs() < 0.01, "order {order}: observed {p}");
        let pb = t.rows[2].order_successive_blocks.unwrap();
        assert!((pb - order).abs() < 0.01, "order {order}: blocks {pb}");
        // Against the finest level the same model gives the same order (solve_order accounts
        // for the finest level's own error).
        let pf = t.rows[1].order_vs_finest.unwrap();
        assert!((pf - order).abs() < 0.02, "order {order}: vs finest {pf}");
        // The Richardson estimate of the finest level (observed p) matches its true error
        // ‖u_56 − u‖/‖u_56‖ on the coarsest grid within 2%.
        let exact = cell_avg_u([14, 14, 1]);
        let fine = restrict(&levels[2].fluence, [56, 56, 1], [14, 14, 1]).unwrap();
        let truth = rel_l2_diff(&fine, &exact) * rel_l2_diff(&exact, &vec![0.0; 196])
            / rel_l2_diff(&fine, &vec![0.0; 196]);
        let est = t.rows[2].richardson.unwrap();
        assert!(
            (est / truth - 1.0).abs() < 0.02,
            "order {order}: {est} vs {truth}"
        );
    }
    // Unequal ratios (h, h/2, h/6) with d = C h^p exactly.
    let p = 1.7;
    let h: [f64; 3] = [1.0, 0.5, 1.0 / 6.0];
    let d12 = h[0].powf(p) - h[1].powf(p);
    let d23 = h[1].powf(p) - h[2].powf(p);
    assert!((observed_order(h, d12, d23).unwrap() - p).abs() < 1e-10);
    assert!((solve_order([h[0], h[1], h[1], h[2]], d12 / d23).unwrap() - p).abs() < 1e-10);
}

/// Richardson with the exact model u_h = ū + h² e (ū cell averages, e linear) is exact per
/// cell (1e-13: rounding of values ~10).
#[test]
fn richardson_is_exact_for_the_model() {
    let e = |p: [f64; 3]| 0.1 * p[1];
    let (hf, hc) = (7.0 / 20.0, 7.0 / 10.0);
    let add = |u: Vec<f64>, n: usize, h: f64| -> Vec<f64> {
        u.iter()
            .zip(sample([n, n, 1], e))
            .map(|(a, b)| a + h * h * b)
            .collect()
    };
    let fine = add(cell_avg_u([20, 20, 1]), 20, hf);
    let coarse = add(cell_avg_u([10, 10, 1]), 10, hc);
    let fr = restrict(&fine, [20, 20, 1], [10, 10, 1]).unwrap();
    let est = richardson(&fr, &coarse, 2.0, 2.0, "exact model");
    // The true error of the fine solution restricted: hf² × (restricted e), e linear → exact.
    // E ≈ u − u_fine = −hf² e.
    let truth = sample([10, 10, 1], |p| -hf * hf * e(p));
    assert!(max_diff(&est.per_cell, &truth) < 1e-13);
    assert!((est.max_abs - truth.iter().fold(0.0f64, |m, v| m.max(v.abs()))).abs() < 1e-13);
}

/// The per-level estimate (`estimate_next`: the error of level i from levels i and i+1) is
/// exact for the model `u_h = ū + h^p e` (ū exact cell averages, e linear, so restriction
/// commutes with both), uses the order of levels i, i+1, i+2, and brackets the difference to
/// the finest level: `D = (1 − (h_f/h_i)^p)·E`, inside `[E/2, E]` for every p ≥ 1 when the
/// finest level is two or more halvings finer. The estimate equals the true error to 1e-9
/// relative (rounding of differences of values ~10 that are ~1e-2 apart, plus the bisection
/// tolerance of the observed order).
#[test]
fn per_level_estimate_is_exact_for_the_model() {
    let e = |p: [f64; 3]| 0.1 + 0.05 * p[0] - 0.02 * p[1];
    let domain = Grid {
        dim: Dim::Two,
        min: [0.0; 3],
        max: [7.0; 3],
        res: [10, 10, 1],
    };
    for order in [1.0f64, 1.5, 2.0] {
        let ns = [10usize, 20, 40, 80];
        let levels: Vec<Level> = ns
            .iter()
            .map(|&n| {
                let h = 7.0 / n as f64;
                let fluence = cell_avg_u([n, n, 1])
                    .iter()
                    .zip(sample([n, n, 1], e))
                    .map(|(a, b)| a + h.powf(order) * b)
                    .collect();
                Level {
                    res: [n, n, 1],
                    unknowns: n * n,
                    seconds: 0.0,
                    fluence,
                }
            })
            .collect();
        let t = analyse(&levels, &domain, None).unwrap();
        let finest = restrict(&levels[3].fluence, [80, 80, 1], [10, 10, 1]).unwrap();
        let norm_f = finest.iter().map(|v| v * v).sum::<f64>().sqrt();
        let exact = cell_avg_u([10, 10, 1]);
        for (i, &n) in ns.iter().enumerate().take(3) {
            let row = &t.rows[i];
            let coarse = restrict(&levels[i].fluence, [n, n, 1], [10, 10, 1]).unwrap();
            let truth = rel_l2_diff(&coarse, &exact)
                * exact.iter().map(|v| v * v).sum::<f64>().sqrt()
                / norm_f;
            let est = row.estimate_next.unwrap();
            // The order comes from levels i, i+1, i+2 where they exist, else 2.
            let p_used = row.estimate_next_order.unwrap();
            let want_p = if i + 2 < ns.len() { order } else { 2.0 };
            assert!(
                (p_used - want_p).abs() < 1e-6,
                "order {order} level {n}: p {p_used}"
            );
            if i + 2 < ns.len() {
                assert!(
                    (est / truth - 1.0).abs() < 1e-9,
                    "order {order} level {n}: estimate {est} vs true {truth}"
                );
                assert_eq!(row.bracketed, Some(true), "order {order} level {n}");
            } else {
                assert_eq!(row.bracketed, None);
            }
        }
        assert!(t.rows[3].estimate_next.is_none() && t.rows[3].bracketed.is_none());
    }
}
