//! The table of a self-convergence study.
//!
//! Every level is compared on the coarsest grid (its fluence restricted there) and, where
//! the scene defines blocks, by block averages. Orders: `order_successive` of level i uses
//! the successive differences of levels i−2, i−1, i; `order_vs_finest` of level i uses the
//! differences of levels i−1 and i to the finest level (biased low when the finest level is
//! not much finer). The Richardson estimate of level i uses levels i−1 and i with the
//! successive order where it is measurable and in (0.5, 4), else p = 2.
//!
//! The per-level estimate (`estimate_next`) is the other reading of the same two levels: the
//! error of level i (every level but the finest) from it and the next finer level i+1,
//! `‖u_i − u‖ ≈ ‖u_i − u_{i+1}‖ · r^p/(r^p − 1)` (from `u_h = u + C h^p`), with the order of
//! levels i, i+1, i+2 where that is measurable and in (0.5, 4), else p = 2. It is what a user
//! who solved only levels i and i+1 can say about level i. The study checks it against the
//! difference to the finest level, the best measured proxy of that error: `bracketed` says
//! whether `diff_finest ≤ estimate_next ≤ 2·diff_finest` — the estimate is not optimistic
//! (when refinement converges monotonically the true error is at least the difference to the
//! finest level) and over-estimates by at most a factor 2. It is undefined for the level next
//! to the finest, whose difference to the finest is the very difference the estimate is built
//! from.

use super::order::{l2_diff, rel_l2_diff, richardson, solve_order};
use super::restrict::{block_averages, restrict, restriction_ratio};
use crate::problem::Grid;
use anyhow::{ensure, Result};
use serde::Serialize;

/// One solved level.
#[derive(Clone, Debug)]
pub struct Level {
    /// Cells per axis.
    pub res: [usize; 3],
    /// Unknowns of the discrete system.
    pub unknowns: usize,
    /// Seconds for assembly and solve.
    pub seconds: f64,
    /// Cell-centred fluence (L_0^0), C order.
    pub fluence: Vec<f64>,
}

/// One row of the table (one level).
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct StudyRow {
    /// Cells per axis.
    pub res: [usize; 3],
    /// Unknowns.
    pub unknowns: usize,
    /// Seconds.
    pub seconds: f64,
    /// `‖u_{i−1} − u_i‖/‖u_i‖` (previous, coarser level), on the coarsest grid.
    pub diff_prev: Option<f64>,
    /// Relative L2 difference to the finest level, on the coarsest grid.
    pub diff_finest: Option<f64>,
    /// Observed order from the successive differences of the last three levels.
    pub order_successive: Option<f64>,
    /// Observed order from this and the previous level's difference to the finest.
    pub order_vs_finest: Option<f64>,
    /// Richardson estimate of this level's error (relative L2, on the coarsest grid).
    pub richardson: Option<f64>,
    /// The order the Richardson estimate used.
    pub richardson_order: Option<f64>,
    /// Relative L2 difference of the block averages to the finest level's.
    pub diff_finest_blocks: Option<f64>,
    /// Observed order of the block averages (successive differences).
    pub order_successive_blocks: Option<f64>,
    /// Observed order of the block averages against the finest level.
    pub order_vs_finest_blocks: Option<f64>,
    /// Richardson estimate of this level's own error from it and the next finer level,
    /// relative L2 (normalised by the finest level, like `diff_finest`); None for the finest.
    pub estimate_next: Option<f64>,
    /// The order `estimate_next` used.
    pub estimate_next_order: Option<f64>,
    /// Whether `diff_finest ≤ estimate_next ≤ 2·diff_finest` (None for the finest two
    /// levels).
    pub bracketed: Option<bool>,
}

/// `r^p/(r^p − 1)`: the factor from the difference of two levels (ratio r) to the coarser
/// level's error under `u_h = u + C h^p`.
pub fn coarse_error_factor(r: f64, p: f64) -> f64 {
    let rp = r.powf(p);
    rp / (rp - 1.0)
}

/// A whole study.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct StudyTable {
    /// The common grid of the comparisons (the coarsest level).
    pub coarsest: [usize; 3],
    /// Blocks per axis of the block averages, if any.
    pub blocks: Option<[usize; 3]>,
    /// One row per level, coarsest first.
    pub rows: Vec<StudyRow>,
}

/// Differences, orders of one compared quantity (one vector per level, same length).
struct Compared {
    diff_prev: Vec<Option<f64>>,
    diff_finest: Vec<Option<f64>>,
    order_successive: Vec<Option<f64>>,
    order_vs_finest: Vec<Option<f64>>,
}

