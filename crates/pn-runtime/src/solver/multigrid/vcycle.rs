//! The V-cycle `z = M⁻¹ r`.
//!
//! On each level, starting from `x = 0`: smooth (`x = p(D⁻¹A)D⁻¹ b`, leaving the residual
//! `r = b − A x`), restrict `b_c = Pᵀ r`, recurse, prolong `x += s·P x_c`, recompute the
//! residual and smooth again with the same polynomial. The coarsest level is solved
//! exactly (dense LU). With the same smoother before and after, and `Pᵀ` as restriction,
//! `M⁻¹` is symmetric whenever `A` is (tested in `tests/multigrid.rs`).
//!
//! An additive finest level ([`super::FineCycle::Additive`]) is `x = ω D⁻¹ b + s·P x_c`
//! with `x_c` the cycle of the coarse levels for `Pᵀ b`: symmetric as well, and without
//! any application of the finest operator.

use super::aggregate::Aggregation;
use super::{Multigrid, SingleFine, Work};
use crate::linalg::Real;
use rayon::prelude::*;

impl Multigrid {
    /// `z = M⁻¹ r`, with `fine_apply` the finest operator (`S`, or the matrix the
    /// hierarchy was built for).
    pub fn apply(&self, fine_apply: &dyn Fn(&[f64], &mut [f64]), r: &[f64], z: &mut [f64]) {
        let t0 = std::time::Instant::now();
        let mut work = self.work.lock().unwrap_or_else(|e| e.into_inner());
        z.iter_mut().for_each(|v| *v = 0.0);
        match &self.single {
            Some(single) => self.cycle_single(single, fine_apply, r, z, &mut work),
            None => self.cycle(0, fine_apply, r, z, &mut work),
        }
        use std::sync::atomic::Ordering::Relaxed;
        self.cycle_stats[0].fetch_add(1, Relaxed);
        self.cycle_stats[1].fetch_add(t0.elapsed().as_nanos() as u64, Relaxed);
    }

    /// The finest level of [`Multigrid::cycle`] in `f32` ([`Multigrid::with_single_fine`]):
    /// the same steps, with `b` rounded once and `x` widened at the end.
    fn cycle_single(
        &self,
        single: &SingleFine,
        fine_apply: &dyn Fn(&[f64], &mut [f64]),
        b: &[f64],
        x: &mut [f64],
        work: &mut [Work],
    ) {
        let mut vecs = single.work.lock().unwrap_or_else(|e| e.into_inner());
        let [b32, r, x32, d, t] = &mut *vecs;
        let lev = &self.levels[0];
        let apply = |v: &[f32], out: &mut [f32]| {
            single
                .applications
                .fetch_add(1, std::sync::atomic::Ordering::Relaxed);
            (single.apply)(v, out);
        };
        let apply = &apply;
        b32.par_iter_mut()
            .zip(b.par_iter())
            .with_min_len(super::PAR_MIN_LEN)
            .for_each(|(o, &v)| *o = v as f32);
        r.copy_from_slice(b32);
        x32.iter_mut().for_each(|v| *v = 0.0);
        lev.smoother
            .smooth_with(&single.inv_diag, apply, r, x32, d, t, true);
        let Some((w, rest)) = work.split_first_mut() else {
            return;
        };
        let agg = &lev.agg;
        restrict(agg, r, &mut w.b_next);
        w.x_next.iter_mut().for_each(|v| *v = 0.0);
        self.cycle(1, fine_apply, &w.b_next, &mut w.x_next, rest);
        let (xc, s) = (&w.x_next, self.scale);
        x32.par_iter_mut()
            .zip(agg.agg.par_iter())
            .with_min_len(super::PAR_MIN_LEN)
            .for_each(|(xi, &c)| *xi += (s * xc[c as usize]) as f32);
        apply(x32, t);
        r.par_iter_mut()
            .zip(b32.par_iter().zip(t.par_iter()))
            .with_min_len(super::PAR_MIN_LEN)
            .for_each(|(ri, (&bi, &ti))| *ri = bi - ti);
        lev.smoother
            .smooth_with(&single.inv_diag, apply, r, x32, d, t, false);
        x.par_iter_mut()
            .zip(x32.par_iter())
            .with_min_len(super::PAR_MIN_LEN)
            .for_each(|(o, &v)| *o = v as f64);
    }

    fn cycle(
        &self,
        l: usize,
        fine_apply: &dyn Fn(&[f64], &mut [f64]),
        b: &[f64],
        x: &mut [f64],
        work: &mut [Work],
    ) {
        let Some((w, rest)) = work.split_first_mut() else {
            // Coarsest level: dense LU.
            let rhs = nalgebra::DVector::from_column_slice(b);
            if let Some(sol) = self.coarsest.solve(&rhs) {
                x.copy_from_slice(sol.as_slice());
            }
            return;
        };
        let lev = &self.levels[l];
        let coarse_apply;
        let apply: &dyn Fn(&[f64], &mut [f64]) = match &lev.op {
            Some(a) => {
                coarse_apply = move |v: &[f64], out: &mut [f64]| a.apply(v, out);
                &coarse_apply
            }
            None => fine_apply,
        };
        let additive = l == 0 && self.additive;
        w.r.copy_from_slice(b);
        if additive {
            // x = ω D⁻¹ b; the coarse levels get Pᵀ b.
            let inv = &lev.smoother.inv_diag;
            let omega = 1.0 / lev.smoother.lambda_max;
            x.par_iter_mut()
                .zip(b.par_iter().zip(inv.par_iter()))
                .with_min_len(super::PAR_MIN_LEN)
                .for_each(|(xi, (bi, di))| *xi = omega * bi * di);
        } else {
            // Pre-smoothing from x = 0 (x was zeroed by the caller).
            lev.smoother
                .smooth(apply, &mut w.r, x, &mut w.d, &mut w.t, true);
        }
        // Restriction b_c = Pᵀ r.
        let agg = &lev.agg;
        restrict(agg, &w.r, &mut w.b_next);
        w.x_next.iter_mut().for_each(|v| *v = 0.0);
        self.cycle(l + 1, fine_apply, &w.b_next, &mut w.x_next, rest);
        // Prolongation x += s P x_c.
        let (xc, s) = (&w.x_next, self.scale);
        x.par_iter_mut()
            .zip(agg.agg.par_iter())
            .with_min_len(super::PAR_MIN_LEN)
            .for_each(|(xi, &c)| *xi += s * xc[c as usize]);
        if additive {
            return;
        }
        // Post-smoothing on the new residual.
        apply(x, &mut w.t);
        w.r.par_iter_mut()
            .zip(b.par_iter().zip(w.t.par_iter()))
            .with_min_len(super::PAR_MIN_LEN)
            .for_each(|(ri, (bi, ti))| *ri = bi - ti);
        lev.smoother
            .smooth(apply, &mut w.r, x, &mut w.d, &mut w.t, false);
    }
}

/// The restriction `b_c = Pᵀ r`: each aggregate's sum of its members' residuals (in `f64`).
fn restrict<T: Real>(agg: &Aggregation, r: &[T], b_next: &mut [f64]) {
    b_next
        .par_iter_mut()
        .enumerate()
        .with_min_len(super::PAR_MIN_LEN)
        .for_each(|(c, bc)| {
            *bc = agg.members[agg.ptr[c]..agg.ptr[c + 1]]
                .iter()
                .map(|&i| r[i as usize].wide())
                .sum();
        });
}
