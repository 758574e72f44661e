//! What `pn solve slab` and `pn solve milne` add to `report.json`: the quantities the
//! Marshak vacuum boundary is checked with (docs/design.md §3, "Domain and boundary";
//! `tests/data/marshak/README.md`), next to the 1D P_N–Marshak reference of the same order
//! ([`pn_runtime::reference::slab`]) when one exists.
//!
//! * `slab`: `reflection` and `transmission`, the collided outgoing flux per unit incident
//!   flux through x = 0 and x = τ ([`slab_fluxes`]; for a text PDE that closes the faces
//!   with its own `boundary marshak` conditions, the flux of its L_0^0 equation through the
//!   faces, [`pn_runtime::RobinFaces::face_outflow`]); `reference_reflection` and
//!   `reference_transmission` (P_N–Marshak, exact in 1D) for odd N and albedo < 1, when the
//!   boundary is Marshak on both x faces.
//! * `milne`: `extrapolation_length` ([`milne_extrapolation_length`]) and
//!   `reference_extrapolation_length` (P_N–Marshak) for odd N with a Marshak face at x = 0.

use anyhow::Result;
use pn_formats::VacuumMeasurements;
use pn_runtime::pipeline::Solution;
use pn_runtime::problem::{BoundaryKind, Problem};
use pn_runtime::reference::{pn_marshak_milne, pn_marshak_slab};
use pn_runtime::scenes::vacuum::{milne_extrapolation_length, slab_fluxes, SLAB_ALBEDO};
use pn_runtime::RobinFaces;
use pn_stencil::StencilKernel;
use std::io::Write;

/// Whether `scene` has extras here.
pub fn applies(scene: &str) -> bool {
    scene == "slab" || scene == "milne"
}

/// Measures the `slab` or `milne` scene for `report.json` ([`VacuumMeasurements`]) and
/// prints the measurements. `order` is the P_N order (0 for CDA and text PDEs: no
/// reference); `kernel` is the solved stencil (a text PDE closing the faces itself gives R
/// and T through its conditions).
pub fn measure(
    scene: &str,
    problem: &Problem,
    kernel: &dyn StencilKernel,
    albedo: Option<f64>,
    sol: &Solution,
    order: usize,
    stdout: &mut dyn Write,
) -> Result<VacuumMeasurements> {
    let b = &problem.boundary;
    let odd = order % 2 == 1;
    let mut m = VacuumMeasurements::default();
    if scene == "slab" {
        let robin = RobinFaces::new(problem, &sol.layout, kernel)?;
        let (r, t) = match &robin {
            Some(f) if f.closes((0, 0)) && f.closes((0, 1)) => (
                f.face_outflow(problem, kernel, &sol.layout, &sol.u, (0, 0))?,
                f.face_outflow(problem, kernel, &sol.layout, &sol.u, (0, 1))?,
            ),
            _ => slab_fluxes(&sol.layout, &sol.u)?,
        };
        m.reflection = Some(r);
        m.transmission = Some(t);
        let tau = problem.grid.max[0] - problem.grid.min[0];
        let c = albedo.unwrap_or(SLAB_ALBEDO);
        let vacuum = b.face(0, 0) == BoundaryKind::Marshak && b.face(0, 1) == BoundaryKind::Marshak;
        write!(
            stdout,
            "slab τ = {tau}, albedo {c}: reflection {r:.6}, transmission {t:.6}"
        )?;
        if odd && vacuum && c < 1.0 {
            let reference = pn_marshak_slab(order, tau, c)?;
            m.reference_reflection = Some(reference.reflection);
            m.reference_transmission = Some(reference.transmission);
            write!(
                stdout,
                " (1D P_{order}–Marshak: {:.6}, {:.6})",
                reference.reflection, reference.transmission
            )?;
        }
        writeln!(stdout)?;
    } else {
        let z0 = milne_extrapolation_length(&problem.grid, &sol.layout, &sol.u)?;
        m.extrapolation_length = Some(z0);
        write!(stdout, "milne: extrapolation length {z0:.6}")?;
        if odd && b.face(0, 0) == BoundaryKind::Marshak {
            let reference = pn_marshak_milne(order)?;
            m.reference_extrapolation_length = Some(reference);
            write!(stdout, " (P_{order}–Marshak: {reference:.6})")?;
        }
        writeln!(stdout)?;
    }
    Ok(m)
}
