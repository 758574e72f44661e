//! Fuzzing with proptest: the `.vol` and `.npy` readers and the TOML scene parser
//! return errors on malformed input and never panic (a panic fails the property).
//!
//! Arbitrary bytes rarely get past a magic number, so each reader is also fed inputs with a
//! valid prefix and random rest (headers with random dimensions, shapes and lengths), and
//! the scene parser gets files assembled from the real keys with random (valid and invalid)
//! values besides arbitrary text.
#![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)] // test code

use pn_formats::{decode_npy, encode_npy};
use pn_formats::{decode_vol, encode_vol};
use pn_render::load_scene;
use pn_runtime::field::VoxelGrid;
use proptest::prelude::*;
use std::path::PathBuf;

fn vol_header(enc: i32, dims: [i32; 3], ch: i32, bbox: [f32; 6]) -> Vec<u8> {
    let mut b = b"VOL\x03".to_vec();
    for v in [enc, dims[0], dims[1], dims[2], ch] {
        b.extend_from_slice(&v.to_le_bytes());
    }
    for v in bbox {
        b.extend_from_slice(&v.to_le_bytes());
    }
    b
}

fn npy_file(major: u8, header: &str, payload: &[u8]) -> Vec<u8> {
    let mut b = b"\x93NUMPY".to_vec();
    b.push(major);
    b.push(0);
    if major == 1 {
        b.extend_from_slice(&(header.len() as u16).to_le_bytes());
    } else {
        b.extend_from_slice(&(header.len() as u32).to_le_bytes());
    }
    b.extend_from_slice(header.as_bytes());
    b.extend_from_slice(payload);
    b
}

/// A dimension that is small, zero, negative or huge.
fn dim() -> impl Strategy<Value = i32> {
    prop_oneof![1..5i32, Just(0), -3..0i32, Just(i32::MAX), 1000..100_000i32]
}

/// A shape entry as text: numbers (small, huge, overflowing), negatives and garbage.
fn shape_entry() -> impl Strategy<Value = String> {
    prop_oneof![
        (0..5usize).prop_map(|n| n.to_string()),
        Just("18446744073709551615".to_string()),
        Just("4294967296".to_string()),
        Just("-1".to_string()),
        "[a-z ]{0,3}",
    ]
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 256, ..ProptestConfig::default() })]

    #[test]
    fn vol_arbitrary_bytes(bytes in proptest::collection::vec(any::<u8>(), 0..120)) {
        let _ = decode_vol(&bytes);
    }

    #[test]
    fn vol_random_header(
        enc in prop_oneof![Just(1), any::<i32>()],
        dims in [dim(), dim(), dim()],
        ch in prop_oneof![Just(1), any::<i32>()],
        bbox in proptest::array::uniform6(any::<f32>()),
        payload in proptest::collection::vec(any::<u8>(), 0..300),
    ) {
        let mut b = vol_header(enc, dims, ch, bbox);
        b.extend_from_slice(&payload);
        if let Ok(g) = decode_vol(&b) {
            // Accepted only when the header and the payload agree.
            prop_assert_eq!(g.data.len() * 4, payload.len());
        }
    }

    #[test]
    fn vol_round_trip(
        dims in [1..4usize, 1..4usize, 1..4usize],
        seed in proptest::collection::vec(-1e3f32..1e3, 64),
    ) {
        let n = dims.iter().product::<usize>();
        let data: Vec<f64> = seed[..n].iter().map(|&v| v as f64).collect();
        let g = VoxelGrid::new(dims, [0.0; 3], [1.0, 2.0, 3.0], data).unwrap();
        let back = decode_vol(&encode_vol(&g)).unwrap();
        prop_assert_eq!(back, g);
    }

    #[test]
    fn npy_arbitrary_bytes(bytes in proptest::collection::vec(any::<u8>(), 0..120)) {
        let _ = decode_npy(&bytes);
    }

    #[test]
    fn npy_random_header(
        major in prop_oneof![Just(1u8), Just(2u8), any::<u8>()],
        descr in prop_oneof![Just("<f8"), Just("<f4"), Just("<i8"), Just(""), Just("'")],
        fortran in prop_oneof![Just("False"), Just("True"), Just("")],
        shape in proptest::collection::vec(shape_entry(), 0..4),
        junk in "[ (),:'{}a-z0-9]{0,12}",
        payload in proptest::collection::vec(any::<u8>(), 0..200),
    ) {
        let header = format!(
            "{{'descr': '{descr}', 'fortran_order': {fortran}, 'shape': ({},){junk}}}",
            shape.join(", ")
        );
        let _ = decode_npy(&npy_file(major, &header, &payload));
        // A truncated or overlong length field.
        let mut b = npy_file(major, &header, &payload);
        if b.len() > 9 {
            b[8] = b[8].wrapping_add(7);
        }
        let _ = decode_npy(&b);
    }

    #[test]
    fn npy_round_trip(shape in proptest::collection::vec(1..4usize, 1..4), v in -1e6f64..1e6) {
        let n = shape.iter().product::<usize>();
        let data: Vec<f64> = (0..n).map(|i| v + i as f64).collect();
        let a = decode_npy(&encode_npy(&shape, &data).unwrap()).unwrap();
        prop_assert_eq!(a.shape, shape);
        prop_assert_eq!(a.data, data);
    }
}

