//! Reference solutions: point source in an infinite medium (P_N, CDA, Grosjean).
//!
//! docs/design.md §7 ("Point source, 3D") and `tests/data/pointsource/README.md`.
//! Everything here is expressed in the *normalised* form used there: with τ = σ_t r the
//! normalised fluence of a unit-power isotropic point source is `4πφ/σ_t²`, a function of τ
//! (and of the albedo α and the Henyey–Greenstein g) only. The `*_world` helpers convert to
//! the fluence φ in world units for a given σ_t.
//!
//! * [`pointsource`]: the semi-analytic P_N solution for any order (slab eigen-decomposition),
//!   CDA and SP_3 as modes of the same form.
//! * [`closed_forms`]: CDA (= P_1), Grosjean's approximation, and the exact transport
//!   diffusion mode for isotropic scattering.
//! * [`gaussian`]: the same solutions for a source with a 3D Gaussian profile (for
//!   convergence studies), and the scaled complementary error function they need.
//! * [`profile`]: the `profile.csv` / `profile.png` outputs of the `pointsource` scene.
//! * [`slab`]: the 1D P_N–Marshak slab (reflection, transmission) and Milne (extrapolation
//!   length) references of `tests/data/marshak/README.md` (eigen-decomposition).
//! * [`special`]: the special functions they need (erfc, the scaled erfcx).
//! * [`starmap`]: the reader of the StaRMAP checkerboard references (CSV).

pub mod closed_forms;
pub mod gaussian;
pub mod pointsource;
pub mod profile;
pub mod slab;
pub mod special;
pub mod starmap;

pub use closed_forms::{
    cda_point_source, grosjean, transport_diffusion_mode, TransportDiffusionMode,
};
pub use gaussian::{gaussian_3d, yukawa_gaussian};
pub use pointsource::{pn_point_source, PointSourceModes, MAX_ORDER};
pub use profile::ProfileRow;
pub use slab::{pn_marshak_milne, pn_marshak_slab, SlabReference};
pub use special::{erfc, erfcx};
