//! Tests of the scene format's sky lights (`kind = "envmap"`, `kind = "constant"`).

use super::*;
use crate::sky::SkyRadiance;
use crate::Light;
use std::path::{Path, PathBuf};

const BASE: &str = r#"
[medium]
kind = "sphere"
resolution = [8, 8, 8]
sigma_t_scale = 2.0
albedo = 0.5
[camera]
position = [0.0, 0.0, 4.0]
target = [0.0, 0.0, 0.0]
up = [0.0, 1.0, 0.0]
fov = 40.0
width = 8
height = 8
"#;

fn with_lights(lights: &str) -> String {
    format!("{BASE}\n{lights}")
}

fn parse_in(s: &str, dir: &Path) -> anyhow::Result<RenderScene> {
    RenderScene::from_toml_str(s, dir)
}

fn err_in(s: &str, dir: &Path) -> String {
    format!("{:#}", parse_in(s, dir).unwrap_err())
}

/// A folder of its own (`tag`: the test, which run in parallel) with EXR maps: good (8 × 4),
/// square, with a NaN, with a negative texel.
fn maps(tag: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("pn-render-sky-{tag}-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let write = |name: &str, w: usize, h: usize, bad: Option<f32>| {
        let mut v: Vec<f32> = (0..w * h).map(|i| 0.5 + (i % 7) as f32 * 0.1).collect();
        if let Some(b) = bad {
            v[w + 2] = b;
        }
        pn_formats::write_exr_rgb(&dir.join(name), w, h, [&v, &v, &v]).unwrap();
    };
    write("sky.exr", 8, 4, None);
    write("square.exr", 8, 8, None);
    write("nan.exr", 8, 4, Some(f32::NAN));
    write("negative.exr", 8, 4, Some(-1.0));
    std::fs::write(dir.join("garbage.exr"), b"not an image").unwrap();
    dir
}

#[test]
fn sky_lights_are_read_with_their_keys() {
    let dir = maps("sky_lights_are_read_with_their_keys");
    let s = parse_in(
        &with_lights(
            "[[light]]\nkind = \"constant\"\nradiance = [0.2, 0.4, 0.6]\ndirections = 16\n\
             [[light]]\nkind = \"directional\"\ndirection = [0.0, -1.0, 0.0]\nirradiance = 2.0",
        ),
        &dir,
    )
    .unwrap();
    assert_eq!(
        s.lights.len(),
        1,
        "the sky is not one of the scene's own lights"
    );
    let sky = s.sky.as_ref().unwrap();
    assert_eq!(sky.radiance, SkyRadiance::Constant([0.2, 0.4, 0.6]));
    assert_eq!(sky.directions, 16);
    assert!(s.colours.is_some(), "an RGB sky makes the scene coloured");
    // Cut into lights: 16 more directional lights, per channel.
    let cut = s.with_sky_lights();
    assert_eq!(cut.lights.len(), 17);
    assert!(matches!(cut.lights[1], Light::Directional { .. }));
    let col = cut.colours.as_ref().unwrap();
    let red: f64 = col.light_strength[1..].iter().map(|c| c[0]).sum();
    assert!(
        (red - 0.2 * 4.0 * std::f64::consts::PI).abs() < 1e-9,
        "{red}"
    );
    // An environment map with a scale and an up vector; hide_emitters in [render].
    let s = parse_in(
        &with_lights(
            "[[light]]\nkind = \"envmap\"\nfile = \"sky.exr\"\nscale = 2.0\nup = [0.0, 0.0, 1.0]\n\
             [render]\nhide_emitters = true",
        ),
        &dir,
    )
    .unwrap();
    let sky = s.sky.as_ref().unwrap();
    assert!(matches!(sky.radiance, SkyRadiance::Map(_)));
    assert_eq!(sky.scale, 2.0);
    assert!((sky.to_world[2][1] - 1.0).abs() < 1e-12, "+Y maps to +Z");
    assert!(s.render.hide_emitters);
    assert!(s.colours.is_none(), "a grey map keeps the scene grey");
}