fn compare(q: &[Vec<f64>], h: &[f64]) -> Compared {
    let n = q.len();
    let last = &q[n - 1];
    // Relative to the finer level (so that the Richardson estimate is diff_prev/(r^p − 1)).
    let diff_prev: Vec<Option<f64>> = (0..n)
        .map(|i| (i > 0).then(|| rel_l2_diff(&q[i - 1], &q[i])))
        .collect();
    // Orders from absolute norms (no normalisation by different levels).
    let abs_prev: Vec<f64> = (0..n)
        .map(|i| {
            if i > 0 {
                l2_diff(&q[i - 1], &q[i])
            } else {
                0.0
            }
        })
        .collect();
    let abs_finest: Vec<f64> = (0..n).map(|i| l2_diff(&q[i], last)).collect();
    let diff_finest: Vec<Option<f64>> = (0..n)
        .map(|i| (i + 1 < n).then(|| rel_l2_diff(&q[i], last)))
        .collect();
    let order_successive = (0..n)
        .map(|i| {
            if i < 2 {
                return None;
            }
            solve_order(
                [h[i - 2], h[i - 1], h[i - 1], h[i]],
                abs_prev[i - 1] / abs_prev[i],
            )
        })
        .collect();
    let order_vs_finest = (0..n)
        .map(|i| {
            if i < 1 || i + 1 >= n {
                return None;
            }
            solve_order(
                [h[i - 1], h[n - 1], h[i], h[n - 1]],
                abs_finest[i - 1] / abs_finest[i],
            )
        })
        .collect();
    Compared {
        diff_prev,
        diff_finest,
        order_successive,
        order_vs_finest,
    }
}

/// Builds the study table. `domain` gives the box and dimension (its resolution is ignored);
/// levels must be sorted coarsest first and nest in the coarsest (see [`check_nesting`]).
pub fn analyse(levels: &[Level], domain: &Grid, blocks: Option<[usize; 3]>) -> Result<StudyTable> {
    ensure!(levels.len() >= 2, "a study needs at least two resolutions");
    let coarsest = levels[0].res;
    check_nesting(&levels.iter().map(|l| l.res).collect::<Vec<_>>())?;
    let restricted: Vec<Vec<f64>> = levels
        .iter()
        .map(|l| restrict(&l.fluence, l.res, coarsest))
        .collect::<Result<_>>()?;
    let h: Vec<f64> = levels.iter().map(|l| 1.0 / l.res[0] as f64).collect();
    let fl = compare(&restricted, &h);
    let bl = match blocks {
        Some(b) => {
            let q: Vec<Vec<f64>> = levels
                .iter()
                .map(|l| {
                    let g = Grid {
                        res: l.res,
                        ..domain.clone()
                    };
                    block_averages(&l.fluence, &g, b)
                })
                .collect::<Result<_>>()?;
            Some(compare(&q, &h))
        }
        None => None,
    };
    let n = levels.len();
    let norm_finest = restricted[n - 1].iter().map(|v| v * v).sum::<f64>().sqrt();
    let mut rows = Vec::new();
    for (i, l) in levels.iter().enumerate() {
        let next = (i + 1 < n).then(|| {
            let r = levels[i + 1].res[0] as f64 / l.res[0] as f64;
            let d =
                l2_diff(&restricted[i], &restricted[i + 1]) / norm_finest.max(f64::MIN_POSITIVE);
            let p = (i + 2 < n)
                .then(|| fl.order_successive[i + 2])
                .flatten()
                .filter(|p| *p > 0.5 && *p < 4.0)
                .unwrap_or(2.0);
            (d * coarse_error_factor(r, p), p)
        });
        let (richardson_est, richardson_order) = if i > 0 {
            let p = fl.order_successive[i]
                .filter(|p| *p > 0.5 && *p < 4.0)
                .unwrap_or(2.0);
            let r = l.res[0] as f64 / levels[i - 1].res[0] as f64;
            let e = richardson(&restricted[i], &restricted[i - 1], r, p, "");
            (Some(e.rel_l2), Some(p))
        } else {
            (None, None)
        };
        rows.push(StudyRow {
            res: l.res,
            unknowns: l.unknowns,
            seconds: l.seconds,
            diff_prev: fl.diff_prev[i],
            diff_finest: fl.diff_finest[i],
            order_successive: fl.order_successive[i],
            order_vs_finest: fl.order_vs_finest[i],
            richardson: richardson_est,
            richardson_order,
            diff_finest_blocks: bl.as_ref().and_then(|b| b.diff_finest[i]),
            order_successive_blocks: bl.as_ref().and_then(|b| b.order_successive[i]),
            order_vs_finest_blocks: bl.as_ref().and_then(|b| b.order_vs_finest[i]),
            estimate_next: next.map(|e| e.0),
            estimate_next_order: next.map(|e| e.1),
            bracketed: next
                .zip(fl.diff_finest[i])
                .filter(|_| i + 2 < n)
                .map(|(e, d)| d <= e.0 && e.0 <= 2.0 * d),
        });
    }
    Ok(StudyTable {
        coarsest,
        blocks,
        rows,
    })
}

