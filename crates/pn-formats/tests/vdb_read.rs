//! OpenVDB input (issue 22) against files written by an independent tool: Debian's OpenVDB
//! 10.0.1 Python bindings (tests/data/vdb/make_fixtures.py). For each valid fixture, OpenVDB's
//! own dense reading of the active bounding box (`<name>.npy`) and its `indexToWorld` of the
//! box's outer corners (`<name>.json`) are the references.
//!
//! Tolerances: the voxel values must be equal exactly (both are the same float32 numbers,
//! widened to f64 here); the world corners to 1e-12 (OpenVDB computes them in double
//! precision, as we do; the JSON holds them to full precision).
#![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)] // test code

use pn_formats::read_npy;
use pn_formats::{read_vdb, IndexBox};
use std::path::{Path, PathBuf};

fn fixture(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../tests/data/vdb")
        .join(name)
}

fn json(name: &str) -> serde_json::Value {
    let text = std::fs::read_to_string(fixture(name)).unwrap();
    serde_json::from_str(&text).unwrap()
}

fn vec3(v: &serde_json::Value) -> [f64; 3] {
    [0, 1, 2].map(|d| v[d].as_f64().unwrap())
}

/// The grid read by pn equals OpenVDB's dense reading voxel for voxel, over the same index
/// box and with the same world placement.
fn check_against_openvdb(name: &str) {
    let g = read_vdb(&fixture(&format!("{name}.vdb")), None).unwrap();
    let meta = json(&format!("{name}.json"));
    let min = vec3(&meta["bbox_min_index"]).map(|c| c as i64);
    let max = vec3(&meta["bbox_max_index"]).map(|c| c as i64);
    assert_eq!(
        g.active_box,
        Some(IndexBox { min, max }),
        "{name}: active box"
    );
    let dense = g.dense_active().unwrap();
    let reference = read_npy(&fixture(&format!("{name}.npy"))).unwrap();
    assert_eq!(dense.dims.to_vec(), reference.shape, "{name}: shape");
    let differing = dense
        .data
        .iter()
        .zip(&reference.data)
        .filter(|(a, b)| a != b)
        .count();
    assert_eq!(differing, 0, "{name}: voxels that differ from OpenVDB's");
    let lo = vec3(&meta["bbox_min_world_corner"]);
    let hi = vec3(&meta["bbox_max_world_corner"]);
    for d in 0..3 {
        assert!(
            (dense.min[d] - lo[d]).abs() < 1e-12,
            "{name}: min {:?}",
            dense.min
        );
        assert!(
            (dense.max[d] - hi[d]).abs() < 1e-12,
            "{name}: max {:?}",
            dense.max
        );
    }
}

#[test]
fn a_cloud_at_the_origin_equals_openvdbs_reading() {
    check_against_openvdb("cloud16");
}

#[test]
fn an_offset_scaled_translated_grid_keeps_its_placement() {
    check_against_openvdb("offset12");
    let g = read_vdb(&fixture("offset12.vdb"), Some("density")).unwrap();
    assert_eq!(g.transform.scale, [0.125; 3]);
    assert_eq!(g.transform.translation, [0.5, -1.0, 0.25]);
}

#[test]
fn active_tiles_fill_their_blocks() {
    // 6145 active voxels: 11 tiles of 8³, one leaf split off a tile, one isolated voxel.
    let g = read_vdb(&fixture("tiles.vdb"), None).unwrap();
    assert_eq!(g.active_voxel_count(), 6145);
    assert_eq!(g.tiles.len(), 11);
    check_against_openvdb("tiles");
}

