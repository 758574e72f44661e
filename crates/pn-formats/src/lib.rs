//! `pn-formats` — the files pnsolver reads and writes, in one place.
//!
//! The libraries below it (`pn-runtime`, `pn-render`) return values; the commands
//! (`pn-drivers`, `pn-lab`) and the Python package turn them into files through this crate.
//! Its modules are private; what a caller needs is re-exported here:
//!
//! * NumPy `.npy`: [`write_npy`], [`read_npy`] (an [`NpyArray`]), [`encode_npy`],
//!   [`decode_npy`].
//! * Mitsuba's `.vol`: [`read_vol`], [`decode_vol`], [`encode_vol`], [`encode_vol_scaled`]
//!   (one channel per factor).
//! * OpenVDB float grids: [`read_vdb`] returns a [`VdbGrid`] (its [`IndexBox`] and
//!   [`IndexToWorld`]).
//! * Images: [`write_exr_gray`], [`write_exr_rgb`], [`read_exr_gray`], [`read_exr_rgb`];
//!   tone-mapped PNG ([`write_png_tonemapped`], [`write_png_tonemapped_rgb`], [`exposure`],
//!   [`srgb8`], [`channel_mean`]); [`write_png`]: a [`Slice`] of a solution as a
//!   colour-mapped PNG.
//! * The files of a solve: [`write_outputs`] (the [`OUTPUT_FILES`], written atomically;
//!   [`cell_shape`]) and its report types ([`Report`], [`RunInfo`], [`SolveReport`],
//!   [`ErrorEstimate`], [`VacuumMeasurements`], [`FldSection`]).
//! * [`read_text`]: a text input (scene, PDE), bounded ([`MAX_TEXT_BYTES`], regular files
//!   only).
//! * [`files`]: plain writes of bytes and folders (the Mitsuba export's files).
//! * [`write_atomic`]: every JSON report, written atomically (a file appears only when
//!   complete).
//! * [`Table`]: one table type for every CSV and Markdown table ([`Align`], [`num`]).
//! * [`plot`] (a public module): plot frames, the fonts registered once, the convergence and
//!   profile plots.
#![warn(missing_docs)]

pub mod files;
mod image_io;
mod input;
mod json;
mod npy;
mod output;
pub mod plot;
mod png;
mod table;
mod vdb;
mod vol;

pub use image_io::{
    channel_mean, encode_exr_rgb, exposure, image_dimensions, read_exr_gray, read_exr_rgb, srgb8,
    write_exr_gray, write_exr_rgb, write_png_tonemapped, write_png_tonemapped_rgb,
};
pub use input::{read_text, MAX_TEXT_BYTES};
pub use json::write_atomic;
pub use npy::{decode_npy, encode_npy, read_npy, write_npy, NpyArray};
pub use output::report::{
    DistributedSection, ErrorEstimate, FldSection, RankSection, Report, RunInfo, SolveReport,
    VacuumMeasurements,
};
pub use output::{cell_shape, write_outputs, OUTPUT_FILES};
pub use png::{write_png, Slice};
pub use table::{num, Align, Table};
pub use vdb::{read_vdb, IndexBox, IndexToWorld, VdbGrid, VdbTile};
pub use vol::{decode_vol, encode_vol, encode_vol_scaled, read_vol};
