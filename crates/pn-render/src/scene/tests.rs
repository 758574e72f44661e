//! Tests of the render scenes.

use super::*;
use crate::medium::{DensityFilter, DensityGrid};
use crate::{Light, SceneOverride};
use pn_runtime::problem::Phase;
use std::path::Path;

const MINIMAL: &str = r#"
[medium]
kind = "sphere"
resolution = [8, 8, 8]
sigma_t_scale = 2.0
albedo = 0.5
[[light]]
kind = "directional"
direction = [0.0, -2.0, 0.0]
irradiance = 1.0
[camera]
position = [0.0, 0.0, 4.0]
target = [0.0, 0.0, 0.0]
up = [0.0, 1.0, 0.0]
fov = 40.0
width = 8
height = 8
"#;

fn parse(s: &str) -> anyhow::Result<RenderScene> {
    RenderScene::from_toml_str(s, Path::new("."))
}

fn err(s: &str) -> String {
    format!("{:#}", parse(s).unwrap_err())
}

#[test]
fn builtin_scenes_parse() {
    for name in builtin_names() {
        let s = RenderScene::builtin(name).unwrap_or_else(|| panic!("{name}"));
        assert_eq!(s.name, name);
        let g = s.density_grid().unwrap();
        assert!(g.max_density() > 0.0, "{name}");
    }
    assert!(RenderScene::builtin("nope").is_none());
    assert!(RenderScene::builtin("checkerboard").is_none());
    let e = format!("{:#}", RenderScene::load("checkerboard").unwrap_err());
    assert!(
        e.contains("`pn solve checkerboard`") && e.contains("built-in"),
        "{e}"
    );
    let e = format!("{:#}", RenderScene::load("nope").unwrap_err());
    assert!(e.contains("built-in") && e.contains("lowalbedo"), "{e}");
}

#[test]
fn defaults_and_normalisation() {
    let s = parse(MINIMAL).unwrap();
    assert_eq!(s.phase, Phase::Isotropic);
    assert_eq!(
        s.lights[0],
        Light::Directional {
            direction: [0.0, -1.0, 0.0],
            irradiance: 1.0
        }
    );
    assert_eq!(s.solve.method, RenderMethod::Pn);
    assert_eq!(s.solve.sigma_t_min, None);
    assert_eq!(s.render.spp, 64);
}

#[test]
fn bad_input_is_refused_with_the_field() {
    let e = err(&MINIMAL.replace("albedo = 0.5", "albedo = 0.5\ncolour = 1"));
    assert!(e.contains("unknown field") && e.contains("line"), "{e}");
    let e = err(&MINIMAL.replace("albedo = 0.5", "albedo = 1.5"));
    assert!(e.contains("[0, 1]"), "{e}");
    let e = err(&MINIMAL.replace("sigma_t_scale = 2.0", "sigma_t_scale = -2.0"));
    assert!(e.contains("non-negative"), "{e}");
    let e = err(&MINIMAL.replace("sigma_t_scale = 2.0", "sigma_t_scale = nan"));
    assert!(e.contains("sigma_t_scale"), "{e}");
    let e = err(&MINIMAL.replace("width = 8", "width = 0"));
    assert!(e.contains("image size"), "{e}");
    let e = err(&MINIMAL.replace("up = [0.0, 1.0, 0.0]", "up = [0.0, 0.0, 1.0]"));
    assert!(e.contains("parallel"), "{e}");
    let e = err(&MINIMAL.replace("fov = 40.0", "fov = 180.0"));
    assert!(e.contains("fov"), "{e}");
    let e = err(&MINIMAL.replace("kind = \"sphere\"", "kind = \"torus\""));
    assert!(e.contains("torus"), "{e}");
    let e = err(&MINIMAL.replace("irradiance = 1.0", "irradiance = -1.0"));
    assert!(e.contains("irradiance"), "{e}");
    let e = err(&MINIMAL.replace("fov = 40.0", "fov = \"wide\""));
    assert!(e.contains("line 15, column 7"), "{e}");
    for bad in ["-1", "nan", "17", "inf"] {
        let e = format!(
            "{:#}",
            with_sets(&[&format!("render.sky_grid={bad}")]).unwrap_err()
        );
        assert!(
            e.contains("[render]") && e.contains("sky_grid"),
            "{bad}: {e}"
        );
    }
    let ok = with_sets(&["render.sky_grid=0"]).unwrap();
    assert_eq!(ok.render.sky_grid, 0.0);
    assert_eq!(parse(MINIMAL).unwrap().render.sky_grid, DEFAULT_SKY_GRID);
}