#[test]
fn a_file_with_several_grids_needs_the_name_and_reads_each() {
    let path = fixture("two_grids.vdb");
    let e = format!("{:#}", read_vdb(&path, None).unwrap_err());
    assert!(e.contains("\"albedo\"") && e.contains("\"smoke\""), "{e}");
    assert!(e.contains("grid"), "{e}");
    let smoke = read_vdb(&path, Some("smoke")).unwrap();
    let albedo = read_vdb(&path, Some("albedo")).unwrap();
    assert_eq!(smoke.active_voxel_count(), 912);
    assert_eq!(albedo.active_voxel_count(), 512);
    // The albedo read over the smoke's box: 0.9 on (2..=9)³, inactive (0) elsewhere.
    let a = albedo.dense(smoke.active_box.unwrap()).unwrap();
    assert_eq!(a.dims, [12, 12, 12]);
    for i in 0..12 {
        for j in 0..12 {
            for k in 0..12 {
                let inside = [i, j, k].iter().all(|c| (2..=9).contains(c));
                let want = if inside { 0.9f32 as f64 } else { 0.0 };
                assert_eq!(a.at(i, j, k), want, "albedo at {:?}", [i, j, k]);
            }
        }
    }
}

/// Unsupported or broken files: an error that names the file and the problem.
fn error_of(name: &str, grid: Option<&str>) -> String {
    let e = read_vdb(&fixture(name), grid).expect_err(name);
    let text = format!("{e:#}");
    assert!(text.contains(name), "the error names the file: {text}");
    text
}

#[test]
fn unsupported_and_broken_files_are_refused_with_a_reason() {
    let half = error_of("half16.vdb", None);
    assert!(half.contains("half precision"), "{half}");
    let vec3 = error_of("vec3.vdb", None);
    assert!(
        vec3.contains("value type") && vec3.contains("vec3s"),
        "{vec3}"
    );
    let truncated = error_of("truncated.vdb", None);
    assert!(truncated.contains("truncated"), "{truncated}");
    let missing = error_of("cloud16.vdb", Some("temperature"));
    assert!(
        missing.contains("no grid named \"temperature\"") && missing.contains("density"),
        "{missing}"
    );
    let e = format!("{:#}", read_vdb(&fixture("absent.vdb"), None).unwrap_err());
    assert!(e.contains("absent.vdb") && e.contains("cannot open"), "{e}");
}

/// Every prefix of a valid file (cut at 97 places), and the file with bytes flipped, give an
/// error or a grid, never a panic; the prefixes are all refused.
#[test]
fn damaged_files_never_panic() {
    let bytes = std::fs::read(fixture("cloud16.vdb")).unwrap();
    let dir = std::env::temp_dir().join(format!("pn-vdb-damaged-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("cut.vdb");
    for cut in (0..97).map(|i| i * bytes.len() / 97) {
        std::fs::write(&path, &bytes[..cut]).unwrap();
        assert!(
            read_vdb(&path, None).is_err(),
            "prefix of {cut} bytes accepted"
        );
    }
    for at in (0..61).map(|i| i * bytes.len() / 61) {
        let mut b = bytes.clone();
        b[at] ^= 0x5a;
        std::fs::write(&path, &b).unwrap();
        // Some flips land in values and give a valid grid; what matters is no panic.
        let _ = read_vdb(&path, None);
    }
    std::fs::remove_dir_all(&dir).unwrap();
}

/// A damaged file (a fuzzer finding) whose active tiles, expanded voxel by voxel, took 5 GB
/// and 12 s: tiles stay blocks, and the dense block is checked against its limit first.
#[test]
fn a_damaged_files_tiles_stay_blocks() {
    let path = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../fuzz/regressions/vdb/tile-expands-to-gigabytes");
    let g = read_vdb(&path, None).unwrap();
    assert!(
        g.voxels.len() + g.tiles.len() < 100_000,
        "{}",
        g.voxels.len()
    );
    eprintln!(
        "{} voxels, {} tiles, {} active, box {:?}",
        g.voxels.len(),
        g.tiles.len(),
        g.active_voxel_count(),
        g.active_box
    );
    match g.dense_active() {
        Ok(d) => assert!(d.data.len() <= 1 << 27),
        Err(e) => assert!(
            format!("{e:#}").contains("too large to read densely"),
            "{e:#}"
        ),
    }
}
