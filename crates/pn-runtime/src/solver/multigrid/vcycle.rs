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
use pn_krylov::linalg::Real;
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
    ///
    /// The vector work between the operator's applications is fused into as few passes as
    /// the recurrence allows (the finest level's vectors are the largest of the cycle;
    /// at 80³ P_5 each `f32` vector is 31 MB): the pre-smoothing starts from `x = 0`, so
    /// its first direction is `D⁻¹ b / θ` written together with `b`'s rounding, and its
    /// first residual `b − A d` is never copied from `b`; each residual update
    /// `r −= A d` is done in the pass that updates `d` and `x`; the pre-smoothed residual is
    /// restricted as `Pᵀ (r − A d)` without being stored; and the post-smoothing's last
    /// update writes `x` straight into the `f64` output. 34 vector passes per cycle at
    /// degree 2 instead of 48, with the same arithmetic in the same order as
    /// [`super::smoother::Chebyshev::smooth_with`] (the results are bit-identical).
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
        let inv = &single.inv_diag[..];
        let apply = |v: &[f32], out: &mut [f32]| {
            single
                .applications
                .fetch_add(1, std::sync::atomic::Ordering::Relaxed);
            (single.apply)(v, out);
        };
        let steps = lev.smoother.steps();
        let theta = steps.theta as f32;
        let coefficients = |&(c1, c2): &(f64, f64)| (c1 as f32, c2 as f32);
        const MIN: usize = super::PAR_MIN_LEN;
        // Pre-smoothing from x = 0, where r = b: d = D⁻¹ b / θ, x = d.
        b32.par_iter_mut()
            .zip(d.par_iter_mut().zip(x32.par_iter_mut()))
            .zip(b.par_iter().zip(inv.par_iter()))
            .with_min_len(MIN)
            .for_each(|((bo, (di, xi)), (&bi, &ii))| {
                *bo = bi as f32;
                *di = *bo * ii / theta;
                *xi = *di;
            });
        // Each further step: r = r − A d (r = b the first time), d = c₁ d + c₂ D⁻¹ r, x += d.
        for (k, step) in steps.updates.iter().enumerate() {
            apply(d, t);
            let (c1, c2) = coefficients(step);
            step_single(r, (k == 0).then_some(&b32[..]), d, x32, t, inv, c1, c2);
        }
        apply(d, t);
        let Some((w, rest)) = work.split_first_mut() else {
            return;
        };
        let agg = &lev.agg;
        // The pre-smoothed residual r − A d, restricted without being stored.
        let before: &[f32] = if steps.updates.is_empty() { b32 } else { r };
        restrict_difference(agg, before, t, &mut w.b_next);
        w.x_next.iter_mut().for_each(|v| *v = 0.0);
        self.cycle(1, fine_apply, &w.b_next, &mut w.x_next, rest);
        let (xc, s) = (&w.x_next, self.scale);
        x32.par_iter_mut()
            .zip(agg.agg.par_iter())
            .with_min_len(MIN)
            .for_each(|(xi, &c)| *xi += (s * xc[c as usize]) as f32);
        // Post-smoothing on the new residual r = b − A x: d = D⁻¹ r / θ, x += d; with no
        // further step that update is the last and goes straight to the output.
        apply(x32, t);
        if steps.updates.is_empty() {
            x.par_iter_mut()
                .zip(x32.par_iter())
                .zip(b32.par_iter().zip(t.par_iter().zip(inv.par_iter())))
                .with_min_len(MIN)
                .for_each(|((o, &xi), (&bi, (&ti, &ii)))| {
                    let di = (bi - ti) * ii / theta;
                    *o = (xi + di) as f64;
                });
            return;
        }
        r.par_iter_mut()
            .zip(d.par_iter_mut().zip(x32.par_iter_mut()))
            .zip(b32.par_iter().zip(t.par_iter().zip(inv.par_iter())))
            .with_min_len(MIN)
            .for_each(|((ri, (di, xi)), (&bi, (&ti, &ii)))| {
                *ri = bi - ti;
                *di = *ri * ii / theta;
                *xi += *di;
            });
        // The further steps, the last writing x = x + d into the f64 output.
        let last = steps.updates.len() - 1;
        for (k, step) in steps.updates.iter().enumerate() {
            apply(d, t);
            let (c1, c2) = coefficients(step);
            if k < last {
                step_single(r, None, d, x32, t, inv, c1, c2);
            } else {
                x.par_iter_mut()
                    .zip(r.par_iter().zip(d.par_iter()))
                    .zip(x32.par_iter().zip(t.par_iter().zip(inv.par_iter())))
                    .with_min_len(MIN)
                    .for_each(|((o, (&ri, &di)), (&xi, (&ti, &ii)))| {
                        let ri = ri - ti;
                        let di = c1 * di + c2 * ri * ii;
                        *o = (xi + di) as f64;
                    });
            }
        }
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

/// One fused Chebyshev step of [`Multigrid::cycle_single`]: `r = from − t` (`from` = `r`
/// itself when `None`), `d = c₁ d + c₂ D⁻¹ r`, `x += d`, in one pass.
#[allow(clippy::too_many_arguments)]
fn step_single(
    r: &mut [f32],
    from: Option<&[f32]>,
    d: &mut [f32],
    x: &mut [f32],
    t: &[f32],
    inv: &[f32],
    c1: f32,
    c2: f32,
) {
    let update = |ri: &mut f32, di: &mut f32, xi: &mut f32, ii: f32| {
        *di = c1 * *di + c2 * *ri * ii;
        *xi += *di;
    };
    let rest = d.par_iter_mut().zip(x.par_iter_mut());
    let read = t.par_iter().zip(inv.par_iter());
    match from {
        Some(from) => r
            .par_iter_mut()
            .zip(rest)
            .zip(from.par_iter().zip(read))
            .with_min_len(super::PAR_MIN_LEN)
            .for_each(|((ri, (di, xi)), (&fi, (&ti, &ii)))| {
                *ri = fi - ti;
                update(ri, di, xi, ii);
            }),
        None => r
            .par_iter_mut()
            .zip(rest)
            .zip(read)
            .with_min_len(super::PAR_MIN_LEN)
            .for_each(|((ri, (di, xi)), (&ti, &ii))| {
                *ri -= ti;
                update(ri, di, xi, ii);
            }),
    }
}

