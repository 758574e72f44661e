//! Extra outputs of `pn solve pointsource` (docs/pointsource.md, docs/design.md §7 "Point source, 3D"):
//! `profile.csv` / `profile.png` (the discrete solution along +x from the source cell centre
//! beside the semi-analytic P_N solution, CDA and Grosjean) and `profile_diagonal.csv` (the
//! same along the face diagonal (1,1,0)/√2, for the rotational-invariance check).
//!
//! **Normalisation.** The scene's source has `∫ Q_0^0 dV = 1` (`Q_0^0 = 1/h³` in one cell, or
//! a normalised Gaussian). Its power is `∫∫ Q_0^0 Y_0^0 dω dV = √(4π)` and the fluence is
//! `φ = √(4π) L_0^0`, so the fluence *per unit power* is `G = L_0^0` (docs/design.md §7: "then
//! L_0^0 is the unit-power Green's function"). The profiles show the normalised fluence
//! `4πG/σ_t² = 4π L_0^0/σ_t²` against τ = σ_t r.
//!
//! **Gaussian source.** With `--source gaussian:<s>` every reference column is the
//! Gaussian-smoothed solution: P_N and CDA mode by mode
//! ([`PointSourceModes::fluence_gaussian`]), Grosjean by radial quadrature
//! ([`grosjean_gaussian`]), since its `e^{−τ}/τ²` term is not a Yukawa mode.

use anyhow::{ensure, Context, Result};
use pn_formats::plot::{write_profile_csv, write_profile_png_titled};
use pn_kernels::Dim;
use pn_runtime::pipeline::Solution;
use pn_runtime::problem::Grid;
use pn_runtime::reference::{grosjean, pn_point_source, PointSourceModes, ProfileRow};
use pn_runtime::scenes::{PointSourceParams, PointSourceShape};
use std::f64::consts::PI;
use std::io::Write;
use std::path::Path;

/// Direction of a sampled ray through the source cell centre.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Ray {
    /// +x: cells (c+k, c, c), r = k h_x.
    Axis,
    /// The face diagonal (1,1,0)/√2: cells (c+k, c+k, c), r = k √(h_x² + h_y²).
    Diagonal,
}

/// The source cell of the `pointsource` scene: index n/2 on every axis (cell (40,40,40) for
/// 80³, whose centre lies h/2 past the domain centre for even n, as in the paper).
pub fn source_cell(grid: &Grid) -> [usize; 3] {
    [grid.res[0] / 2, grid.res[1] / 2, grid.res[2] / 2]
}

/// The semi-analytic solution the profile compares with: P_N of the run's order, or CDA
/// (`order` = 0, i.e. `--method cda`).
pub fn exact_modes(order: usize, p: &PointSourceParams) -> Result<PointSourceModes> {
    if order == 0 {
        PointSourceModes::cda(p.albedo, p.g)
    } else {
        pn_point_source(order, p.albedo, p.g)
    }
}

/// Grosjean's approximation smoothed by a normalised 3D Gaussian of standard deviation `s_tau`
/// (mean free paths), at optical distance `tau` from its centre. A radial function `f`
/// convolved with the Gaussian is (integrating the angles analytically, as in
/// `pn_runtime::reference::gaussian`)
/// `(f∗G)(R) = 1/(R s√(2π)) ∫_0^∞ r f(r) [e^{−(R−r)²/2s²} − e^{−(R+r)²/2s²}] dr`;
/// `r f(r)` is at most `~1/r` at 0 while the bracket is `O(r)`, so the integrand is bounded.
/// Composite Gauss–Legendre (5 points on each of 400 panels over `[max(0, R−10s), R+10s]`;
/// the Gaussian tails beyond 10s are below 1e-21). For `R < s/100` the value at `R = s/100` is
/// returned (the smoothed function is even and smooth in R, so the error is O((R/s)²) ≈ 1e-4
/// relative at most — far below a discretization error that resolves such a Gaussian).
pub fn grosjean_gaussian(tau: f64, s_tau: f64, albedo: f64) -> f64 {
    if s_tau == 0.0 {
        return grosjean(tau, albedo);
    }
    let big_r = tau.abs().max(s_tau * 1e-2);
    let s = s_tau;
    let a = (big_r - 10.0 * s).max(0.0);
    let b = big_r + 10.0 * s;
    const PANELS: usize = 400;
    // 5-point Gauss–Legendre nodes and weights on [−1, 1].
    const X: [f64; 5] = [
        0.0,
        0.538_469_310_105_683_1,
        -0.538_469_310_105_683_1,
        0.906_179_845_938_664,
        -0.906_179_845_938_664,
    ];
    const W: [f64; 5] = [
        0.568_888_888_888_888_9,
        0.478_628_670_499_366_5,
        0.478_628_670_499_366_5,
        0.236_926_885_056_189_1,
        0.236_926_885_056_189_1,
    ];
    let width = (b - a) / PANELS as f64;
    let mut sum = 0.0;
    for p in 0..PANELS {
        let mid = a + (p as f64 + 0.5) * width;
        for (x, w) in X.iter().zip(&W) {
            let r = mid + 0.5 * width * x;
            let rf = r * grosjean(r, albedo);
            let bracket = (-(big_r - r).powi(2) / (2.0 * s * s)).exp()
                - (-(big_r + r).powi(2) / (2.0 * s * s)).exp();
            sum += w * 0.5 * width * rf * bracket;
        }
    }
    sum / (big_r * s * (2.0 * PI).sqrt())
}