fn with_sets(sets: &[&str]) -> anyhow::Result<RenderScene> {
    let o: Vec<SceneOverride> = sets.iter().map(|s| s.parse().unwrap()).collect();
    RenderScene::from_toml_str_with_overrides(MINIMAL, Path::new("."), &o)
}

#[test]
fn set_overrides_apply_before_the_checks() {
    let s = with_sets(&[
        "solve.margin=8",
        "solve.sigma_t_min=0.5",
        "solve.absorber=box",
        "camera.position=[0,0,3]",
        "light.0.irradiance=2",
        "render.exact_transmittance=true",
        "phase.kind=hg",
        "phase.g=0.3",
    ])
    .unwrap();
    assert_eq!(s.solve.margin, 8);
    assert_eq!(s.solve.sigma_t_min, Some(0.5));
    assert_eq!(s.solve.absorber, AbsorberPlacement::Box);
    assert_eq!(s.camera.position, [0.0, 0.0, 3.0]);
    assert_eq!(
        s.lights[0],
        Light::Directional {
            direction: [0.0, -1.0, 0.0],
            irradiance: 2.0
        }
    );
    assert!(s.render.exact_transmittance);
    assert_eq!(s.phase, Phase::HenyeyGreenstein(0.3));
    // The file alone is unchanged by an empty list.
    assert_eq!(with_sets(&[]).unwrap(), parse(MINIMAL).unwrap());
    // A built-in keeps its name.
    let o: SceneOverride = "solve.margin=5".parse().unwrap();
    let b = RenderScene::load_with_overrides("sphere", &[o]).unwrap();
    assert_eq!((b.name.as_str(), b.solve.margin), ("sphere", 5));
}

#[test]
fn bad_set_overrides_name_the_key_and_the_flag() {
    let e = format!(
        "{:#}",
        with_sets(&["solve.margin=8", "solve.nonsense=1"]).unwrap_err()
    );
    assert!(
        e.contains("--set solve.nonsense=1") && e.contains("unknown field `nonsense`"),
        "{e}"
    );
    assert!(!e.contains("solve.margin=8"), "{e}");
    let e = format!("{:#}", with_sets(&["colour.x=1"]).unwrap_err());
    assert!(
        e.contains("--set colour.x=1") && e.contains("`colour`"),
        "{e}"
    );
    let e = format!("{:#}", with_sets(&["solve.margin=wide"]).unwrap_err());
    assert!(
        e.contains("--set solve.margin=wide") && e.contains("wide"),
        "{e}"
    );
    let e = format!("{:#}", with_sets(&["solve.margin=100"]).unwrap_err());
    assert!(
        e.contains("with --set solve.margin=100") && e.contains("at most 64"),
        "{e}"
    );
    let e = format!("{:#}", with_sets(&["light.3.irradiance=1"]).unwrap_err());
    assert!(e.contains("out of range"), "{e}");
    let o: SceneOverride = "solve.nonsense=1".parse().unwrap();
    let e = format!(
        "{:#}",
        RenderScene::load_with_overrides("sphere", &[o]).unwrap_err()
    );
    assert!(
        e.contains("built-in scene sphere") && e.contains("nonsense"),
        "{e}"
    );
}

