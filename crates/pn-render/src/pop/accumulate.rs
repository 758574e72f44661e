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
//! **Resampling** (the paper's §4.4 upsampling): the band amplitudes are read at each
//! solve-cell centre trilinearly between POP cell centres, clamped at the outermost centres
//! (the POP grid covers the medium's support, so a solve centre outside it lies in vacuum,
//! where σ_s = 0 and the value is never used), optionally with the trilinear weights
//! multiplied by the range kernel of the joint bilateral upsampling guided by σ_s
//! ([`super::upsample`]); the lights' moments are summed. The same code serves the
//! light-aligned and the radial grids ([`BandGrid`]).

use super::propagate::LightGrid;
use super::upsample::Bilateral;
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

/// A propagation grid whose band amplitudes can be read at world points: the light-aligned
/// [`LightGrid`] and a point light's [`super::radial::RadialGrid`].
pub trait BandGrid: Sync {
    /// The eight cells around `x` with their trilinear weights between cell centres,
    /// clamped at the outermost centres (weights sum to 1; zero weights allowed), in the
    /// order (a, b, c) ∈ {0, 1}³ with c fastest.
    fn corners(&self, x: [f64; 3]) -> [(usize, f64); 8];
    /// The world position of the centre of cell `c` (storage index).
    fn centre_of(&self, c: usize) -> [f64; 3];
    /// The lobes' principal direction at `x` (unit).
    fn principal(&self, x: [f64; 3]) -> [f64; 3];
    /// `Some(d)` where the principal direction is `d` everywhere (a directional light).
    fn fixed_principal(&self) -> Option<[f64; 3]>;
}

/// Trilinear corners of the continuous cell coordinates `q` (cell c's centre at c) on a
/// grid of `res` cells, clamped at the outermost centres; `index` maps (i, j, k) to storage.
pub fn trilinear_corners(
    q: [f64; 3],
    res: [usize; 3],
    index: impl Fn(usize, usize, usize) -> usize,
) -> [(usize, f64); 8] {
    let mut idx = [[0usize; 2]; 3];
    let mut w = [[0.0f64; 2]; 3];
    for ax in 0..3 {
        let n = res[ax];
        let t = q[ax].clamp(0.0, (n - 1) as f64);
        let i0 = (t.floor() as usize).min(n - 1);
        let i1 = (i0 + 1).min(n - 1);
        let f = t - i0 as f64;
        idx[ax] = [i0, i1];
        w[ax] = [1.0 - f, f];
    }
    let mut out = [(0usize, 0.0f64); 8];
    for a in 0..2 {
        for b in 0..2 {
            for c in 0..2 {
                let wt = w[0][a] * w[1][b] * w[2][c];
                out[a * 4 + b * 2 + c] = (index(idx[0][a], idx[1][b], idx[2][c]), wt);
            }
        }
    }
    out
}

impl BandGrid for LightGrid {
    fn corners(&self, x: [f64; 3]) -> [(usize, f64); 8] {
        trilinear_corners(self.local(x), self.res, |i, j, k| self.index(i, j, k))
    }

    fn centre_of(&self, c: usize) -> [f64; 3] {
        let [nx, ny, _] = self.res;
        self.centre([c % nx, (c / nx) % ny, c / (nx * ny)])
    }

    fn principal(&self, _x: [f64; 3]) -> [f64; 3] {
        self.axes[2]
    }

    fn fixed_principal(&self) -> Option<[f64; 3]> {
        Some(self.axes[2])
    }
}

/// The band amplitudes `A_0..=A_lmax` at `x` from the weighted `corners`
/// (`bands[c·(lmax+1) + l]`); zero weights are skipped.
pub fn bands_from(corners: &[(usize, f64); 8], bands: &[f64], lmax: usize) -> Vec<f64> {
    let nb = lmax + 1;
    let mut out = vec![0.0; nb];
    for &(cell, wt) in corners {
        if wt == 0.0 {
            continue;
        }
        for (o, v) in out.iter_mut().zip(&bands[cell * nb..(cell + 1) * nb]) {
            *o += wt * v;
        }
    }
    out
}

/// The band amplitudes `A_0..=A_lmax` at the world point `x`, trilinear between the POP
/// cell centres and clamped at the outermost ones (`bands[c·(lmax+1) + l]`, c the storage
/// index of [`LightGrid::index`]).
pub fn bands_at(grid: &LightGrid, bands: &[f64], lmax: usize, x: [f64; 3]) -> Vec<f64> {
    bands_from(&grid.corners(x), bands, lmax)
}

/// Adds one light's moments `A_l(x) · Y_lm(d)` at every cell centre of `target` to `out`
/// (`out.per_cell = (lmax+1)²`, the order of [`CellMoments`]), trilinear.
pub fn add_light_moments(
    grid: &LightGrid,
    bands: &[f64],
    lmax: usize,
    target: &Grid,
    out: &mut CellMoments,
) {
    add_moments(grid, bands, lmax, target, out, None);
}

