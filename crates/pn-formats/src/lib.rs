//! `pn-formats` — the file formats of pnsolver in one place.
//!
//! * [`table`]: one table type for every table the tools write (CSV, read back, Markdown).
#![warn(missing_docs)]

pub mod table;
