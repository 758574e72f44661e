//! StaRMAP reference solutions as CSV: the checkerboard fluences in `tests/data/checkerboard`
//! (see the README there for how they were produced).
//!
//! The format: one line per x index, the values along y separated by commas (no header;
//! blank lines are skipped, spaces around a value are allowed). Every line has the same
//! number of values. [`read_csv`] returns them x slowest, the order of the first axis of
//! `fluence.npy`.

use anyhow::{bail, ensure, Context, Result};
use std::path::Path;

/// Reads the StaRMAP CSV at `path` as x-slowest values (rows = x index, columns = y index).
///
/// Fails with the file, line and column on a value that is not a finite number or a line
/// whose number of values differs from the first line's, and on a file without values.
pub fn read_csv(path: &Path) -> Result<Vec<f64>> {
    let text = std::fs::read_to_string(path)
        .with_context(|| format!("cannot read StaRMAP reference {}", path.display()))?;
    parse_csv(&text).with_context(|| format!("StaRMAP reference {}", path.display()))
}

/// [`read_csv`] on text already read; errors name the line and column (both from 1).
pub fn parse_csv(text: &str) -> Result<Vec<f64>> {
    let mut values = Vec::new();
    let mut width: Option<(usize, usize)> = None; // (values per line, first line number)
    for (i, line) in text.lines().enumerate() {
        let line_no = i + 1;
        if line.trim().is_empty() {
            continue;
        }
        let mut n = 0;
        for (j, cell) in line.split(',').enumerate() {
            let cell = cell.trim();
            let v: f64 = match cell.parse() {
                Ok(v) => v,
                Err(_) => bail!("line {line_no}, column {}: {cell:?} is not a number", j + 1),
            };
            ensure!(
                v.is_finite(),
                "line {line_no}, column {}: {cell:?} is not finite",
                j + 1
            );
            values.push(v);
            n += 1;
        }
        match width {
            None => width = Some((n, line_no)),
            Some((w, first)) => ensure!(
                n == w,
                "line {line_no} has {n} values, line {first} has {w}: every line must have the \
                 same number of values"
            ),
        }
    }
    ensure!(!values.is_empty(), "no values (empty file)");
    Ok(values)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn err(text: &str) -> String {
        format!("{:#}", parse_csv(text).unwrap_err())
    }

    #[test]
    fn reads_rows_x_slowest_and_skips_blank_lines() {
        let v = parse_csv("1.0, 2.0,3e-1\n\n4,5.5e+00 ,6\n").unwrap();
        assert_eq!(v, [1.0, 2.0, 0.3, 4.0, 5.5, 6.0]);
    }

    #[test]
    fn malformed_files_name_line_and_column() {
        assert_eq!(
            err("1,2,3\n4,x5,6\n"),
            "line 2, column 2: \"x5\" is not a number"
        );
        assert_eq!(err("1,2,\n"), "line 1, column 3: \"\" is not a number");
        assert_eq!(err("1,nan\n"), "line 1, column 2: \"nan\" is not finite");
        assert!(err("1,2\n\n3\n").starts_with("line 3 has 1 values, line 1 has 2"));
        assert_eq!(err("\n \n"), "no values (empty file)");
    }

    #[test]
    fn the_file_is_named() {
        let e = format!(
            "{:#}",
            read_csv(Path::new("/no/such/starmap.csv")).unwrap_err()
        );
        assert!(e.contains("/no/such/starmap.csv"), "{e}");
    }

    #[test]
    fn the_checkerboard_references_are_71_by_71() {
        let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../tests/data/checkerboard");
        for f in ["starmap_p1_n71.csv", "starmap_p5_n71.csv"] {
            let v = read_csv(&dir.join(f)).unwrap();
            assert_eq!(v.len(), 71 * 71, "{f}");
        }
    }
}
