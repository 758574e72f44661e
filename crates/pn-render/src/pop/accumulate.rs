//! From POP's band amplitudes to the spherical-harmonic moments of the collided radiance on
//! the solve grid (docs/pop-design.md, "Coupling to the existing renderer").
//!
//! An HG lobe `I · f_hg(ω·d, a)` (ω the travel direction) has the exact moments
//! `∫ I f_hg(ω·d, a) Y_lm(ω) dω = I · a^l · Y_lm(d)`: `f_hg = Σ_l (2l+1)/(4π) a^l P_l(ω·d)`
//! and the addition theorem `P_l(ω·d) = 4π/(2l+1) Σ_m Y_lm(ω) Y_lm(d)` for the orthonormal
//! real harmonics of [`pn_stencil::quadrature::real_sh`]. The accumulated radiance of a POP
//! cell, `Σ_m w_m L^m f_hg(·, a^m)` (Eq. 7–8 for every view at once), therefore has the
//! moments `L_lm = A_l · Y_lm(d)` with `A_l = Σ_m w_m L^m (a^m)^l`, truncated at the solve
//! order's lmax (the dropped part is Σ_{l>lmax} of lobes with a ≤ g; the renderer's
//! `g^l` factor damps it further). The renderer ([`crate::renderer::MsField`])
//! multiplies moment `l(l+1)+m` by `g^l Y_lm(ω_o)` (Funk–Hecke), which is the convolution of
//! the lobe with the phase function (open point 4 of `../shared/papers/README.md`).
//!
//! **Resampling** (the paper's §4.4 upsampling, without its bilateral filter): the band
//! amplitudes are read at each solve-cell centre trilinearly between POP cell centres,
//! clamped at the outermost centres (the POP grid covers the medium's support, so a solve
//! centre outside it lies in vacuum, where σ_s = 0 and the value is never used), and the
//! lights' moments are summed.

use super::propagate::LightGrid;
use crate::shadow::cell_centre;
use pn_runtime::problem::Grid;
use pn_runtime::CellMoments;
use pn_stencil::quadrature::real_sh;
use rayon::prelude::*;

/// `Y_lm(d)` for l = 0..=lmax, at index `l(l+1)+m` (`d` unit).
pub fn sh_of_direction(d: [f64; 3], lmax: usize) -> Vec<f64> {
    let mu = d[2].clamp(-1.0, 1.0);
    let phi = d[1].atan2(d[0]);
    let mut y = vec![0.0; (lmax + 1) * (lmax + 1)];
    for l in 0..=lmax {
        for m in -(l as i64)..=(l as i64) {
            y[(l as i64 * (l as i64 + 1) + m) as usize] = real_sh(l, m, mu, phi);
        }
    }
    y
}

/// The band amplitudes `A_0..=A_lmax` at the world point `x`, trilinear between the POP
/// cell centres and clamped at the outermost ones (`bands[c·(lmax+1) + l]`, c the storage
/// index of [`LightGrid::index`]).
pub fn bands_at(grid: &LightGrid, bands: &[f64], lmax: usize, x: [f64; 3]) -> Vec<f64> {
    let nb = lmax + 1;
    let q = grid.local(x);
    let mut idx = [[0usize; 2]; 3];
    let mut w = [[0.0f64; 2]; 3];
    for ax in 0..3 {
        let n = grid.res[ax];
        let t = q[ax].clamp(0.0, (n - 1) as f64);
        let i0 = (t.floor() as usize).min(n - 1);
        let i1 = (i0 + 1).min(n - 1);
        let f = t - i0 as f64;
        idx[ax] = [i0, i1];
        w[ax] = [1.0 - f, f];
    }
    let mut out = vec![0.0; nb];
    for a in 0..2 {
        for b in 0..2 {
            for c in 0..2 {
                let wt = w[0][a] * w[1][b] * w[2][c];
                if wt == 0.0 {
                    continue;
                }
                let cell = grid.index(idx[0][a], idx[1][b], idx[2][c]);
                for (o, v) in out.iter_mut().zip(&bands[cell * nb..(cell + 1) * nb]) {
                    *o += wt * v;
                }
            }
        }
    }
    out
}