#[test]
fn the_density_filter_is_read_and_applied() {
    let s = parse(MINIMAL).unwrap();
    assert_eq!(s.medium.filter, DensityFilter::Trilinear);
    assert_eq!(s.density_grid().unwrap().filter, DensityFilter::Trilinear);
    let s = parse(&MINIMAL.replace("albedo = 0.5", "albedo = 0.5\nfilter = \"nearest\"")).unwrap();
    assert_eq!(s.medium.filter, DensityFilter::Nearest);
    assert_eq!(s.density_grid().unwrap().filter, DensityFilter::Nearest);
    let e = err(&MINIMAL.replace("albedo = 0.5", "albedo = 0.5\nfilter = \"cubic\""));
    assert!(
        e.contains("medium.filter") && e.contains("\"cubic\"") && e.contains("trilinear"),
        "{e}"
    );
}

#[test]
fn render_settings_have_defaults_and_are_checked() {
    let s = parse(MINIMAL).unwrap();
    assert_eq!(s.render.renderer, RendererKind::Deterministic);
    assert_eq!((s.render.rays, s.render.step), (DEFAULT_RAYS, DEFAULT_STEP));
    let with = |r: &str| format!("{MINIMAL}[render]\n{r}\n");
    let s = parse(&with("renderer = \"montecarlo\"\nrays = 9\nstep = 0.25")).unwrap();
    assert_eq!(s.render.renderer, RendererKind::MonteCarlo);
    assert_eq!((s.render.rays, s.render.step), (9, 0.25));
    for (bad, want) in [
        ("rays = 3", "square number"),
        ("rays = 0", "square number"),
        ("rays = 1024", "square number"),
        ("step = 0.0", "step must lie"),
        ("step = 10.0", "step must lie"),
        ("step = nan", "step must lie"),
        ("cutoff = 1.0", "cutoff"),
        ("cutoff = -0.1", "cutoff"),
        ("renderer = \"magic\"", "unknown variant"),
    ] {
        let e = err(&with(bad));
        assert!(e.contains(want), "{bad}: {e}");
    }
}

#[test]
fn the_grid_boundary_is_read_and_marshak_needs_odd_pn() {
    assert_eq!(
        parse(MINIMAL).unwrap().solve.boundary,
        SolveBoundary::Dirichlet
    );
    let with = |r: &str| format!("{MINIMAL}[solve]\n{r}\n");
    let s = parse(&with(
        "boundary = \"marshak\"\nmargin = 0\nabsorbing_layer = 0",
    ))
    .unwrap();
    assert_eq!(s.solve.boundary, SolveBoundary::Marshak);
    for (bad, want) in [
        ("boundary = \"marshak\"\norder = 4", "odd order"),
        ("boundary = \"marshak\"\nmethod = \"cda\"", "odd order"),
        ("boundary = \"robin\"", "unknown variant"),
    ] {
        let e = err(&with(bad));
        assert!(e.contains(want), "{bad}: {e}");
    }
}

/// The default ramp keeps its size in space: 2 cells at 12³, 4 at 24³, 8 at 48³ (the
/// padding rounds it up); `absorbing_layer` fixes it in cells instead.
#[test]
fn the_absorber_ramp_is_fixed_in_space_unless_given_in_cells() {
    let with = |r: &str| format!("{MINIMAL}[solve]\n{r}\n");
    for (res, cells) in [(12, 2.0), (24, 4.0), (48, 8.0), (32, 32.0 / 6.0)] {
        let s = parse(&with(&format!("resolution = [{res}, {res}, {res}]"))).unwrap();
        assert!((s.solve.ramp_cells() - cells).abs() < 1e-12, "{res}");
        assert_eq!(s.solve.padding(), s.solve.margin + cells.ceil() as usize);
    }
    let s = parse(&with("resolution = [48, 24, 24]\nabsorber_width = 0.25")).unwrap();
    assert_eq!(s.solve.ramp_cells(), 12.0);
    let s = parse(&with("resolution = [48, 48, 48]\nabsorbing_layer = 3")).unwrap();
    assert_eq!((s.solve.ramp_cells(), s.solve.layer_cells()), (3.0, 3));
    for (bad, want) in [
        ("absorber_width = -0.1", "absorber_width must lie in [0, 1]"),
        ("absorber_width = nan", "absorber_width must lie in [0, 1]"),
        ("absorbing_layer = 65", "at most 64 cells"),
        (
            "resolution = [512, 512, 512]\nabsorber_width = 0.5",
            "at most 64 cells",
        ),
    ] {
        let e = err(&with(bad));
        assert!(e.contains(want), "{bad}: {e}");
    }
}

