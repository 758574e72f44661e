//! The registry of built-in scenes: every built-in name, which command it belongs to, and a
//! one-line description. Both loaders consult it — [`crate::scenes::builtin`] (`pn solve`)
//! and `pn_render::scene::RenderScene::builtin` (`pn render`) — so that a name given
//! to the wrong command is answered with the right command and the names available.
//!
//! **Two kinds, two formats.** The scene formats stay two on purpose, because the two
//! commands solve different problems:
//!
//! * A *solve scene* ([`SceneKind::Solve`]) is the transport problem itself, posed on a grid:
//!   the domain and resolution, σ_t and σ_s (or the albedo), the phase function, the source
//!   moments `Q_l^m` and the boundary closure. `pn solve` writes the moments of the
//!   solution. Built-in solve scenes are built in code ([`crate::scenes`]: the lattice
//!   tests and the point source have analytic fields); files use the TOML format of
//!   `pn_render::scene_file` (e.g. `scenes/box.toml`).
//! * A *render scene* ([`SceneKind::Render`]) describes what a camera sees: a medium (density
//!   grid or procedural kind, its box, σ_t scale and albedo), the phase function, lights and a
//!   camera, plus the settings of the solve behind the image. Its transport problem is
//!   derived from it (the sources are the lights' first scattering, the grid is cropped
//!   around the medium; see `pn_render`). Built-in render scenes are the files
//!   `scenes/<name>.toml` compiled in; files use the TOML format of
//!   `pn_render::scene`.

/// Which command a built-in scene belongs to.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SceneKind {
    /// A transport problem for `pn solve` ([`crate::scenes::Scene`]).
    Solve,
    /// A medium, lights and a camera for `pn render` (`pn_render::scene::RenderScene`).
    Render,
}

impl SceneKind {
    /// The command that takes scenes of this kind: `pn solve` or `pn render`.
    pub fn command(self) -> &'static str {
        match self {
            SceneKind::Solve => "pn solve",
            SceneKind::Render => "pn render",
        }
    }

    /// `solve` or `render`, as in "a built-in render scene".
    pub fn name(self) -> &'static str {
        match self {
            SceneKind::Solve => "solve",
            SceneKind::Render => "render",
        }
    }
}

/// One built-in scene.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct BuiltinScene {
    /// The name given on the command line.
    pub name: &'static str,
    /// The command it belongs to.
    pub kind: SceneKind,
    /// What it is, in one line.
    pub description: &'static str,
    /// The render scene's TOML text (the file `scenes/<name>.toml`); `None` for solve scenes,
    /// which [`crate::scenes::builtin`] builds in code.
    pub toml: Option<&'static str>,
}

/// Every built-in scene, solve scenes first, in the order the help texts list them.
pub const BUILTIN_SCENES: [BuiltinScene; 9] = [
    BuiltinScene {
        name: "checkerboard",
        kind: SceneKind::Solve,
        description: "the 2D lattice test on [0,7]²: absorbing blocks around a central \
                      source, 71² cells, P_5 by default",
        toml: None,
    },
    BuiltinScene {
        name: "checkerboard3d",
        kind: SceneKind::Solve,
        description: "the 3D lattice test on [0,7]³, 31³ cells, P_1 by default",
        toml: None,
    },
    BuiltinScene {
        name: "pointsource",
        kind: SceneKind::Solve,
        description: "an isotropic point source in a homogeneous medium, σ_t = 8 and \
                      α = 0.9 on [0,2]³, 80³ cells, with analytic references",
        toml: None,
    },
    BuiltinScene {
        name: "slab",
        kind: SceneKind::Solve,
        description: "a slab of optical thickness --tau (1) and --albedo (0.9) lit by a \
                      normal beam, Marshak vacuum faces in x: collided reflection and \
                      transmission",
        toml: None,
    },
    BuiltinScene {
        name: "milne",
        kind: SceneKind::Solve,
        description: "the Milne problem (half-space, c = 1, Marshak face at x = 0, depth \
                      --tau 30): the extrapolation length",
        toml: None,
    },
    BuiltinScene {
        name: "cloud",
        kind: SceneKind::Render,
        description: "a noise-displaced cumulus-like cloud in vacuum, lit from the upper left",
        toml: Some(include_str!("../../../scenes/cloud.toml")),
    },
    BuiltinScene {
        name: "nebula",
        kind: SceneKind::Render,
        description: "three noise-warped lobes of wispy, highly scattering density, the \
                      comparison figure's scene",
        toml: Some(include_str!("../../../scenes/nebula.toml")),
    },
    BuiltinScene {
        name: "sphere",
        kind: SceneKind::Render,
        description: "a homogeneous ball lit by a directional and a point light",
        toml: Some(include_str!("../../../scenes/sphere.toml")),
    },
    BuiltinScene {
        name: "lowalbedo",
        kind: SceneKind::Render,
        description: "a low-albedo medium for the single-scattering check against Mitsuba",
        toml: Some(include_str!("../../../scenes/lowalbedo.toml")),
    },
];

