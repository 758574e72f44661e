//! The built-in render scenes (`scenes/<name>.toml`, compiled in by
//! [`pn_runtime::scene_registry`]) and loading a scene by built-in name or file path.

use super::*;
use crate::scene_override::SceneOverride;
use anyhow::Context;
use pn_runtime::scene_registry::{self, SceneKind};
use std::path::Path;

/// Names of the built-in render scenes (the [`SceneKind::Render`] entries of
/// [`pn_runtime::scene_registry::BUILTIN_SCENES`]).
pub fn builtin_names() -> Vec<&'static str> {
    scene_registry::names(SceneKind::Render)
}

impl RenderScene {
    /// A built-in render scene ([`builtin_names`]; the same files as `scenes/<name>.toml`,
    /// compiled in by [`pn_runtime::scene_registry`]). `None` for any other name, a built-in
    /// solve scene's included.
    pub fn builtin(name: &str) -> Option<RenderScene> {
        let text = scene_registry::find_kind(name, SceneKind::Render)?.toml?;
        // The built-in files are tested to parse (see the tests below).
        let mut s = Self::from_toml_str(text, Path::new(".")).ok()?;
        s.name = name.to_string();
        Some(s)
    }

    /// A built-in name or a scene file path. A built-in solve scene's name (`checkerboard`,
    /// …) is refused with a message naming `pn solve`.
    pub fn load(arg: &str) -> anyhow::Result<RenderScene> {
        Self::load_with_overrides(arg, &[])
    }

    /// [`RenderScene::load`] with `--set` overrides applied to the scene's TOML (a file's or
    /// a built-in's text) before it is checked
    /// ([`RenderScene::from_toml_str_with_overrides`]). The name stays the file stem or the
    /// built-in name.
    pub fn load_with_overrides(
        arg: &str,
        overrides: &[SceneOverride],
    ) -> anyhow::Result<RenderScene> {
        let path = Path::new(arg);
        if arg.ends_with(".toml") || path.is_file() {
            return Self::from_path_with_overrides(path, overrides);
        }
        if let Some(e) = scene_registry::wrong_kind_error(arg, SceneKind::Render) {
            return Err(e);
        }
        let unknown = || {
            format!(
                "{arg:?} is neither a scene file nor a built-in scene ({})",
                builtin_names().join(", ")
            )
        };
        if overrides.is_empty() {
            return Self::builtin(arg).with_context(unknown);
        }
        let text = scene_registry::find_kind(arg, SceneKind::Render)
            .and_then(|e| e.toml)
            .with_context(unknown)?;
        let mut s = Self::from_toml_str_with_overrides(text, Path::new("."), overrides)
            .with_context(|| format!("built-in scene {arg}"))?;
        s.name = arg.to_string();
        Ok(s)
    }
}