#[test]
fn a_solve_scene_file_points_to_pn_solve() {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../scenes/box.toml");
    let e = format!("{:#}", RenderScene::from_path(&path).unwrap_err());
    assert!(
        e.contains("this is a solve scene file: run it with `pn solve "),
        "{e}"
    );
    assert!(e.contains("unknown field"), "{e}");
}

#[test]
fn vol_files_are_read_and_bad_ones_refused() {
    let dir = std::env::temp_dir().join(format!("pn-render-scene-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let g = DensityGrid::new([2, 1, 1], [0.0; 3], [2.0, 1.0, 1.0], vec![0.25, 1.0]).unwrap();
    let bytes = pn_formats::encode_vol(&g.to_voxel_grid());
    std::fs::write(dir.join("d.vol"), &bytes).unwrap();
    std::fs::write(dir.join("bad.vol"), &bytes[..bytes.len() - 2]).unwrap();
    let text = MINIMAL
        .replace("kind = \"sphere\"", "kind = \"grid\"\nfile = \"d.vol\"")
        .replace("resolution = [8, 8, 8]\n", "");
    let s = RenderScene::from_toml_str(&text, &dir).unwrap();
    assert_eq!(s.density_grid().unwrap(), g);
    let e = format!(
        "{:#}",
        RenderScene::from_toml_str(&text.replace("d.vol", "bad.vol"), &dir).unwrap_err()
    );
    assert!(e.contains("bytes of data"), "{e}");
    // A per-voxel albedo from .npy (shape (nx, ny, nz), x first) on the same grid.
    pn_formats::write_npy(&dir.join("a.npy"), &[2, 1, 1], &[0.5, 0.25]).unwrap();
    let with_albedo = text.replace("albedo = 0.5", "albedo_file = \"a.npy\"");
    let s = RenderScene::from_toml_str(&with_albedo, &dir).unwrap();
    assert_eq!((s.medium.albedo_at(0), s.medium.albedo_at(1)), (0.5, 0.25));
    pn_formats::write_npy(&dir.join("b.npy"), &[2, 1, 1], &[0.5, 1.5]).unwrap();
    let e = format!(
        "{:#}",
        RenderScene::from_toml_str(&with_albedo.replace("a.npy", "b.npy"), &dir).unwrap_err()
    );
    assert!(
        e.contains("albedo must lie in [0, 1], voxel (1, 0, 0) is 1.5"),
        "{e}"
    );
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn vdb_files_are_read_with_their_placement_and_grid_names() {
    let data = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../tests/data/vdb");
    let text = MINIMAL
        .replace(
            "kind = \"sphere\"",
            "kind = \"grid\"\nfile = \"offset12.vdb\"",
        )
        .replace("resolution = [8, 8, 8]\n", "");
    let s = RenderScene::from_toml_str(&text, &data).unwrap();
    let g = s.density_grid().unwrap();
    // The box of tests/data/vdb/offset12.json (OpenVDB's indexToWorld of the outer corners).
    assert_eq!(g.res, [12, 12, 12]);
    assert_eq!(
        (s.medium.bbox_min, s.medium.bbox_max),
        ([-0.1875, -0.6875, 1.3125], [1.3125, 0.8125, 2.8125])
    );
    // The same voxels through a .vol file give the same medium.
    let dir = std::env::temp_dir().join(format!("pn-render-vdb-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let vg = pn_formats::read_vdb(&data.join("offset12.vdb"), None)
        .unwrap()
        .dense_active()
        .unwrap();
    std::fs::write(dir.join("same.vol"), pn_formats::encode_vol(&vg)).unwrap();
    let vol = RenderScene::from_toml_str(&text.replace("offset12.vdb", "same.vol"), &dir).unwrap();
    assert_eq!(vol.density_grid().unwrap(), g);
    std::fs::remove_dir_all(&dir).unwrap();

    // A named grid, and an albedo grid of the same file read over the density's voxels:
    // 0.9 on 8³ of the 12³ cells, inactive (0) elsewhere.
    let two = text.replace("offset12.vdb", "two_grids.vdb").replace(
        "albedo = 0.5",
        "albedo_file = \"two_grids.vdb\"\nalbedo_grid = \"albedo\"",
    );
    let e = format!("{:#}", RenderScene::from_toml_str(&two, &data).unwrap_err());
    assert!(e.contains("say which one with the `grid` key"), "{e}");
    let named = two.replace(
        "\nfile = \"two_grids.vdb\"\n",
        "\nfile = \"two_grids.vdb\"\ngrid = \"smoke\"\n",
    );
    let s = RenderScene::from_toml_str(&named, &data).unwrap();
    let albedo: Vec<f64> = (0..12 * 12 * 12).map(|i| s.medium.albedo_at(i)).collect();
    assert_eq!(albedo.iter().filter(|&&a| a == 0.9f32 as f64).count(), 512);
    assert_eq!(
        albedo.iter().filter(|&&a| a == 0.0).count(),
        12 * 12 * 12 - 512
    );

    for (scene, want) in [
        // An albedo grid whose voxels are not the density's.
        (
            text.replace("albedo = 0.5", "albedo_file = \"cloud16.vdb\""),
            "share one transform",
        ),
        (
            text.replace("albedo = 0.5", "albedo = 0.5\nalbedo_grid = \"a\""),
            "albedo_grid needs medium.albedo_file",
        ),
        (
            text.replace("file = \"offset12.vdb\"", "file = \"half16.vdb\""),
            "half precision",
        ),
        (
            text.replace(
                "file = \"offset12.vdb\"",
                "file = \"offset12.vdb\"\ngrid = \"heat\"",
            ),
            "no grid named \"heat\"",
        ),
        (
            text.replace("file = \"offset12.vdb\"", "file = \"offset12.json\""),
            "expected .vol, .npy or .vdb",
        ),
    ] {
        let e = format!(
            "{:#}",
            RenderScene::from_toml_str(&scene, &data).unwrap_err()
        );
        assert!(e.contains(want), "want {want:?}: {e}");
    }
    let e = err(&MINIMAL.replace("kind = \"sphere\"", "kind = \"sphere\"\ngrid = \"density\""));
    assert!(e.contains("apply to kind = \"grid\" only"), "{e}");
}

/// MINIMAL with a `[phase]` table of these lines.
fn with_phase(lines: &str) -> String {
    format!("{MINIMAL}[phase]\n{lines}\n")
}

#[test]
fn every_phase_kind_is_read() {
    let p = |lines: &str| parse(&with_phase(lines)).unwrap().phase;
    assert_eq!(p("kind = \"isotropic\""), Phase::Isotropic);
    assert_eq!(
        p("kind = \"hg\"\ng = -0.25"),
        Phase::HenyeyGreenstein(-0.25)
    );
    let two = p("kind = \"two_term_hg\"\ng1 = 0.8\ng2 = -0.4\nweight = 0.25");
    assert_eq!(
        two,
        Phase::TwoTermHg {
            g1: 0.8,
            g2: -0.4,
            weight: 0.25
        }
    );
    // weight is the second lobe's share (Mitsuba's blendphase).
    assert!((two.moment(1) - (0.75 * 0.8 + 0.25 * -0.4)).abs() < 1e-15);

    // A regular table over [-1, 1]: p ∝ 1 + μ (normalised: 2π ∫ (1 + μ) dμ = 4π), g = 1/3.
    let tab = p("kind = \"tabulated\"\nvalues = [0.0, 0.5, 1.0]");
    let Phase::Tabulated(t) = &tab else {
        panic!("{tab:?}")
    };
    assert_eq!(t.cos_theta(), &[-1.0, 0.0, 1.0]);
    assert!((t.normalisation() - 1.0 / (2.0 * std::f64::consts::PI)).abs() < 1e-15);
    assert!(
        (tab.moment(1) - 1.0 / 3.0).abs() < 1e-14,
        "{}",
        tab.moment(1)
    );
    assert!((tab.value(1.0) - 1.0 / (2.0 * std::f64::consts::PI)).abs() < 1e-15);
    // The same function on irregular nodes, forward = cos θ = 1.
    let irr = p("kind = \"tabulated\"\ncos_theta = [-1.0, 0.5, 1.0]\nvalues = [0.0, 1.5, 2.0]");
    let Phase::Tabulated(t) = &irr else {
        panic!("{irr:?}")
    };
    assert_eq!(t.cos_theta(), &[-1.0, 0.5, 1.0]);
    assert!(!t.is_regular());
    assert!(
        (irr.moment(1) - 1.0 / 3.0).abs() < 1e-14,
        "{}",
        irr.moment(1)
    );

    let drop = p("kind = \"droplet\"\ndiameter = 10.0");
    let Phase::Droplet(d) = &drop else {
        panic!("{drop:?}")
    };
    assert_eq!(d.diameter, 10.0);
    let g = (1.0 - d.w_draine) * d.g_hg
        + d.w_draine * pn_runtime::phase::draine_moment(d.g_draine, d.alpha, 1);
    assert!((drop.moment(1) - g).abs() < 1e-15);
    assert!((0.8..0.9).contains(&g), "{g}");
    // An integer diameter is a number too.
    assert_eq!(p("kind = \"droplet\"\ndiameter = 20").moment(1), {
        Phase::Droplet(pn_runtime::phase::DropletPhase::new(20.0).unwrap()).moment(1)
    });
}

#[test]
fn bad_phase_tables_are_refused_with_the_key() {
    let cases: &[(&str, &[&str])] = &[
        ("kind = \"hg\"\ng = 1.0", &["[phase]", "g", "< 1"]),
        ("kind = \"hg\"\ng = -1.5", &["g", "< 1"]),
        ("kind = \"hg\"", &["needs g"]),
        (
            "kind = \"two_term_hg\"\ng1 = 0.5\ng2 = 1.2\nweight = 0.5",
            &["g2"],
        ),
        (
            "kind = \"two_term_hg\"\ng1 = 0.5\ng2 = 0.2\nweight = 1.5",
            &["weight", "[0, 1]"],
        ),
        (
            "kind = \"two_term_hg\"\ng1 = 0.5\ng2 = 0.2\nweight = -0.1",
            &["weight"],
        ),
        ("kind = \"two_term_hg\"\ng1 = 0.5\ng2 = 0.2", &["needs weight"]),
        ("kind = \"tabulated\"\nvalues = [1.0, -0.5, 2.0]", &["values[1]", "non-negative"]),
        ("kind = \"tabulated\"\nvalues = [1.0, nan]", &["values[1]", "NaN"]),
        ("kind = \"tabulated\"\nvalues = [1.0]", &["two values"]),
        ("kind = \"tabulated\"\nvalues = []", &["two values"]),
        ("kind = \"tabulated\"", &["needs values"]),
        (
            "kind = \"tabulated\"\ncos_theta = [-1.0, 0.5, 0.2, 1.0]\nvalues = [1.0, 1.0, 1.0, 1.0]",
            &["cos_theta[2]", "sorted"],
        ),
        (
            "kind = \"tabulated\"\ncos_theta = [-0.5, 1.0]\nvalues = [1.0, 1.0]",
            &["cos_theta", "-1 to 1"],
        ),
        (
            "kind = \"tabulated\"\ncos_theta = [-1.0, 1.0]\nvalues = [1.0, 1.0, 1.0]",
            &["2 cosines for 3 values"],
        ),
        ("kind = \"tabulated\"\nvalues = [0.0, 0.0]", &["all values are zero"]),
        ("kind = \"droplet\"\ndiameter = 4.0", &["diameter", "[5, 50]"]),
        ("kind = \"droplet\"\ndiameter = 51.0", &["diameter", "[5, 50]"]),
        ("kind = \"droplet\"", &["needs diameter"]),
        ("kind = \"droplet\"\ndiameter = 10.0\ng = 0.5", &["g does not apply", "droplet", "diameter"]),
        ("kind = \"isotropic\"\ng = 0.5", &["g does not apply", "none"]),
        ("kind = \"hg\"\ng = 0.5\nweight = 0.5", &["weight does not apply"]),
        ("kind = \"tabulated\"\nvalues = [1.0, 1.0]\ndiameter = 10.0", &["diameter does not apply"]),
        ("kind = \"mie\"", &["unknown kind \"mie\"", "droplet"]),
        ("kind = \"hg\"\ng = 0.5\nlobes = 2", &["unknown field `lobes`"]),
        ("kind = \"hg\"\ng = \"0.5\"", &["invalid type"]),
    ];
    for (lines, wants) in cases {
        let e = err(&with_phase(lines));
        for w in *wants {
            assert!(e.contains(w), "{lines:?}: {e:?} lacks {w:?}");
        }
    }
}

#[test]
fn phase_tables_outside_scene_files_are_read_and_checked_the_same() {
    let t: toml::Table =
        toml::from_str("kind = \"two_term_hg\"\ng1 = 0.7\ng2 = -0.2\nweight = 0.1").unwrap();
    assert_eq!(
        phase_from_table(t).unwrap(),
        Phase::TwoTermHg {
            g1: 0.7,
            g2: -0.2,
            weight: 0.1
        }
    );
    let t: toml::Table = toml::from_str("kind = \"droplet\"\ng = 0.5").unwrap();
    let e = format!("{:#}", phase_from_table(t).unwrap_err());
    assert!(e.contains("g does not apply"), "{e}");
    let t: toml::Table = toml::from_str("kind = \"hg\"\ngee = 0.5").unwrap();
    let e = format!("{:#}", phase_from_table(t).unwrap_err());
    assert!(e.contains("unknown field `gee`"), "{e}");
    let t: toml::Table = toml::from_str("g = 0.5").unwrap();
    let e = format!("{:#}", phase_from_table(t).unwrap_err());
    assert!(e.contains("kind"), "{e}");
}

#[test]
fn sizes_are_refused_with_the_memory_they_would_take_before_anything_is_allocated() {
    // A procedural medium's resolution, as the scene is read (not first at the render).
    let e = err(&MINIMAL.replace("[8, 8, 8]", "[100000, 100000, 100000]"));
    assert!(
        e.contains(
            "[medium]: medium.resolution [100000, 100000, 100000] is 1000000000000000 \
                    voxels, about 3.55 PiB as float32"
        ) && e.contains("512³ = 134217728"),
        "{e}"
    );
    assert!(err(&MINIMAL.replace("[8, 8, 8]", "[0, 8, 8]")).contains("positive on every axis"));
    // Arrays (the Python binding's check before it copies numpy arrays).
    let e = format!(
        "{:#}",
        check_array_shape("density", [100000; 3], 1, 16 << 30).unwrap_err()
    );
    assert!(
        e.contains("density of shape [100000, 100000, 100000] is 1000000000000000 voxels")
            && e.contains("about 10.66 PiB, more than the memory limit of 16.00 GiB"),
        "{e}"
    );
    let e = format!(
        "{:#}",
        check_array_shape("density", [0, 4, 4], 1, 16 << 30).unwrap_err()
    );
    assert!(
        e.contains("density has a zero-length axis: shape [0, 4, 4]"),
        "{e}"
    );
    check_array_shape("density", [512; 3], 2, 16 << 30).unwrap();
    assert!(check_array_shape("density", [1024; 3], 2, 16 << 30).is_err());
}

#[test]
fn solve_tables_alone_are_read_and_checked_as_in_a_scene() {
    let s = solve_from_toml_str("order = 5\nresolution = [8, 8, 16]\n").unwrap();
    assert_eq!(
        (s.order, s.resolution, s.sweeps),
        (5, [8, 8, 16], DEFAULT_SWEEPS)
    );
    let e = format!("{:#}", solve_from_toml_str("order = 0\n").unwrap_err());
    assert!(e.contains("order must lie in 1..="), "{e}");
    // A wrong type keeps toml's error, with its span, for the caller to name the key.
    let e = solve_from_toml_str("margin = -1\n").unwrap_err();
    let te = e.downcast_ref::<toml::de::Error>().expect("a toml error");
    assert_eq!(te.span(), Some(9..11));
    assert!(te.message().contains("expected usize"), "{}", te.message());
    assert!(format!("{:#}", solve_from_toml_str("zoom = 2\n").unwrap_err()).contains("zoom"));
}

#[test]
fn the_sweep_quadrature_grows_with_the_order_unless_given() {
    let at = |extra: &str| parse(&format!("{MINIMAL}[solve]\n{extra}\n"));
    let nodes = |extra: &str| at(extra).unwrap().solve.sweep_nodes();
    // At least 8 nodes, and N + 1 beyond P_7 (2n − 1 ≥ 2N: SolveSettings::sweep_nodes).
    assert_eq!(nodes("order = 3"), 8);
    assert_eq!(nodes("order = 7"), 8);
    assert_eq!(nodes("order = 9"), 10);
    assert_eq!(nodes("order = 15"), 16);
    assert_eq!(nodes("order = 9\nsweep_quadrature = 6"), 6);
    // sweep_bands is checked against the nodes in use.
    assert!(at("order = 9\nsweep_bands = 19").is_ok());
    let e = format!("{:#}", at("order = 5\nsweep_bands = 16").unwrap_err());
    assert!(
        e.contains("sweep_bands = 16 needs sweep_quadrature ≥ 9"),
        "{e}"
    );
    let e = format!("{:#}", at("sweep_quadrature = 0").unwrap_err());
    assert!(e.contains("sweep_quadrature must lie in 1..=64"), "{e}");
    // sweep_order raises the sweeps' bands (and their nodes) only where there are sweeps.
    let s = at("order = 3
sweep_order = 9")
    .unwrap()
    .solve;
    assert_eq!(
        (s.sweep_band(3), s.sweep_band(0), s.sweep_nodes()),
        (9, 9, 10)
    );
    let s = at("order = 3
sweep_order = 9
sweeps = 0")
    .unwrap()
    .solve;
    assert_eq!(s.sweep_band(3), 3);
    assert_eq!(
        at("order = 5
sweep_order = 1")
        .unwrap()
        .solve
        .sweep_band(5),
        5
    );
    let e = format!("{:#}", at("sweep_order = 16").unwrap_err());
    assert!(e.contains("sweep_order must be at most 15"), "{e}");
}