/// A scratch directory for the scene files of one property (in the system's temp dir).
fn scratch(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("pn-proptest-{name}-{}", std::process::id()));
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// Writes `text` (and a few voxel files it may refer to) and parses it; must not panic.
fn parse(name: &str, text: &[u8]) {
    let d = scratch(name);
    std::fs::write(
        d.join("good.npy"),
        encode_npy(&[2, 2, 2], &[1.0; 8]).unwrap(),
    )
    .unwrap();
    std::fs::write(d.join("bad.npy"), b"\x93NUMPY\x01\x00\xff\xff{").unwrap();
    std::fs::write(
        d.join("neg.npy"),
        encode_npy(&[2, 1], &[-1.0, f64::NAN]).unwrap(),
    )
    .unwrap();
    let g = VoxelGrid::new([1, 2, 1], [0.0; 3], [1.0; 3], vec![0.5, 2.0]).unwrap();
    std::fs::write(d.join("good.vol"), encode_vol(&g)).unwrap();
    let p = d.join(format!("{name}.toml"));
    std::fs::write(&p, text).unwrap();
    let _ = load_scene(&p);
}

/// One `key = value` line of a scene file, from the real keys and risky values.
fn scene_line() -> impl Strategy<Value = String> {
    let key = prop_oneof![
        Just("name"),
        Just("dim"),
        Just("resolution"),
        Just("domain_min"),
        Just("domain_max"),
        Just("order"),
        Just("boundary"),
        Just("sigma_t_min"),
        Just("sigma_t"),
        Just("sigma_s"),
        Just("albedo"),
        Just("g"),
        Just("bogus"),
    ];
    let value = prop_oneof![
        Just("0".to_string()),
        Just("1".to_string()),
        Just("2".to_string()),
        Just("3".to_string()),
        Just("-1".to_string()),
        Just("1e308".to_string()),
        Just("nan".to_string()),
        Just("inf".to_string()),
        Just("-0.5".to_string()),
        Just("0.99".to_string()),
        Just("9223372036854775807".to_string()),
        Just("\"neumann\"".to_string()),
        Just("\"dirichlet\"".to_string()),
        Just("\"x\"".to_string()),
        Just("[2, 2, 2]".to_string()),
        Just("[2, 2]".to_string()),
        Just("[0, 3, 1]".to_string()),
        Just("[]".to_string()),
        Just("[1.0, 1.0, 1.0]".to_string()),
        Just("[0.0, 0.0, 0.0]".to_string()),
        Just("[nan, 0.0, 1.0]".to_string()),
        Just("{ file = \"good.npy\" }".to_string()),
        Just("{ file = \"good.vol\", scale = 2.0 }".to_string()),
        Just("{ file = \"bad.npy\" }".to_string()),
        Just("{ file = \"neg.npy\" }".to_string()),
        Just("{ file = \"missing.vol\" }".to_string()),
        Just("{ file = \"good.npy\", scale = -1.0 }".to_string()),
        Just("{ file = \"good.txt\" }".to_string()),
    ];
    (key, value).prop_map(|(k, v)| format!("{k} = {v}"))
}

/// A `[[source]]` table with random entries.
fn source_table() -> impl Strategy<Value = String> {
    let line = prop_oneof![
        Just("l = 0"),
        Just("l = 1"),
        Just("l = 4294967295"),
        Just("m = 0"),
        Just("m = -1"),
        Just("m = 2147483647"),
        Just("value = 1.0"),
        Just("value = nan"),
        Just("value = -2.0"),
        Just("file = \"good.npy\""),
        Just("file = \"neg.npy\""),
        Just("scale = 3.0"),
        Just("box_min = [0.2, 0.2, 0.2]"),
        Just("box_max = [0.8, 0.8, 0.8]"),
        Just("box_max = [0.1, 0.1]"),
    ];
    proptest::collection::vec(line, 0..6).prop_map(|v| format!("[[source]]\n{}\n", v.join("\n")))
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 256, ..ProptestConfig::default() })]

    #[test]
    fn scene_arbitrary_text(text in "\\PC{0,200}") {
        parse("arbitrary", text.as_bytes());
    }

    #[test]
    fn scene_arbitrary_bytes(bytes in proptest::collection::vec(any::<u8>(), 0..200)) {
        parse("bytes", &bytes);
    }

    #[test]
    fn scene_from_real_keys(
        lines in proptest::collection::vec(scene_line(), 0..10),
        sources in proptest::collection::vec(source_table(), 0..3),
    ) {
        let text = format!("{}\n{}", lines.join("\n"), sources.join("\n"));
        parse("keys", text.as_bytes());
    }
}
