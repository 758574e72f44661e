//! `pn-render` — rendering participating media with deterministic multiple scattering
//! (docs/design.md §6, docs/rendering.md).
//!
//! A render scene ([`RenderScene`]: a TOML file, a built-in name, or built in code;
//! the format is specified in [`scene`]) goes through one pipeline, [`render_views`]:
//! its density grid, the multiple scattering of its method (one [`MultipleScattering`]
//! implementation per method: P_N, CDA, FLD, POP, none, a text PDE), the first-scatter
//! source and the transport sweeps, and the deterministic ray marcher or the Monte Carlo
//! renderer. It returns a [`RenderRun`] — images, the solution, the [`RenderReport`] and
//! notes — in memory: the library writes no file and prints nothing; a caller watching the
//! progress passes callbacks in the [`RenderOptions`].
//!
//! ```no_run
//! use pn_render::{render_views, RenderOptions, RenderScene};
//!
//! let mut scene = RenderScene::load("sphere")?;
//! scene.camera.width = 32;
//! scene.camera.height = 24;
//! let options = RenderOptions { progress: false, ..Default::default() };
//! let run = render_views(&scene, &options, 1)?;
//! println!("{} × {} px, mean {:.3e}", run.image.width, run.image.height, run.report.mean_radiance);
//! # Ok::<(), anyhow::Error>(())
//! ```
//!
//! The modules:
//!
//! * [`scene`]: the render scene, its TOML format, voxel files, validation and the built-in
//!   scenes; [`scene_override`]: `--set SECTION.KEY=VALUE` on its TOML;
//! * [`pipeline`]: [`render_views`], its options, run and report, and the methods
//!   ([`pipeline::methods`]);
//! * [`medium`]: the density grid, its filter (trilinear as Mitsuba, or nearest) and the
//!   procedural media; [`colour`]: per-channel (RGB) media and lights;
//! * [`lights`], [`camera`]: lights, phase function values and the pinhole camera;
//! * [`shadow`], [`light_depth`]: exact optical depth (traversal of the filter's lattice),
//!   the optical depth to the lights;
//! * [`solve_setup`], [`first_scatter`], [`hull_absorber`], [`source_quadrature`]: the
//!   cropped solve grid, resampled coefficients, the absorber and the first-scatter source
//!   moments (a [`pn_runtime::problem::Problem`]);
//! * [`fld_problem`], [`pde_kernel`]: the FLD problem and its solve, text PDEs' stencils
//!   (shared with `pn solve`);
//! * [`transport_sweep`]: source iterations of the transport equation started from the
//!   solution, which the renderer reads instead of it;
//! * [`march`], [`renderer`]: the deterministic ray marcher; delta tracking, next-event
//!   estimation and the solution lookup;
//! * [`pop`]: Principal-Ordinates Propagation for directional lights;
//! * [`mitsuba`], [`compare`]: the Mitsuba 3 export and image comparison;
//! * [`scene_file`], [`scene_kind`]: the TOML solve scenes of `pn solve` (with voxel files).
#![warn(missing_docs)]

pub mod camera;
pub mod colour;
pub mod compare;
pub mod first_scatter;
pub mod fld_problem;
pub mod hull_absorber;
pub mod light_depth;
pub mod lights;
pub mod march;
pub mod medium;
pub mod mitsuba;
pub mod pde_kernel;
pub mod pipeline;
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
pub use pipeline::methods::{method_for, MsSolution, MultipleScattering, PreparedScene};
pub use pipeline::{
    render_scene, render_views, turntable_camera, ProgressCallback, RenderOptions, RenderReport,
    RenderRun, RgbImages,
};
pub use renderer::Image;
pub use scene::{
    AbsorberPlacement, MediumSpec, MsLookup, RenderMethod, RenderScene, RenderSettings,
    SolveBoundary, SolveSettings,
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
