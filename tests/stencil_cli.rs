//! `pn stencil`: the discretized stencil as text and JSON, and its bad-input errors.
#![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)] // test code

use std::process::Command;

fn pn(args: &[&str]) -> std::process::Output {
    Command::new(env!("CARGO_BIN_EXE_pn"))
        .args(args)
        .output()
        .expect("run pn")
}

#[test]
fn pn_stencil_json_and_text() {
    let out = pn(&["stencil", "--order", "1", "--json"]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let moments = v["moments"].as_array().unwrap();
    let placed: Vec<(i64, i64, Vec<i64>)> = moments
        .iter()
        .map(|m| {
            let o = m["offset"].as_array().unwrap();
            (
                m["l"].as_i64().unwrap(),
                m["m"].as_i64().unwrap(),
                o.iter().map(|x| x.as_i64().unwrap()).collect(),
            )
        })
        .collect();
    assert_eq!(
        placed,
        vec![
            (0, 0, vec![0, 0, 0]),
            (1, -1, vec![0, 1, 0]),
            (1, 0, vec![0, 0, 1]),
            (1, 1, vec![1, 0, 0]),
        ]
    );
    let rows = v["rows"].as_array().unwrap();
    assert_eq!(rows.len(), 4);
    // Row L_0^0: 6 transport terms and the collision term.
    assert_eq!(rows[0]["terms"].as_array().unwrap().len(), 7);

    let out = pn(&["stencil", "--cda", "--dim", "2"]);
    assert!(out.status.success());
    let text = String::from_utf8(out.stdout).unwrap();
    assert!(text.contains("cda_2d") && text.contains("L_0^0"), "{text}");

    let out = pn(&[
        "stencil",
        "--order",
        "2",
        "--dim",
        "2",
        "--collocated",
        "--json",
    ]);
    assert!(out.status.success());
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(v["moments"].as_array().unwrap().len(), 6);
}

#[test]
fn pn_stencil_rejects_bad_input() {
    for args in [
        &["stencil", "--order", "0"][..],
        &["stencil", "--order", "1000"],
        &["stencil", "--dim", "4"],
        &["stencil", "--cda", "--collocated"],
    ] {
        let out = pn(args);
        assert!(!out.status.success(), "{args:?} should fail");
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(!err.contains("panicked"), "{args:?}: {err}");
    }
}