/// `b_c = Pᵀ (r − t)` without storing `r − t` (the difference taken in `T`, as
/// `r −= t` would, then widened).
fn restrict_difference<T: Real>(agg: &Aggregation, r: &[T], t: &[T], b_next: &mut [f64]) {
    restrict_values(agg, b_next, |i| (r[i] - t[i]).wide());
}

/// The restriction `b_c = Pᵀ r`: each aggregate's sum of its members' residuals (in `f64`).
fn restrict<T: Real>(agg: &Aggregation, r: &[T], b_next: &mut [f64]) {
    restrict_values(agg, b_next, |i| r[i].wide());
}

/// `b_c = Σ_{i in aggregate c} value(i)`, the members summed in order.
fn restrict_values(agg: &Aggregation, b_next: &mut [f64], value: impl Fn(usize) -> f64 + Sync) {
    b_next
        .par_iter_mut()
        .enumerate()
        .with_min_len(super::PAR_MIN_LEN)
        .for_each(|(c, bc)| {
            *bc = agg.members[agg.ptr[c]..agg.ptr[c + 1]]
                .iter()
                .map(|&i| value(i as usize))
                .sum();
        });
}

#[cfg(test)]
mod tests {
    use super::super::{FineCycle, Geometry, MgOptions, Multigrid};
    use pn_krylov::linalg::spmv;

    /// A 3D 7-point diffusion operator with absorption on `n³` cells (one class) and its
    /// geometry.
    fn diffusion(n: usize) -> (sprs::CsMat<f64>, Geometry) {
        let id = |x: usize, y: usize, z: usize| (x * n + y) * n + z;
        let mut tri = sprs::TriMat::new((n * n * n, n * n * n));
        let mut coords = Vec::new();
        for x in 0..n {
            for y in 0..n {
                for z in 0..n {
                    let i = id(x, y, z);
                    // A varying absorption, so that the diagonal is not constant.
                    tri.add_triplet(i, i, 6.0 + 0.1 * ((x + 2 * y + 3 * z) % 5) as f64);
                    for (dx, dy, dz) in [(1, 0, 0), (0, 1, 0), (0, 0, 1)] {
                        let (u, v, w) = (x + dx, y + dy, z + dz);
                        if u < n && v < n && w < n {
                            tri.add_triplet(i, id(u, v, w), -1.0);
                            tri.add_triplet(id(u, v, w), i, -1.0);
                        }
                    }
                    coords.push([x as u32, y as u32, z as u32]);
                }
            }
        }
        let geometry = Geometry {
            class: vec![0; n * n * n],
            coords,
        };
        (tri.to_csr(), geometry)
    }

    /// The fused single-precision finest level (`cycle_single`) applies the same
    /// preconditioner as the `f64` cycle, for fine degrees 1 (no further step), 2 (one)
    /// and 3 (a middle step in place): the two agree to `f32` rounding (the vectors are
    /// rounded to 6e-8 relative; a few levels of smoothing amplify it by at most a few
    /// hundred here, so 1e-5 relative), and the single level applies its operator
    /// `2 · degree` times per cycle.
    #[test]
    fn fused_single_precision_cycle_equals_the_double_cycle() {
        let (a, geometry) = diffusion(12);
        let n = a.rows();
        let r: Vec<f64> = (0..n)
            .map(|i| ((i * 7919) % 1000) as f64 / 500.0 - 1.0)
            .collect();
        for degree in 1..=3 {
            let opts = MgOptions {
                fine_degree: degree,
                coarse_max: 50,
                fine_cycle: FineCycle::Multiplicative,
                ..MgOptions::default()
            };
            let fine = |x: &[f64], y: &mut [f64]| spmv(&a, x, y);
            let double = Multigrid::for_matrix(&a, &geometry, &opts).unwrap();
            let mut z_double = vec![0.0; n];
            double.apply(&fine, &r, &mut z_double);
            let a32 = a.map(|&v| v as f32);
            let single = Multigrid::for_matrix(&a, &geometry, &opts)
                .unwrap()
                .with_single_fine(Box::new(move |x: &[f32], y: &mut [f32]| {
                    for (yi, row) in y.iter_mut().zip(a32.outer_iterator()) {
                        *yi = row.iter().map(|(j, &v)| v * x[j]).sum();
                    }
                }));
            assert!(single.is_single_fine());
            let mut z_single = vec![0.0; n];
            single.apply(&fine, &r, &mut z_single);
            let norm = z_double.iter().map(|v| v * v).sum::<f64>().sqrt();
            let diff = z_double
                .iter()
                .zip(&z_single)
                .map(|(a, b)| (a - b) * (a - b))
                .sum::<f64>()
                .sqrt();
            assert!(diff <= 1e-5 * norm, "degree {degree}: {diff:e} of {norm:e}");
            assert_eq!(
                single.single_fine_applications(),
                2 * degree,
                "degree {degree}"
            );
        }
    }
}
