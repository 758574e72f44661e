//! `pn solve`: solves a scene and writes the results.
use clap::Args;

/// Arguments of `pn solve`.
#[derive(Args, Debug)]
pub struct SolveArgs {}

/// Runs `pn solve`.
pub fn run(_args: &SolveArgs) -> anyhow::Result<()> {
    anyhow::bail!("pn solve: not implemented yet")
}
