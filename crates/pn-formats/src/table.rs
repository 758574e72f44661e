//! One table type for every table the tools write: a header and rows of text cells, written
//! as CSV (and read back) or as a Markdown table.
//!
//! The race writes its measurements as CSV and generates `results.md` from those files alone;
//! the bench, the trade-off and the figure write their CSV and Markdown tables from the same
//! rows.
//!
//! # Example
//!
//! ```
//! use pn_formats::{num, Align, Table};
//!
//! let mut t = Table::new(&["method", "seconds"]);
//! t.push(&[("method", "p3".into()), ("seconds", num(Some(1.23456)))])?;
//! t.push_row(["cda", "0.5"])?;
//! assert_eq!(t.to_csv(), "method,seconds\np3,1.235\ncda,0.5\n");
//! assert_eq!(
//!     t.to_markdown(),
//!     "| method | seconds |\n|---|---|\n| p3 | 1.235 |\n| cda | 0.5 |\n"
//! );
//! assert_eq!(
//!     t.to_markdown_aligned(&[Align::Left, Align::Right]),
//!     "| method | seconds |\n|:--|--:|\n| p3 | 1.235 |\n| cda | 0.5 |\n"
//! );
//! assert_eq!(Table::from_csv(&t.to_csv())?, t);
//! # Ok::<(), anyhow::Error>(())
//! ```

use anyhow::{ensure, Context, Result};
use std::collections::BTreeMap;
use std::path::Path;

/// A table: a header and rows of cells, each row as long as the header. A cell holds no
/// newline; in CSV a cell with a comma or a double quote is quoted (RFC 4180), every other
/// cell is written as it is.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Table {
    /// Column names.
    pub header: Vec<String>,
    /// Rows, each as long as the header.
    pub rows: Vec<Vec<String>>,
}

/// The alignment of a Markdown column (its cell in the separator row).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Align {
    /// `---`: the renderer's default.
    #[default]
    Default,
    /// `:--`.
    Left,
    /// `:-:`.
    Center,
    /// `--:`.
    Right,
}

impl Align {
    fn separator(self) -> &'static str {
        match self {
            Align::Default => "---",
            Align::Left => ":--",
            Align::Center => ":-:",
            Align::Right => "--:",
        }
    }
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

/// A CSV cell: as it is, or quoted with its quotes doubled where it holds a comma or a quote.
fn csv_cell(c: &str) -> String {
    if c.contains([',', '"']) {
        format!("\"{}\"", c.replace('"', "\"\""))
    } else {
        c.to_string()
    }
}

/// The cells of one CSV line (quoted cells as [`csv_cell`] writes them).
fn csv_cells(line: &str) -> Result<Vec<String>> {
    let mut cells = vec![];
    let mut cell = String::new();
    let mut chars = line.chars().peekable();
    let mut quoted = false;
    while let Some(c) = chars.next() {
        match (quoted, c) {
            (false, ',') => cells.push(std::mem::take(&mut cell)),
            (false, '"') if cell.is_empty() => quoted = true,
            (true, '"') if chars.peek() == Some(&'"') => {
                chars.next();
                cell.push('"');
            }
            (true, '"') => {
                quoted = false;
                ensure!(
                    matches!(chars.peek(), None | Some(',')),
                    "a quoted cell ends before {:?}",
                    chars.peek()
                );
            }
            _ => cell.push(c),
        }
    }
    ensure!(!quoted, "a quoted cell is not closed");
    cells.push(cell);
    Ok(cells)
}

/// A Markdown row: the cells between `| ` and ` |`, separated by ` | `.
fn markdown_row(cells: &[String]) -> String {
    format!("| {} |\n", cells.join(" | "))
}

impl Table {
    /// An empty table with these columns.
    pub fn new(header: &[&str]) -> Self {
        Self {
            header: header.iter().map(|s| s.to_string()).collect(),
            rows: vec![],
        }
    }

    /// Appends a row given as (column, value) pairs; missing columns stay empty. A cell
    /// with a comma, a double quote or a newline is refused (the race's CSV files are read
    /// by other tools line by line and cell by comma).
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

    /// Appends a row given cell by cell, as many cells as columns, none with a newline.
    pub fn push_row<S: Into<String>>(&mut self, cells: impl IntoIterator<Item = S>) -> Result<()> {
        let row: Vec<String> = cells.into_iter().map(Into::into).collect();
        ensure!(
            row.len() == self.header.len(),
            "internal: a row of {} cells in a table of {} columns ({:?})",
            row.len(),
            self.header.len(),
            self.header
        );
        ensure!(
            row.iter().all(|c| !c.contains('\n')),
            "internal: a cell with a newline in {row:?}"
        );
        self.rows.push(row);
        Ok(())
    }

    /// The table as CSV: the header line, then one line per row, each ending in a newline.
    pub fn to_csv(&self) -> String {
        let mut s = String::new();
        for r in std::iter::once(&self.header).chain(&self.rows) {
            let cells: Vec<String> = r.iter().map(|c| csv_cell(c)).collect();
            s += &cells.join(",");
            s.push('\n');
        }
        s
    }

