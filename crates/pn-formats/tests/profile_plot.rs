//! `profile.csv` / `profile.png` writers of the point-source scene.
#![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)] // test code

use pn_formats::plot::{write_profile_csv, write_profile_png, PROFILE_CSV_HEADER};
use pn_runtime::reference::{cda_point_source, grosjean, pn_point_source, ProfileRow};
use std::path::PathBuf;

/// A fresh scratch directory under the system temp dir for one test.
fn scratch_dir(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("pn-reference-{name}-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// A profile like the paper's setup: P_5, α = 0.9, samples every h = 0.2 mean free paths, with
/// a "solved" column perturbed by a few percent and one non-positive sample (a log plot must
/// skip it, not fail).
fn sample_rows() -> Vec<ProfileRow> {
    let m = pn_point_source(5, 0.9, 0.0).unwrap();
    (1..=40)
        .map(|i| {
            let tau = 0.2 * i as f64 - 0.1;
            let exact = m.fluence(tau);
            ProfileRow {
                tau,
                solved: if i == 38 {
                    -1e-3
                } else {
                    exact * (1.0 + 0.03 * (i as f64).sin())
                },
                pn_exact: exact,
                cda: cda_point_source(tau, 0.9, 0.0),
                grosjean: grosjean(tau, 0.9),
            }
        })
        .collect()
}

#[test]
fn csv_has_the_exact_header_and_round_trips() {
    let rows = sample_rows();
    let path = scratch_dir("csv").join("profile.csv");
    write_profile_csv(&path, &rows).unwrap();
    let text = std::fs::read_to_string(&path).unwrap();
    let mut lines = text.lines();
    assert_eq!(lines.next(), Some("tau,solved,pn_exact,cda,grosjean"));
    assert_eq!(PROFILE_CSV_HEADER, "tau,solved,pn_exact,cda,grosjean");
    let parsed: Vec<Vec<f64>> = lines
        .map(|l| l.split(',').map(|v| v.parse().unwrap()).collect())
        .collect();
    assert_eq!(parsed.len(), rows.len());
    for (p, r) in parsed.iter().zip(&rows) {
        // Shortest round-trip formatting: bit-exact.
        assert_eq!(p, &vec![r.tau, r.solved, r.pn_exact, r.cda, r.grosjean]);
    }
}

/// The PNG decodes, has the documented size, and shows every series: the black P_N line,
/// red CDA, green Grosjean and the blue markers of the solved values (pure colours the
/// anti-aliased grid and text do not produce in quantity).
#[test]
fn png_is_a_readable_plot_with_all_series() {
    let rows = sample_rows();
    let path = scratch_dir("png").join("profile.png");
    write_profile_png(&path, &rows).unwrap();
    let img = image::open(&path).unwrap().to_rgb8();
    assert_eq!(img.dimensions(), (1000, 700));
    let count = |want: [u8; 3]| img.pixels().filter(|p| p.0 == want).count();
    for (name, rgb) in [
        ("P_N exact (black)", [0, 0, 0]),
        ("CDA (red)", [255, 0, 0]),
        ("Grosjean (green)", [0, 140, 60]),
        ("solved markers (blue)", [30, 90, 220]),
    ] {
        let n = count(rgb);
        assert!(n > 200, "{name}: only {n} pixels");
    }
    // Mostly white background.
    assert!(count([255, 255, 255]) > 1000 * 700 / 2);
}

/// The row constructor evaluates the reference solutions of the modes' medium.
#[test]
fn row_constructor_uses_the_modes_medium() {
    let m = pn_point_source(3, 0.8, 0.4).unwrap();
    let row = ProfileRow::point_source(1.5, 0.3, &m);
    assert_eq!(row.tau, 1.5);
    assert_eq!(row.solved, 0.3);
    assert_eq!(row.pn_exact, m.fluence(1.5));
    assert_eq!(row.cda, cda_point_source(1.5, 0.8, 0.4));
    assert_eq!(row.grosjean, grosjean(1.5, 0.8));
}

#[test]
fn png_without_plottable_values_is_an_error() {
    let path = scratch_dir("empty").join("profile.png");
    assert!(write_profile_png(&path, &[]).is_err());
    let bad = ProfileRow {
        tau: 1.0,
        solved: -1.0,
        pn_exact: 0.0,
        cda: f64::NAN,
        grosjean: -2.0,
    };
    let err = write_profile_png(&path, &[bad]).unwrap_err().to_string();
    assert!(err.contains("no finite positive values"), "{err}");
}
