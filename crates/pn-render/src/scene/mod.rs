//! Render scenes (`pn render`): the TOML format, its validation and the built-in scenes
//! (`scenes/<name>.toml`, listed with their descriptions in [`pn_runtime::scene_registry`], which
//! also says how this format differs from the solve-scene format of [`crate::scene_file`]).
//!
//! Unknown keys are refused; parse errors carry the line and column; relative file paths
//! are resolved against the scene file's folder. `pn render --set SECTION.KEY=VALUE`
//! overrides ([`crate::scene_override`]) are applied to the TOML table before these checks
//! ([`RenderScene::load_with_overrides`]). See [`crate::medium`] and
//! [`crate::camera`] for the geometric conventions shared with the Mitsuba export.
//!
//! The submodules: [`types`] (the scene and its settings), `parse` (the TOML representation
//! and its translation), `voxels` (grid files and arrays), `validate` (the checks) and
//! `builtin` (the built-in scenes and [`RenderScene::load`]).
//!
//! # The scene format
//!
#![doc = include_str!("../../../../docs/scene-format.md")]

mod builtin;
mod parse;
pub mod types;
mod validate;
mod voxels;

pub use builtin::builtin_names;
pub use parse::{phase_from_table, solve_from_toml_str};
pub use types::*;
pub use voxels::{check_array_shape, ARRAY_BYTES_PER_VOXEL};

#[cfg(test)]
mod sky_tests;
#[cfg(test)]
mod tests;
