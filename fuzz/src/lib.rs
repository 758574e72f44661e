//! The fuzz targets of pnsolver's input parsers (issue 53, docs/fuzzing.md), one function
//! each, called by the libFuzzer binaries in `fuzz_targets/` and by nothing else. Each
//! takes the raw bytes the fuzzer made; an error is the expected outcome of most inputs, a
//! panic, an abort, a timeout or running out of memory is a defect.
//!
//! The file readers (`.vdb`, images, solve scenes) read from a path; their targets write
//! the input to a file of this process in the temporary folder first.

use std::path::PathBuf;

/// Inputs longer than this are skipped (the fuzzer is run with `-max_len` below it; a
/// seed from the corpus may be longer).
const MAX_INPUT: usize = 1 << 20;

fn text(data: &[u8]) -> Option<&str> {
    if data.len() > MAX_INPUT {
        return None;
    }
    std::str::from_utf8(data).ok()
}

/// A file of this process in the temporary folder holding `data`.
fn temp_file(name: &str, data: &[u8]) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("pn-fuzz-{}", std::process::id()));
    let _ = std::fs::create_dir_all(&dir);
    let path = dir.join(name);
    let _ = std::fs::write(&path, data);
    path
}

/// A text PDE (docs/pde-text.md): lexer, parser, lowering, then the placement and the
/// discretization in 2D and 3D and the boundary conditions. A first line `#params A=1,B=2`
/// gives `--pde-param` overrides.
pub fn text_pde(data: &[u8]) {
    let Some(src) = text(data) else { return };
    let params: Vec<(String, String)> = src
        .lines()
        .next()
        .and_then(|l| l.strip_prefix("#params "))
        .map(|l| {
            l.split(',')
                .filter_map(|kv| kv.split_once('='))
                .map(|(k, v)| (k.trim().to_string(), v.trim().to_string()))
                .collect()
        })
        .unwrap_or_default();
    if !small_includes(src) {
        return;
    }
    let Ok(pde) = pn_codegen::text::parse_pde(src, &params) else {
        return;
    };
    for dim in [pn_stencil::Dim::Two, pn_stencil::Dim::Three] {
        let _ = pde.ir(dim);
        let _ = pde.boundary(dim, "marshak");
    }
}

/// Whether every `include` in `src` is `include pn(D)` with one digit D: deriving P_N is
/// legitimate work that grows fast with N (`include pn(60)` takes minutes), which the
/// fuzzer would report as a timeout; the parser's own checks of N are covered by `D`
/// outside 1..=9 and by the unit tests.
fn small_includes(src: &str) -> bool {
    src.match_indices("include").all(|(i, w)| {
        let rest = src[i + w.len()..].trim_start();
        let b = rest.as_bytes();
        rest.starts_with("pn(") && b.len() >= 5 && b[3].is_ascii_digit() && b[4] == b')'
    })
}

/// A render scene's TOML (docs/scene-format.md), read relative to an empty folder.
pub fn render_scene(data: &[u8]) {
    let Some(src) = text(data) else { return };
    let _ = pn_render::RenderScene::from_toml_str(src, &empty_dir());
}

/// A solve scene's TOML (`pn solve FILE.toml`).
pub fn solve_scene(data: &[u8]) {
    if text(data).is_none() {
        return;
    }
    let path = temp_file("scene.toml", data);
    let _ = pn_render::load_scene(&path);
}

/// `--set KEY=VALUE` overrides, one a line, applied to a small cloud scene.
pub fn set_override(data: &[u8]) {
    let Some(src) = text(data) else { return };
    let overrides: Vec<pn_render::SceneOverride> =
        src.lines().filter_map(|l| l.parse().ok()).collect();
    let _ =
        pn_render::RenderScene::from_toml_str_with_overrides(BASE_SCENE, &empty_dir(), &overrides);
}

/// The render scene the overrides apply to.
const BASE_SCENE: &str = r#"
[medium]
kind = "cloud"
seed = 5
resolution = [8, 8, 8]
sigma_t_scale = 10.0
albedo = 0.9
[phase]
kind = "hg"
g = 0.3
[[light]]
kind = "directional"
direction = [0.5, -1.0, -0.3]
irradiance = 1.0
[camera]
position = [0.0, 0.0, 4.0]
target = [0.0, 0.0, 0.0]
up = [0.0, 1.0, 0.0]
fov = 40.0
width = 8
height = 8
[solve]
method = "pn"
order = 1
resolution = [8, 8, 8]
"#;

/// A Mitsuba `.vol` grid held in memory.
pub fn vol(data: &[u8]) {
    let _ = pn_formats::decode_vol(data);
}

/// A NumPy `.npy` array held in memory.
pub fn npy(data: &[u8]) {
    let _ = pn_formats::decode_npy(data);
}

/// An OpenVDB file: its default grid read and expanded to a dense block.
pub fn vdb(data: &[u8]) {
    let path = temp_file("grid.vdb", data);
    if let Ok(g) = pn_formats::read_vdb(&path, None) {
        let _ = g.dense_active();
    }
}

/// An image file read as `pn compare` and the environment maps read one (EXR, PNG).
pub fn exr(data: &[u8]) {
    let path = temp_file("image.exr", data);
    let _ = pn_formats::read_exr_rgb(&path);
}

/// `pn race --pn-points` specifications (a comma-separated list).
pub fn race_point(data: &[u8]) {
    let Some(src) = text(data) else { return };
    let _ = pn_lab::race::parse_points(src);
}

fn empty_dir() -> PathBuf {
    let dir = std::env::temp_dir().join(format!("pn-fuzz-{}-empty", std::process::id()));
    let _ = std::fs::create_dir_all(&dir);
    dir
}

/// Runs target `name` on `data`; `false` for an unknown name (the corpus replay test).
pub fn run(name: &str, data: &[u8]) -> bool {
    let f: fn(&[u8]) = match name {
        "text_pde" => text_pde,
        "render_scene" => render_scene,
        "solve_scene" => solve_scene,
        "set_override" => set_override,
        "vol" => vol,
        "npy" => npy,
        "vdb" => vdb,
        "exr" => exr,
        "race_point" => race_point,
        _ => return false,
    };
    f(data);
    true
}

/// The targets, in the order the script runs them.
pub const TARGETS: [&str; 9] = [
    "text_pde",
    "render_scene",
    "solve_scene",
    "set_override",
    "vol",
    "npy",
    "vdb",
    "exr",
    "race_point",
];
