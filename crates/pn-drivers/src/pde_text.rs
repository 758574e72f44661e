//! PDE text files (docs/pde-text.md) for `pn solve --pde`, `pn stencil --pde` and the
//! bench: the `--pde-param` values and the description of the unknowns. Reading a file
//! ([`load`]) and its 3D stencil ([`PdeKernel`]) live in [`pn_render::pde_kernel`] (shared
//! with `pn render --pde`), re-exported here.

use anyhow::Context;
use pn_codegen::text::TextPde;

pub use pn_render::pde_kernel::{load, PdeKernel};

/// Parses a `--pde-param` value `NAME=VALUE`.
pub fn parse_param(s: &str) -> anyhow::Result<(String, String)> {
    let (name, value) = s
        .split_once('=')
        .with_context(|| format!("--pde-param {s:?}: expected NAME=VALUE, e.g. sigma_f=2"))?;
    let (name, value) = (name.trim(), value.trim());
    anyhow::ensure!(
        !name.is_empty() && !value.is_empty(),
        "--pde-param {s:?}: expected NAME=VALUE, e.g. sigma_f=2"
    );
    Ok((name.to_string(), value.to_string()))
}

/// A one-line description of the unknowns: names, labels and which are radiance moments.
pub fn describe_unknowns(pde: &TextPde) -> String {
    pde.unknowns
        .iter()
        .map(|u| {
            if u.radiance {
                format!("{} = L({}, {})", u.name, u.label.0, u.label.1)
            } else {
                format!(
                    "{} (auxiliary, stored as moment ({}, {}))",
                    u.name, u.label.0, u.label.1
                )
            }
        })
        .collect::<Vec<_>>()
        .join(", ")
}
