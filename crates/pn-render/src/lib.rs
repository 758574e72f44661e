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
//! Public modules, for what has many parts of its own:
//!
//! * [`scene`]: the render scene, its TOML format, voxel files, validation and the built-in
//!   scenes (its enums: [`scene::RenderMethod`], [`scene::RendererKind`], …);
//! * [`fld_problem`]: the FLD problem of a scene and its solve (the route `pn render` and
//!   `pn solve` share); [`pde_kernel`]: text PDEs' stencils (shared with `pn solve`);
//! * [`pop`]: Principal-Ordinates Propagation for directional lights;
//! * [`sky`]: sky lights (a uniform sky, a latitude–longitude environment map in Mitsuba's
//!   convention) and how they become directional lights;
//! * [`mitsuba`]: the Mitsuba 3 export and run; [`compare`]: image comparison (metrics,
//!   difference images).
//!
//! Re-exported here, from private modules:
//!
//! * the pipeline: [`render_views`], [`render_scene`], [`RenderOptions`],
//!   [`ProgressCallback`], [`RenderRun`], [`RgbImages`], [`turntable_camera`], [`MAX_VIEWS`],
//!   and the report ([`RenderReport`], [`ViewReport`], [`ChannelReport`], [`SolverReport`],
//!   [`Timings`], [`UnknownStats`]);
//! * the methods: [`MultipleScattering`], [`method_for`], [`PreparedScene`], [`MsSolution`];
//! * the scene's main types: [`RenderScene`], [`MediumSpec`], [`RenderSettings`],
//!   [`SolveSettings`], [`SolveBoundary`], [`AbsorberPlacement`], [`SweepScheme`], [`MsLookup`],
//!   [`RenderMethod`], and [`SceneOverride`] (`--set SECTION.KEY=VALUE` on its TOML);
//! * media and lights: [`DensityGrid`], [`DensityFilter`] (trilinear as Mitsuba, or
//!   nearest), [`Procedural`], [`Light`], [`phase_value`], [`Camera`], [`CHANNELS`] (the
//!   RGB channels of a coloured scene);
//! * the Monte Carlo renderer: [`Renderer`] (delta tracking, next-event estimation),
//!   [`Rng`], [`Image`];
//! * [`solve_grid`]: the cropped solve grid of a scene;
//! * [`load_scene`]: the TOML solve scenes of `pn solve` (with voxel files).
//!
//! The rest is private: the first-scatter source, exact optical depth, the absorber, the
//! transport sweeps and the deterministic ray marcher.
#![warn(missing_docs)]

mod camera;
mod colour;
pub mod compare;
mod delta_m;
mod first_scatter;
pub mod fld_problem;
mod hull_absorber;
mod light_depth;
mod lights;
mod march;
mod medium;
pub mod mitsuba;
pub mod pde_kernel;
mod pipeline;
pub mod pop;
mod progress;
mod renderer;
pub mod scene;
mod scene_file;
mod scene_kind;
mod scene_override;
mod shadow;
pub mod sky;
mod sky_view;
mod solve_setup;
mod source_quadrature;
mod transport_sweep;

pub use camera::Camera;
pub use colour::CHANNELS;
pub use delta_m::LightLeg;
pub use lights::{phase_value, Light};
pub use medium::{DensityFilter, DensityGrid, Procedural};
pub use pipeline::methods::{method_for, MsSolution, MultipleScattering, PreparedScene};
pub use pipeline::{
    render_scene, render_views, turntable_camera, ChannelReport, LinearSolver, ProgressCallback,
    RenderOptions, RenderReport, RenderRun, RgbImages, SolverReport, Timings, UnknownStats,
    ViewReport, MAX_VIEWS,
};
pub use renderer::{Image, Renderer, Rng};
pub use scene::{
    AbsorberPlacement, MediumSpec, MsLookup, RenderMethod, RenderScene, RenderSettings,
    SolveBoundary, SolveSettings, SweepScheme,
};
pub use scene_file::load_scene;
pub use scene_override::SceneOverride;
pub use solve_setup::solve_grid;

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
