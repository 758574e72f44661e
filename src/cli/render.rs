//! `pn render`: its arguments.

use clap::Args;
use pn_drivers::render::{RenderOptions, RenderRequest};
use pn_runtime::memory_estimate;
use pn_runtime::render::scene::RenderMethod;
use std::path::PathBuf;

use super::Env;

/// Arguments of `pn render`.
#[derive(Args, Debug, Clone)]
pub struct RenderArgs {
    /// A scene file (.toml) or a built-in scene: cloud, nebula, sphere, lowalbedo.
    pub scene: String,
    /// Multiple scattering: pn, cda, fld, or none (single scattering only).
    #[arg(long)]
    pub method: Option<RenderMethod>,
    /// P_N order (--method pn).
    #[arg(long, allow_negative_numbers = true)]
    pub order: Option<usize>,
    /// Samples per pixel.
    #[arg(long, allow_negative_numbers = true)]
    pub spp: Option<usize>,
    /// Solve-grid cells across the medium box: one number for all axes or NX,NY,NZ.
    #[arg(long, value_delimiter = ',', allow_negative_numbers = true)]
    pub solve_res: Option<Vec<usize>>,
    /// Output directory (default out/render-<scene>).
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Worker threads (default: all cores).
    #[arg(long, allow_negative_numbers = true)]
    pub threads: Option<usize>,
    /// Print the unknowns with and without cropping and at the density resolution.
    #[arg(long)]
    pub stats: bool,
    /// Refuse solves whose estimated memory exceeds this (bytes, or with K/M/G/T).
    #[arg(long, value_parser = memory_estimate::parse_size)]
    pub max_memory: Option<u64>,
}

impl RenderArgs {
    /// The driver's request.
    pub fn request(&self, env: &Env) -> RenderRequest {
        RenderRequest {
            scene: self.scene.clone(),
            method: self.method,
            order: self.order,
            spp: self.spp,
            solve_res: self.solve_res.clone(),
            out: self.out.clone(),
            stats: self.stats,
            options: RenderOptions {
                threads: self.threads,
                max_memory: self.max_memory,
                progress: true,
                tuning: env.tuning.clone(),
            },
        }
    }
}