#[test]
fn bad_skies_are_refused_with_the_file_or_key() {
    let dir = maps("bad_skies_are_refused_with_the_file_or_key");
    let env = |extra: &str| with_lights(&format!("[[light]]\nkind = \"envmap\"\n{extra}"));
    let cases: Vec<(String, &str)> = vec![
        (env("file = \"square.exr\""), "twice as wide"),
        (env("file = \"nan.exr\""), "row 1, column 2"),
        (env("file = \"negative.exr\""), "non-negative"),
        (env("file = \"missing.exr\""), "missing.exr"),
        (env("file = \"garbage.exr\""), "garbage.exr"),
        (env(""), "needs file"),
        (env("file = \"sky.exr\"\nradiance = 1.0"), "radiance applies"),
        (env("file = \"sky.exr\"\nscale = 0.0"), "scale must be"),
        (
            env("file = \"sky.exr\"\nto_world = [[1.0, 0.0, 0.0], [0.0, 2.0, 0.0], [0.0, 0.0, 1.0]]"),
            "rotation",
        ),
        (
            env("file = \"sky.exr\"\nup = [0.0, 0.0, 1.0]\nto_world = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]]"),
            "not both",
        ),
        (env("file = \"sky.exr\"\nup = [0.0, 0.0, 0.0]"), "up must be"),
        (env("file = \"sky.exr\"\ndirections = 0"), "directions"),
        (env("file = \"sky.exr\"\ndirection = [0.0, 1.0, 0.0]"), "direction applies"),
        (
            with_lights("[[light]]\nkind = \"constant\"\nradiance = 0.0"),
            "the sky is black",
        ),
        (
            with_lights("[[light]]\nkind = \"constant\"\nradiance = -1.0"),
            "non-negative",
        ),
        (
            with_lights("[[light]]\nkind = \"constant\"\nradiance = 1.0\nfile = \"sky.exr\""),
            "file applies",
        ),
        (
            with_lights(
                "[[light]]\nkind = \"constant\"\nradiance = 1.0\n[[light]]\nkind = \"constant\"\nradiance = 1.0",
            ),
            "at most one sky",
        ),
        (
            with_lights(
                "[[light]]\nkind = \"directional\"\ndirection = [0.0, -1.0, 0.0]\nirradiance = 1.0\nscale = 2.0",
            ),
            "scale applies to sky lights",
        ),
    ];
    for (text, want) in cases {
        let e = err_in(&text, &dir);
        assert!(e.contains(want), "expected {want:?} in: {e}");
    }
}

#[test]
fn set_sky_checks_the_sky_and_colours_a_grey_scene_for_an_rgb_one() {
    let dir = maps("set_sky_checks_the_sky_and_colours_a_grey_scene_for_an_rgb_one");
    let sun = "[[light]]\nkind = \"directional\"\ndirection = [0.0, -1.0, 0.0]\nirradiance = 2.0";
    let mut s = parse_in(&with_lights(sun), &dir).unwrap();
    assert!(s.colours.is_none());
    // A grey sky keeps the scene grey.
    s.set_sky(crate::sky::Sky::constant([0.5; 3])).unwrap();
    assert!(s.colours.is_none() && s.sky.is_some());
    // An RGB sky colours it: the medium and the sun the same in every channel.
    s.set_sky(crate::sky::Sky::constant([0.5, 0.25, 0.1]))
        .unwrap();
    let col = s.colours.as_ref().unwrap();
    assert_eq!(col.sigma_t_scale, [2.0; 3]);
    assert_eq!(col.albedo, None);
    assert_eq!(col.light_strength, vec![[2.0; 3]]);
    // A black sky, and a sky once cut into lights, are refused.
    let e = s.set_sky(crate::sky::Sky::constant([0.0; 3])).unwrap_err();
    assert!(format!("{e:#}").contains("the sky is black"), "{e:#}");
    let mut cut = s.with_sky_lights();
    let e = cut
        .set_sky(crate::sky::Sky::constant([1.0; 3]))
        .unwrap_err();
    assert!(format!("{e:#}").contains("already cut"), "{e:#}");
}