/// The built-in scene called `name`, of either kind.
pub fn find(name: &str) -> Option<&'static BuiltinScene> {
    BUILTIN_SCENES.iter().find(|s| s.name == name)
}

/// The built-in scene `name` if it is of `kind`.
pub fn find_kind(name: &str, kind: SceneKind) -> Option<&'static BuiltinScene> {
    find(name).filter(|s| s.kind == kind)
}

/// The names of the built-in scenes of `kind`, in registry order.
pub fn names(kind: SceneKind) -> Vec<&'static str> {
    BUILTIN_SCENES
        .iter()
        .filter(|s| s.kind == kind)
        .map(|s| s.name)
        .collect()
}

/// The error for `name` given where a built-in scene of `wanted` kind was expected, when
/// `name` is a built-in scene of the other kind: it names the command to use and the
/// built-in scenes `wanted` has. `None` when `name` is no built-in scene of the other kind
/// (the loader then gives its own "unknown scene" message).
pub fn wrong_kind_error(name: &str, wanted: SceneKind) -> Option<anyhow::Error> {
    let s = find(name).filter(|s| s.kind != wanted)?;
    Some(anyhow::anyhow!(
        "{name:?} is a built-in {} scene ({}); run it with `{} {name}`. The built-in scenes \
         of `{}` are {} (or give a path to a .toml {} scene file)",
        s.kind.name(),
        s.description,
        s.kind.command(),
        wanted.command(),
        names(wanted).join(", "),
        wanted.name()
    ))
}

/// The hint for a scene file of `found` kind given to the command of the other kind, e.g.
/// "this is a render scene file: run it with `pn render scenes/cloud.toml`".
pub fn wrong_kind_file_hint(path: &std::path::Path, found: SceneKind) -> String {
    format!(
        "this is a {} scene file: run it with `{} {}`",
        found.name(),
        found.command(),
        path.display()
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_are_unique_and_render_scenes_carry_their_file() {
        for (i, a) in BUILTIN_SCENES.iter().enumerate() {
            assert!(
                BUILTIN_SCENES[i + 1..].iter().all(|b| b.name != a.name),
                "{}",
                a.name
            );
            assert_eq!(a.toml.is_some(), a.kind == SceneKind::Render, "{}", a.name);
            assert!(!a.description.is_empty() && !a.description.contains('\n'));
        }
        assert_eq!(
            names(SceneKind::Solve),
            [
                "checkerboard",
                "checkerboard3d",
                "pointsource",
                "slab",
                "milne"
            ]
        );
        assert_eq!(
            names(SceneKind::Render),
            ["cloud", "nebula", "sphere", "lowalbedo"]
        );
    }

    #[test]
    fn a_name_of_the_other_kind_names_the_right_command() {
        let e = wrong_kind_error("cloud", SceneKind::Solve)
            .map(|e| e.to_string())
            .unwrap_or_default();
        assert!(e.contains("`pn render cloud`"), "{e}");
        assert!(
            e.contains("checkerboard, checkerboard3d, pointsource, slab, milne"),
            "{e}"
        );
        let e = wrong_kind_error("checkerboard", SceneKind::Render)
            .map(|e| e.to_string())
            .unwrap_or_default();
        assert!(e.contains("`pn solve checkerboard`"), "{e}");
        assert!(e.contains("cloud, nebula, sphere, lowalbedo"), "{e}");
        assert!(wrong_kind_error("cloud", SceneKind::Render).is_none());
        assert!(wrong_kind_error("no-such-scene", SceneKind::Solve).is_none());
    }
}