/// Adds the moments `A_l(x) · Y_lm(d(x))` of the band amplitudes on `grid` at every cell
/// centre x of `target` to `out`: trilinear between the POP cell centres, or — with
/// `bilateral` — the joint bilateral upsampling of §4.4 ([`super::upsample`]).
pub fn add_moments<G: BandGrid>(
    grid: &G,
    bands: &[f64],
    lmax: usize,
    target: &Grid,
    out: &mut CellMoments,
    bilateral: Option<&Bilateral<'_>>,
) {
    let pc = (lmax + 1) * (lmax + 1);
    debug_assert_eq!(out.per_cell, pc);
    let fixed = grid.fixed_principal().map(|d| sh_of_direction(d, lmax));
    let [_, ny, nz] = target.res;
    out.data
        .par_chunks_mut(ny * nz * pc)
        .enumerate()
        .for_each(|(i, slab)| {
            for j in 0..ny {
                for k in 0..nz {
                    let x = cell_centre(target, [i, j, k]);
                    let mut corners = grid.corners(x);
                    if let Some(b) = bilateral {
                        b.reweight(x, &mut corners);
                    }
                    let a = bands_from(&corners, bands, lmax);
                    let local;
                    let y = match &fixed {
                        Some(y) => y,
                        None => {
                            local = sh_of_direction(grid.principal(x), lmax);
                            &local
                        }
                    };
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

    /// A 4³ light-aligned grid over the unit cube and the point at its local (grid-frame)
    /// coordinates `q` (cell c's centre at c).
    fn small_grid() -> LightGrid {
        LightGrid::around_box([0.0, -1.0, 0.0], [0.0; 3], [1.0; 3], 4).unwrap()
    }

    fn at(g: &LightGrid, q: [f64; 3]) -> [f64; 3] {
        let s = q.map(|v| (v + 0.5) * g.h);
        [0, 1, 2].map(|d| g.origin[d] + (0..3).map(|a| s[a] * g.axes[a][d]).sum::<f64>())
    }

    /// Item 2 of issue 52 (§4.4): an edge in σ_s half-way between the second and third
    /// coarse centres along the grid's first axis (σ_s = 2 below, 0 above), and a coarse
    /// field that follows it (A = 1 in the medium, 0 outside). Trilinear resampling blurs
    /// the edge over the coarse cell: 0.2 of a cell inside the edge it gives 0.7, 0.2
    /// outside 0.3. The joint bilateral upsampling keeps each side's value: the far side's
    /// range weight is e^{−50} (Δσ_s = 2, σ_r = 0.1 × 2), so the value is 1 resp. 0 to 1e−12.
    #[test]
    fn bilateral_upsampling_keeps_an_edge_that_trilinear_blurs() {
        let g = small_grid();
        let edge = |x: [f64; 3]| if g.local(x)[0] < 1.5 { 2.0 } else { 0.0 };
        let cells = g.cells();
        let bands: Vec<f64> = (0..cells)
            .map(|c| if edge(g.centre_of(c)) > 0.0 { 1.0 } else { 0.0 })
            .collect();
        let b = Bilateral::new(cells, |c| g.centre_of(c), &edge, 0.1).unwrap();
        for (u, want_tri, want_bil) in [(1.3, 0.7, 1.0), (1.7, 0.3, 0.0)] {
            let x = at(&g, [u, 1.2, 2.6]);
            let tri = g.corners(x);
            let mut bil = tri;
            b.reweight(x, &mut bil);
            let (t, v) = (
                bands_from(&tri, &bands, 0)[0],
                bands_from(&bil, &bands, 0)[0],
            );
            assert!((t - want_tri).abs() < 1e-12, "u {u}: trilinear {t}");
            assert!((v - want_bil).abs() < 1e-12, "u {u}: bilateral {v}");
        }
    }

    /// A constant field is reproduced to rounding (1e-14) by the bilateral upsampling onto
    /// a solve grid, for a guide that varies wildly between the coarse centres, and equals
    /// the trilinear resampling there.
    #[test]
    fn bilateral_upsampling_reproduces_a_constant_field() {
        let g = small_grid();
        let wild = |x: [f64; 3]| (17.0 * x[0]).sin().abs() * 3.0 + (9.0 * x[2]).cos().powi(2);
        let cells = g.cells();
        let bands = vec![2.5; cells * 2];
        let b = Bilateral::new(cells, |c| g.centre_of(c), &wild, 0.05).unwrap();
        let target = pn_runtime::problem::Grid {
            dim: pn_stencil::Dim::Three,
            min: [-0.2; 3],
            max: [1.2; 3],
            res: [7, 5, 6],
        };
        let moments = |bil: Option<&Bilateral<'_>>| {
            let mut out = CellMoments {
                res: target.res,
                per_cell: 4,
                data: vec![0.0; target.cells() * 4],
            };
            add_moments(&g, &bands, 1, &target, &mut out, bil);
            out.data
        };
        let (tri, bil) = (moments(None), moments(Some(&b)));
        for (t, v) in tri.iter().zip(&bil) {
            assert!((t - v).abs() < 1e-14 * (1.0 + t.abs()), "{t} vs {v}");
        }
        let y0 = sh_of_direction(g.axes[2], 0)[0];
        assert!((bil[0] - 2.5 * y0).abs() < 1e-14);
    }
}
