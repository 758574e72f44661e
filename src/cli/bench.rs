//! `pn bench`: its arguments.

use clap::Args;
use pn_lab::bench::BenchRequest;
use std::path::PathBuf;

use super::Env;

/// Arguments of `pn bench`.
#[derive(Args, Debug)]
pub struct BenchArgs {
    /// A subset that runs in about a minute (checkerboard P_1/P_3, point source at 40³).
    #[arg(long)]
    pub quick: bool,
    /// Output directory for bench.csv and bench.md.
    #[arg(long, default_value = "out/bench")]
    pub out: PathBuf,
    /// Folder with the reference data (`checkerboard/starmap_p{1,5}_n71.csv`).
    #[arg(long, default_value = "tests/data")]
    pub reference: PathBuf,
    /// Point-source resolution (default 80, the paper's; 40 with --quick).
    #[arg(long, allow_negative_numbers = true)]
    pub pointsource_res: Option<usize>,
    /// Skip the baseline CGNR runs on problems with more unknowns than this.
    #[arg(long, default_value_t = 3_000_000, allow_negative_numbers = true)]
    pub cgnr_max_unknowns: usize,
}

impl BenchArgs {
    /// The driver's request.
    pub fn request(&self, env: &Env) -> BenchRequest {
        BenchRequest {
            quick: self.quick,
            out: self.out.clone(),
            reference: self.reference.clone(),
            pointsource_res: self.pointsource_res,
            cgnr_max_unknowns: self.cgnr_max_unknowns,
            tuning: env.tuning.clone(),
        }
    }
}