/// Checks that resolutions are strictly increasing and each is an integer multiple of the
/// coarsest on every axis (with the same ratio on every refined axis).
pub fn check_nesting(res: &[[usize; 3]]) -> Result<()> {
    ensure!(!res.is_empty(), "no resolutions given");
    for w in res.windows(2) {
        ensure!(
            w[1][0] > w[0][0],
            "resolutions must increase: {} then {}",
            w[0][0],
            w[1][0]
        );
    }
    for r in res {
        restriction_ratio(*r, res[0])?;
    }
    Ok(())
}

impl StudyTable {
    /// The table as CSV (empty fields where a quantity is not defined).
    pub fn to_csv(&self) -> String {
        let f = |v: Option<f64>| v.map(|x| format!("{x:.6e}")).unwrap_or_default();
        let o = |v: Option<f64>| v.map(|x| format!("{x:.3}")).unwrap_or_default();
        let mut s = String::from(
            "resolution,unknowns,seconds,diff_prev,diff_finest,order_successive,order_vs_finest,\
             richardson_estimate,richardson_order,diff_finest_blocks,order_successive_blocks,\
             order_vs_finest_blocks,estimate_next,estimate_next_order,bracketed\n",
        );
        for r in &self.rows {
            s += &format!(
                "{},{},{:.3},{},{},{},{},{},{},{},{},{},{},{},{}\n",
                r.res[0],
                r.unknowns,
                r.seconds,
                f(r.diff_prev),
                f(r.diff_finest),
                o(r.order_successive),
                o(r.order_vs_finest),
                f(r.richardson),
                o(r.richardson_order),
                f(r.diff_finest_blocks),
                o(r.order_successive_blocks),
                o(r.order_vs_finest_blocks),
                f(r.estimate_next),
                o(r.estimate_next_order),
                r.bracketed.map(|b| b.to_string()).unwrap_or_default(),
            );
        }
        s
    }

    /// A fixed-width table for the terminal. `est_own` is `estimate_next` (the level's own
    /// error from it and the next finer level), `bracket` whether it brackets `d_finest`.
    pub fn to_text(&self) -> String {
        let f = |v: Option<f64>| v.map(|x| format!("{x:.3e}")).unwrap_or_else(|| "-".into());
        let o = |v: Option<f64>| v.map(|x| format!("{x:.2}")).unwrap_or_else(|| "-".into());
        let mut s = format!(
            "{:>6} {:>10} {:>9} {:>10} {:>10} {:>6} {:>6} {:>10}",
            "res", "unknowns", "seconds", "d_prev", "d_finest", "p_3lv", "p_fin", "richardson"
        );
        s += &format!(" {:>10} {:>5} {:>7}", "est_own", "p_est", "bracket");
        if self.blocks.is_some() {
            s += &format!(" {:>10} {:>6} {:>6}", "blk_d_fin", "p_3lv", "p_fin");
        }
        s.push('\n');
        for r in &self.rows {
            s += &format!(
                "{:>6} {:>10} {:>9.3} {:>10} {:>10} {:>6} {:>6} {:>10}",
                r.res[0],
                r.unknowns,
                r.seconds,
                f(r.diff_prev),
                f(r.diff_finest),
                o(r.order_successive),
                o(r.order_vs_finest),
                f(r.richardson)
            );
            let bracket = match r.bracketed {
                Some(true) => "yes",
                Some(false) => "no",
                None => "-",
            };
            s += &format!(
                " {:>10} {:>5} {:>7}",
                f(r.estimate_next),
                o(r.estimate_next_order),
                bracket
            );
            if self.blocks.is_some() {
                s += &format!(
                    " {:>10} {:>6} {:>6}",
                    f(r.diff_finest_blocks),
                    o(r.order_successive_blocks),
                    o(r.order_vs_finest_blocks)
                );
            }
            s.push('\n');
        }
        s
    }
}
