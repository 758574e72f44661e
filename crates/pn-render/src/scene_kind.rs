//! Which command a scene file belongs to, told from its TOML tables (a hint for the error
//! message when a file is given to the wrong command).

use pn_runtime::scene_registry::SceneKind;

/// Which kind of scene the TOML `text` looks like, from its top-level keys (`[medium]`,
/// `[camera]` or `[[light]]`: render; `sigma_t`, `[[source]]`, `dim` or a domain: solve), or
/// `None` when it is no TOML table or shows neither. Only a hint for error messages, when a
/// file was given to the wrong command; the loaders decide what a file is.
pub fn toml_kind(text: &str) -> Option<SceneKind> {
    let table: toml::Table = toml::from_str(text).ok()?;
    let has = |keys: &[&str]| keys.iter().any(|k| table.contains_key(*k));
    match (
        has(&["medium", "camera", "light"]),
        has(&[
            "sigma_t",
            "sigma_s",
            "source",
            "dim",
            "domain_min",
            "domain_max",
        ]),
    ) {
        (true, false) => Some(SceneKind::Render),
        (false, true) => Some(SceneKind::Solve),
        _ => None,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use pn_runtime::scene_registry::BUILTIN_SCENES;

    #[test]
    fn scene_files_are_told_apart_by_their_tables() {
        for s in BUILTIN_SCENES.iter().filter_map(|s| s.toml) {
            assert_eq!(toml_kind(s), Some(SceneKind::Render));
        }
        let solve = include_str!("../../../scenes/box.toml");
        assert_eq!(toml_kind(solve), Some(SceneKind::Solve));
        assert_eq!(toml_kind("not = [toml"), None);
        assert_eq!(toml_kind("x = 1"), None);
    }
}
