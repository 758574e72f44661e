//! `pn latex`, `pn equations`, `pn supplemental`: the derived P_N equations.
use clap::Args;

/// Arguments of `pn latex`.
#[derive(Args, Debug)]
pub struct LatexArgs {}

/// Arguments of `pn equations`.
#[derive(Args, Debug)]
pub struct EquationsArgs {}

/// Arguments of `pn supplemental`.
#[derive(Args, Debug)]
pub struct SupplementalArgs {}

/// Runs `pn latex`.
pub fn latex(_args: &LatexArgs) -> anyhow::Result<()> {
    anyhow::bail!("pn latex: not implemented yet")
}
/// Runs `pn equations`.
pub fn equations(_args: &EquationsArgs) -> anyhow::Result<()> {
    anyhow::bail!("pn equations: not implemented yet")
}
/// Runs `pn supplemental`.
pub fn supplemental(_args: &SupplementalArgs) -> anyhow::Result<()> {
    anyhow::bail!("pn supplemental: not implemented yet")
}
