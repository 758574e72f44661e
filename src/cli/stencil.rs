//! `pn stencil`: prints a generated stencil.
use clap::Args;

/// Arguments of `pn stencil`.
#[derive(Args, Debug)]
pub struct StencilArgs {}

/// Runs `pn stencil`.
pub fn run(_args: &StencilArgs) -> anyhow::Result<()> {
    anyhow::bail!("pn stencil: not implemented yet")
}