/// The normalised fluence `4π L_0^0/σ_t²` (see the module documentation) in the cells along
/// `ray` from the source cell (excluding the source cell itself), with the reference columns.
///
/// `l00` is L_0^0 at cell centres, x slowest (as [`Solution::l00`]); the grid must be 3D.
pub fn profile(
    grid: &Grid,
    l00: &[f64],
    p: &PointSourceParams,
    modes: &PointSourceModes,
    ray: Ray,
) -> Result<Vec<ProfileRow>> {
    ensure!(
        grid.dim == Dim::Three,
        "point-source profiles need a 3D grid"
    );
    let [nx, ny, nz] = grid.res;
    ensure!(
        l00.len() == nx * ny * nz,
        "L_0^0 has {} values, the grid {} cells",
        l00.len(),
        nx * ny * nz
    );
    let c = source_cell(grid);
    let (hx, hy) = (grid.h(0), grid.h(1));
    let steps = match ray {
        Ray::Axis => nx - 1 - c[0],
        Ray::Diagonal => (nx - 1 - c[0]).min(ny - 1 - c[1]),
    };
    let cda = PointSourceModes::cda(p.albedo, p.g)?;
    let s_tau = match p.source {
        PointSourceShape::Cell => 0.0,
        PointSourceShape::Gaussian(s) => p.sigma_t * s,
    };
    let scale = 4.0 * PI / (p.sigma_t * p.sigma_t);
    let mut rows = Vec::with_capacity(steps);
    for k in 1..=steps {
        let (i, j, r) = match ray {
            Ray::Axis => (c[0] + k, c[1], k as f64 * hx),
            Ray::Diagonal => (c[0] + k, c[1] + k, k as f64 * hx.hypot(hy)),
        };
        let tau = p.sigma_t * r;
        let solved = scale * l00[(i * ny + j) * nz + c[2]];
        rows.push(ProfileRow {
            tau,
            solved,
            pn_exact: modes.fluence_gaussian(tau, s_tau),
            cda: cda.fluence_gaussian(tau, s_tau),
            grosjean: grosjean_gaussian(tau, s_tau, p.albedo),
        });
    }
    Ok(rows)
}

/// Interpolates one column of a profile at optical distance `tau`: linear interpolation of
/// `ln(τ·value)` in τ between the neighbouring samples (exact for a single mode `C e^{−κτ}/τ`,
/// so the interpolation error is that of the mode mixture's curvature, O(Δτ²)). `None` outside
/// the sampled range or where a value is not positive.
pub fn interpolate(rows: &[ProfileRow], tau: f64, column: fn(&ProfileRow) -> f64) -> Option<f64> {
    let k = rows
        .windows(2)
        .position(|w| w[0].tau <= tau && tau <= w[1].tau)?;
    let (a, b) = (&rows[k], &rows[k + 1]);
    let (va, vb) = (column(a) * a.tau, column(b) * b.tau);
    if !(va > 0.0 && vb > 0.0) {
        return None;
    }
    let t = (tau - a.tau) / (b.tau - a.tau);
    Some((va.ln() * (1.0 - t) + vb.ln() * t).exp() / tau)
}

