//! `pn stencil`: its arguments.

use clap::Args;
use pn_drivers::scene_setup::Dim;
use pn_drivers::stencil::StencilRequest;

/// Arguments of `pn stencil`.
#[derive(Args, Debug)]
pub struct StencilArgs {
    /// P_N order.
    #[arg(long, default_value_t = 1, allow_negative_numbers = true)]
    pub order: usize,
    /// Spatial dimension (2 or 3).
    #[arg(long, default_value_t = 3, allow_negative_numbers = true, value_parser = clap::value_parser!(u8).range(2..=3))]
    pub dim: u8,
    /// Every moment at the cell centre (unknowns interpolated) instead of staggered.
    #[arg(long)]
    pub collocated: bool,
    /// The classical-diffusion (CDA) stencil instead of P_N.
    #[arg(long, conflicts_with_all = ["collocated", "diffusion"])]
    pub cda: bool,
    /// The diffusion stencil with D as a field (FLD Picard steps) instead of P_N.
    #[arg(long, conflicts_with = "collocated")]
    pub diffusion: bool,
    /// Print JSON: `{"moments":[{"l","m","offset":[x,y,z]}], "rows":[…]}`.
    #[arg(long)]
    pub json: bool,
    /// Also print the Marshak vacuum conditions of every axis (odd N, staggered), derived
    /// from the half-range Gram matrix (JSON: a "marshak" entry).
    #[arg(long, conflicts_with_all = ["collocated", "cda", "diffusion"])]
    pub marshak: bool,
    /// The stencil of the linear PDE system in this text file (docs/pde-text.md).
    #[arg(long, value_name = "FILE", conflicts_with_all = ["collocated", "cda", "diffusion", "marshak"])]
    pub pde: Option<std::path::PathBuf>,
    /// Override a `param` of the --pde file (repeatable), e.g. --pde-param N=5.
    #[arg(long, value_name = "NAME=VALUE", value_parser = pn_drivers::pde_text::parse_param, requires = "pde")]
    pub pde_param: Vec<(String, String)>,
}

impl StencilArgs {
    /// The driver's request.
    pub fn request(&self) -> StencilRequest {
        StencilRequest {
            order: self.order,
            dim: if self.dim == 2 { Dim::Two } else { Dim::Three },
            collocated: self.collocated,
            cda: self.cda,
            diffusion: self.diffusion,
            json: self.json,
            marshak: self.marshak,
            pde: self.pde.clone(),
            pde_params: self.pde_param.clone(),
        }
    }
}
