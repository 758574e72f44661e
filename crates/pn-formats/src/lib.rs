//! `pn-formats` — the files pnsolver reads and writes, in one place.
//!
//! The libraries below it (`pn-runtime`, `pn-render`) return values; the commands
//! (`pn-drivers`, `pn-lab`) and the Python package turn them into files through this crate.
//!
//! * Arrays and volumes: [`npy`] (NumPy `.npy`), [`vol`] (Mitsuba's `.vol`, reader and
//!   writer), [`vdb`] (OpenVDB float grids, reader).
//! * Images: [`image_io`] (EXR written and read back, tone-mapped PNG), [`png`] (a slice of a
//!   solution as a colour-mapped PNG).
//! * Results: [`output`] (the files of a solve: `fluence.npy`, `moments.npy`, `fluence.png`,
//!   `report.json`, written atomically), [`json`] (every JSON report written atomically: a
//!   file appears only when complete), [`table`] (one table type for every CSV and Markdown
//!   table), [`plot`] (plot frames, the fonts registered once, the convergence and profile
//!   plots).
#![warn(missing_docs)]

pub mod files;
pub mod image_io;
pub mod json;
pub mod npy;
pub mod output;
pub mod plot;
pub mod png;
pub mod table;
pub mod vdb;
pub mod vol;
