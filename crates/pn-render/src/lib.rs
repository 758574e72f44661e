//! `pn-render` — rendering participating media with deterministic multiple scattering
//! (docs/design.md §6, docs/rendering.md).
//!
//! It builds on the solver core `pn-runtime`: a render scene becomes a transport problem
//! (the lights' first scattering as its source), the solution is rendered by ray marching.
//!
//! * [`scene`]: the TOML render scene ([`RenderScene`]) and the built-in scenes;
//!   [`scene_override`]: `pn render --set SECTION.KEY=VALUE` on its TOML;
//! * [`medium`]: the density grid, its filter (trilinear as Mitsuba, or nearest) and the
//!   procedural media;
//! * [`colour`]: per-channel (RGB) media and lights, rendered channel by channel;
//! * [`lights`], [`camera`]: lights, phase function values and the pinhole camera;
//! * [`shadow`]: exact optical depth (traversal of the filter's lattice), deep shadow maps;
//! * [`solve_setup`], [`first_scatter`]: the cropped solve grid, resampled coefficients and
//!   the first-scatter source moments (a [`pn_runtime::problem::Problem`]);
//! * [`transport_sweep`]: source iterations of the transport equation started from the
//!   solution, which the renderer reads instead of it;
//! * [`renderer`]: delta tracking, next-event estimation and the solution lookup;
//! * images are written by `pn_formats::image_io` (EXR and tone-mapped PNG);
//! * `mitsuba`, `compare`: the Mitsuba 3 export and image comparison (helper "mitsuba");
//! * [`pop`]: Principal-Ordinates Propagation for directional lights;
//! * [`scene_file`]: the TOML solve scenes of `pn solve` (with voxel files).
#![warn(missing_docs)]

pub mod camera;
pub mod colour;
pub mod compare;
pub mod first_scatter;
pub mod hull_absorber;
pub mod light_depth;
pub mod lights;
pub mod march;
pub mod medium;
pub mod mitsuba;
pub mod pop;
mod progress;
pub mod renderer;
pub mod scene;
pub mod scene_file;
pub mod scene_kind;
pub mod scene_override;
pub mod shadow;
pub mod solve_setup;
pub mod source_quadrature;
pub mod transport_sweep;

pub use camera::Camera;
pub use lights::Light;
pub use medium::{DensityFilter, DensityGrid, Procedural};
pub use scene::{
    AbsorberPlacement, MediumSpec, MsLookup, RenderScene, RenderSettings, SolveBoundary,
    SolveSettings,
};
pub use scene_override::SceneOverride;

/// The 3D grid of `res` cells over the box [−1, 1]³ that the render modules' tests share.
#[cfg(test)]
pub(crate) fn test_box_grid(res: [usize; 3]) -> pn_runtime::problem::Grid {
    pn_runtime::problem::Grid {
        dim: pn_stencil::Dim::Three,
        min: [-1.0; 3],
        max: [1.0; 3],
        res,
    }
}
