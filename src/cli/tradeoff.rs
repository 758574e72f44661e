//! `pn tradeoff`: its arguments.

use clap::Args;
use pn_lab::tradeoff::TradeoffRequest;
use std::path::PathBuf;

use super::Env;

/// Arguments of `pn tradeoff`.
#[derive(Args, Debug)]
pub struct TradeoffArgs {
    /// A small subset for a smoke test (resolutions 12 and 16; about a minute).
    #[arg(long)]
    pub quick: bool,
    /// Output directory for tradeoff.csv and tradeoff.png.
    #[arg(long, default_value = "out/tradeoff")]
    pub out: PathBuf,
    /// Resolutions (cells per axis), comma separated (default 20,30,40,60; 12,16 with --quick).
    #[arg(long, value_delimiter = ',', allow_negative_numbers = true)]
    pub res: Option<Vec<usize>>,
    /// Relative-residual tolerances, comma separated (default 1e-4,1e-6).
    #[arg(long, value_delimiter = ',', allow_hyphen_values = true)]
    pub tol: Option<Vec<f64>>,
}

impl TradeoffArgs {
    /// The driver's request.
    pub fn request(&self, env: &Env) -> TradeoffRequest {
        TradeoffRequest {
            quick: self.quick,
            out: self.out.clone(),
            res: self.res.clone(),
            tol: self.tol.clone(),
            tuning: env.tuning.clone(),
        }
    }
}