    /// Writes the table as CSV ([`Table::to_csv`]).
    pub fn write_csv(&self, path: &Path) -> Result<()> {
        std::fs::write(path, self.to_csv())
            .with_context(|| format!("cannot write {}", path.display()))
    }

    /// Parses CSV text as [`Table::to_csv`] writes it.
    pub fn from_csv(text: &str) -> Result<Self> {
        let mut lines = text.lines();
        let header = csv_cells(lines.next().context("no header line")?).context("line 1")?;
        let mut rows = vec![];
        for (i, l) in lines.enumerate() {
            let r = csv_cells(l).with_context(|| format!("line {}", i + 2))?;
            ensure!(
                r.len() == header.len(),
                "line {}: {} cells, the header has {}",
                i + 2,
                r.len(),
                header.len()
            );
            rows.push(r);
        }
        Ok(Self { header, rows })
    }

    /// Reads a CSV file written by [`Table::write_csv`].
    pub fn read_csv(path: &Path) -> Result<Self> {
        let text = std::fs::read_to_string(path)
            .with_context(|| format!("cannot read {}", path.display()))?;
        ensure!(!text.is_empty(), "{} is empty", path.display());
        Self::from_csv(&text).with_context(|| format!("in {}", path.display()))
    }

    /// The table as Markdown with every column's default alignment: `| a | b |`, `|---|---|`,
    /// then one `| … |` line per row. Cells are written as they are: a `|` in a cell splits
    /// it into two Markdown columns, and the separator row counts those columns.
    pub fn to_markdown(&self) -> String {
        self.to_markdown_aligned(&[])
    }

    /// [`Table::to_markdown`] with the alignment of each Markdown column (the default for
    /// the columns past the end of `align`).
    pub fn to_markdown_aligned(&self, align: &[Align]) -> String {
        let columns: usize = self.header.iter().map(|h| 1 + h.matches('|').count()).sum();
        let mut s = markdown_row(&self.header);
        s.push('|');
        for i in 0..columns {
            s += align.get(i).copied().unwrap_or_default().separator();
            s.push('|');
        }
        s.push('\n');
        for r in &self.rows {
            s += &markdown_row(r);
        }
        s
    }

    /// A new table of the chosen columns, as (new name, column) pairs, in that order; a
    /// column this table lacks gives empty cells.
    pub fn select(&self, columns: &[(&str, &str)]) -> Self {
        let index: Vec<Option<usize>> = columns
            .iter()
            .map(|(_, c)| self.header.iter().position(|h| h == c))
            .collect();
        Self {
            header: columns.iter().map(|(n, _)| n.to_string()).collect(),
            rows: self
                .rows
                .iter()
                .map(|r| {
                    index
                        .iter()
                        .map(|i| i.map(|i| r[i].clone()).unwrap_or_default())
                        .collect()
                })
                .collect(),
        }
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
        t.write_csv(&p).unwrap();
        assert_eq!(std::fs::read_to_string(&p).unwrap(), "a,b\nx,0.01235\n,\n");
        let back = Table::read_csv(&p).unwrap();
        assert_eq!(back, t);
        assert_eq!(back.records()[0]["b"], "0.01235");
        std::fs::remove_file(&p).ok();
        assert_eq!(num(Some(123.456)), "123.5");
        assert_eq!(num(Some(2.5e-5)), "2.500e-5");
        assert_eq!(num(Some(f64::NAN)), "");
    }

    #[test]
    fn quoted_cells_round_trip() {
        let mut t = Table::new(&["a", "b,c"]);
        t.push_row(["1, 2", "say \"hi\""]).unwrap();
        t.push_row(["", "\""]).unwrap();
        assert!(t.push_row(["only one"]).is_err());
        assert!(t.push_row(["a\nb", ""]).is_err());
        let csv = t.to_csv();
        assert_eq!(csv, "a,\"b,c\"\n\"1, 2\",\"say \"\"hi\"\"\"\n,\"\"\"\"\n");
        assert_eq!(Table::from_csv(&csv).unwrap(), t);
        assert!(Table::from_csv("a,b\n\"x,1\n").is_err());
        assert!(Table::from_csv("a,b\n\"x\"y,1\n").is_err());
        assert!(Table::from_csv("a,b\n1,2,3\n").is_err());
    }

    #[test]
    fn markdown_tables() {
        let mut t = Table::new(&["x", "y"]);
        t.push_row(["1", ""]).unwrap();
        assert_eq!(t.to_markdown(), "| x | y |\n|---|---|\n| 1 |  |\n");
        assert_eq!(
            t.select(&[("Y", "y"), ("z", "z"), ("X", "x")])
                .to_markdown(),
            "| Y | z | X |\n|---|---|---|\n|  |  | 1 |\n"
        );
        assert_eq!(
            t.to_markdown_aligned(&[Align::Center]),
            "| x | y |\n|:-:|---|\n| 1 |  |\n"
        );
        // A `|` inside a cell is a column break in Markdown: the separator counts it.
        let mut t = Table::new(&["n", "it | s"]);
        t.push_row(["3", "12|0.500"]).unwrap();
        assert_eq!(
            t.to_markdown(),
            "| n | it | s |\n|---|---|---|\n| 3 | 12|0.500 |\n"
        );
    }
}