/// Adds one light's moments `A_l(x) · Y_lm(d)` at every cell centre of `target` to `out`
/// (`out.per_cell = (lmax+1)²`, the order of [`CellMoments`]).
pub fn add_light_moments(
    grid: &LightGrid,
    bands: &[f64],
    lmax: usize,
    target: &Grid,
    out: &mut CellMoments,
) {
    let pc = (lmax + 1) * (lmax + 1);
    debug_assert_eq!(out.per_cell, pc);
    let y = sh_of_direction(grid.axes[2], lmax);
    let [_, ny, nz] = target.res;
    out.data
        .par_chunks_mut(ny * nz * pc)
        .enumerate()
        .for_each(|(i, slab)| {
            for j in 0..ny {
                for k in 0..nz {
                    let x = cell_centre(target, [i, j, k]);
                    let a = bands_at(grid, bands, lmax, x);
                    let base = (j * nz + k) * pc;
                    for (l, al) in a.iter().enumerate() {
                        for n in l * l..(l + 1) * (l + 1) {
                            slab[base + n] += al * y[n];
                        }
                    }
                }
            }
        });
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Test 1 of issue 20: the orthonormal convention the projection assumes,
    /// `Σ_m Y_lm(d)² = (2l+1)/(4π)` (addition theorem at ω = d), for l ≤ 8 and several
    /// directions, with the renderer's `real_sh`; rounding tolerance 1e-12.
    #[test]
    fn sh_band_sums_are_the_addition_theorem() {
        for d in [
            [0.0f64, 0.0, 1.0],
            [0.0, 0.0, -1.0],
            [1.0, 0.0, 0.0],
            [0.3, -0.5, 0.81],
            [-0.7, 0.2, -0.3],
        ] {
            let n = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
            let d = d.map(|c| c / n);
            let y = sh_of_direction(d, 8);
            for l in 0..=8usize {
                let s: f64 = (0..2 * l + 1).map(|m| y[l * l + m].powi(2)).sum();
                let want = (2 * l + 1) as f64 / (4.0 * std::f64::consts::PI);
                assert!(
                    (s - want).abs() < 1e-12 * want,
                    "d {d:?} l {l}: {s} vs {want}"
                );
            }
        }
    }

    /// The lobe's moments are `I a^l Y_lm(d)`: against a product quadrature of
    /// `f_hg(ω·d, a) Y_lm(ω)` (64 × 128 nodes; the integrand is smooth for a = 0.6, error
    /// far below 1e-8).
    #[test]
    fn hg_lobe_moments_are_a_to_the_l_times_y_of_d() {
        let q = pn_stencil::quadrature::SphereQuadrature::new(64, 128);
        let d = {
            let v: [f64; 3] = [0.4, 0.5, -0.3];
            let n = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
            v.map(|c| c / n)
        };
        let a = 0.6;
        let y = sh_of_direction(d, 4);
        for l in 0..=4usize {
            for m in -(l as i64)..=(l as i64) {
                let num: f64 = q
                    .points
                    .iter()
                    .zip(&q.weights)
                    .map(|((w, mu, phi), wt)| {
                        let c = w[0] * d[0] + w[1] * d[1] + w[2] * d[2];
                        wt * pn_stencil::quadrature::henyey_greenstein(a, c)
                            * real_sh(l, m, *mu, *phi)
                    })
                    .sum();
                let want = a.powi(l as i32) * y[(l as i64 * (l as i64 + 1) + m) as usize];
                assert!((num - want).abs() < 1e-8, "l {l} m {m}: {num} vs {want}");
            }
        }
    }
}