/// Writes `profile.csv`, `profile.png` and `profile_diagonal.csv` into `out` and prints the
/// deviations at τ = 1, 2, 4 to `stdout`. Called by `pn solve` for the `pointsource` scene
/// solved with the parameters `p`; `order` is the P_N order (0 for `--method cda`). A 2D run
/// (a line source) gets a note and no profile.
pub fn write_extras(
    out: &Path,
    p: &PointSourceParams,
    grid: &Grid,
    sol: &Solution,
    order: usize,
    stdout: &mut dyn Write,
) -> Result<()> {
    if grid.dim != Dim::Three {
        eprintln!("note: no profile.csv for a 2D pointsource run (a line source, not the 3D Green's function)");
        return Ok(());
    }
    // No infinite-medium solution without absorption (α = 1): skip the profile, not the run.
    let modes = match exact_modes(order, p) {
        Ok(m) => m,
        Err(e) => {
            eprintln!("note: no profile.csv: {e}");
            return Ok(());
        }
    };
    let l00 = sol.l00();
    let axis = profile(grid, &l00, p, &modes, Ray::Axis)?;
    let diagonal = profile(grid, &l00, p, &modes, Ray::Diagonal)?;
    if axis.is_empty() {
        eprintln!(
            "note: no profile.csv: the grid has no cell beyond the source cell along +x (use --res 3 or more)"
        );
        return Ok(());
    }
    write_profile_csv(out.join("profile.csv"), &axis)?;
    write_profile_csv(out.join("profile_diagonal.csv"), &diagonal)?;
    let what = if order == 0 {
        "CDA".to_string()
    } else {
        format!("P_{order}")
    };
    let title = format!(
        "Point source, {what}, α = {}, g = {}, {}×{}×{}",
        p.albedo, p.g, grid.res[0], grid.res[1], grid.res[2]
    );
    write_profile_png_titled(out.join("profile.png"), &axis, &title)
        .with_context(|| format!("writing {}", out.join("profile.png").display()))?;
    for tau in [1.0, 2.0, 4.0] {
        let (Some(s), Some(e), Some(gr)) = (
            interpolate(&axis, tau, |r| r.solved),
            interpolate(&axis, tau, |r| r.pn_exact),
            interpolate(&axis, tau, |r| r.grosjean),
        ) else {
            continue;
        };
        writeln!(
            stdout,
            "profile τ={tau}: solved {s:.5e}, {what} exact {e:.5e} ({:+.2}%), Grosjean {gr:.5e} ({:+.2}%)",
            100.0 * (s / e - 1.0),
            100.0 * (s / gr - 1.0)
        )?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Far from the Gaussian (R ≫ s) each Yukawa mode tends to `e^{κ²s²/2} e^{−κR}/R`, so the
    /// smoothed Grosjean's second term does; the first (`e^{−τ}/τ²`) is smooth there and the
    /// smoothing changes it by O(s²) relative. Check the quadrature against a closed form: the
    /// diffusion term alone equals `yukawa_gaussian` (1e-9: quadrature error is far smaller).
    #[test]
    fn smoothed_grosjean_matches_mode_formula() {
        let alpha: f64 = 0.9;
        let lam = (3.0f64 * (1.0 - alpha) / (2.0 - alpha)).sqrt();
        let amp = 3.0 * alpha / (2.0 - alpha);
        for (tau, s) in [(0.05, 0.3), (1.0, 0.3), (2.5, 0.5), (4.0, 0.1)] {
            let first = grosjean_gaussian(tau, s, 0.0); // α = 0: only e^{−τ}/τ²
            let both = grosjean_gaussian(tau, s, alpha);
            let mode = amp * pn_runtime::reference::yukawa_gaussian(tau, lam, s);
            assert!(
                ((both - first) / mode - 1.0).abs() < 1e-9,
                "τ={tau} s={s}: {} vs {mode}",
                both - first
            );
        }
        // Small s: back to the unsmoothed value (O(s²) change, s = 1e-3 at τ = 1).
        let g = grosjean(1.0, alpha);
        assert!((grosjean_gaussian(1.0, 1e-3, alpha) / g - 1.0).abs() < 1e-5);
    }

    #[test]
    fn log_linear_interpolation_is_exact_for_one_mode() {
        let f = |t: f64| 3.0 * (-0.5 * t).exp() / t;
        let rows: Vec<ProfileRow> = (1..10)
            .map(|k| {
                let t = k as f64 * 0.7;
                ProfileRow {
                    tau: t,
                    solved: f(t),
                    pn_exact: f(t),
                    cda: f(t),
                    grosjean: f(t),
                }
            })
            .collect();
        let v = interpolate(&rows, 2.0, |r| r.solved).unwrap();
        assert!((v / f(2.0) - 1.0).abs() < 1e-13);
        assert!(interpolate(&rows, 0.1, |r| r.solved).is_none());
    }
}
