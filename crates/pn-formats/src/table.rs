//! CSV tables of `pn race`: written by the race, read back by the Markdown writer (so that
//! `results.md` is generated from the CSV files alone).

use anyhow::{ensure, Context, Result};
use std::collections::BTreeMap;
use std::path::Path;

/// A table: a header and rows of cells (no cell contains a comma, a quote or a newline).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Table {
    /// Column names.
    pub header: Vec<String>,
    /// Rows, each as long as the header.
    pub rows: Vec<Vec<String>>,
}

/// A cell: a number with 4 significant digits, empty for None or non-finite values.
pub fn num(v: Option<f64>) -> String {
    match v {
        Some(x) if x.is_finite() => {
            if x == 0.0 {
                "0".into()
            } else if x.abs() >= 1e-3 && x.abs() < 1e5 {
                let digits = (3 - x.abs().log10().floor() as i32).max(0) as usize;
                format!("{x:.digits$}")
            } else {
                format!("{x:.3e}")
            }
        }
        _ => String::new(),
    }
}

impl Table {
    /// An empty table with these columns.
    pub fn new(header: &[&str]) -> Self {
        Self {
            header: header.iter().map(|s| s.to_string()).collect(),
            rows: vec![],
        }
    }

    /// Appends a row given as (column, value) pairs; missing columns stay empty.
    pub fn push(&mut self, cells: &[(&str, String)]) -> Result<()> {
        let mut row = vec![String::new(); self.header.len()];
        for (k, v) in cells {
            let i = self
                .header
                .iter()
                .position(|h| h == k)
                .with_context(|| format!("internal: no column {k}"))?;
            ensure!(
                !v.contains([',', '"', '\n']),
                "internal: cell {v:?} would break the CSV"
            );
            row[i] = v.clone();
        }
        self.rows.push(row);
        Ok(())
    }

    /// Writes the table as CSV.
    pub fn write(&self, path: &Path) -> Result<()> {
        let mut s = self.header.join(",") + "\n";
        for r in &self.rows {
            s += &r.join(",");
            s.push('\n');
        }
        std::fs::write(path, s).with_context(|| format!("cannot write {}", path.display()))
    }

    /// Reads a CSV written by [`Table::write`].
    pub fn read(path: &Path) -> Result<Self> {
        let text = std::fs::read_to_string(path)
            .with_context(|| format!("cannot read {}", path.display()))?;
        let mut lines = text.lines();
        let header: Vec<String> = lines
            .next()
            .with_context(|| format!("{} is empty", path.display()))?
            .split(',')
            .map(str::to_string)
            .collect();
        let mut rows = vec![];
        for (i, l) in lines.enumerate() {
            let r: Vec<String> = l.split(',').map(str::to_string).collect();
            ensure!(
                r.len() == header.len(),
                "{} line {}: {} cells, the header has {}",
                path.display(),
                i + 2,
                r.len(),
                header.len()
            );
            rows.push(r);
        }
        Ok(Self { header, rows })
    }

    /// The rows as maps column → cell.
    pub fn records(&self) -> Vec<BTreeMap<String, String>> {
        self.rows
            .iter()
            .map(|r| self.header.iter().cloned().zip(r.iter().cloned()).collect())
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn round_trip_and_number_format() {
        let mut t = Table::new(&["a", "b"]);
        t.push(&[("b", num(Some(0.012345))), ("a", "x".into())])
            .unwrap();
        t.push(&[("a", num(None))]).unwrap();
        assert!(t.push(&[("c", "1".into())]).is_err());
        assert!(t.push(&[("a", "1,2".into())]).is_err());
        let p = std::env::temp_dir().join(format!("pn-race-table-{}.csv", std::process::id()));
        t.write(&p).unwrap();
        let back = Table::read(&p).unwrap();
        assert_eq!(back, t);
        assert_eq!(back.records()[0]["b"], "0.01235");
        std::fs::remove_file(&p).ok();
        assert_eq!(num(Some(123.456)), "123.5");
        assert_eq!(num(Some(2.5e-5)), "2.500e-5");
        assert_eq!(num(Some(f64::NAN)), "");
    }
}
