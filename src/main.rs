//! The `pn` command-line tool.
use clap::{Parser, Subcommand};
use pnsolver::cli;

/// pnsolver: deterministic multiple scattering (P_N, diffusion, flux-limited diffusion).
#[derive(Parser, Debug)]
#[command(name = "pn", version, about)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand, Debug)]
enum Command {
    /// Print the derived real P_N equations as LaTeX.
    Latex(cli::derive_cmds::LatexArgs),
    /// Print the expanded P_N system (JSON with --json).
    Equations(cli::derive_cmds::EquationsArgs),
    /// Write the generated derivation document (LaTeX).
    Supplemental(cli::derive_cmds::SupplementalArgs),
    /// Print a discretized stencil.
    Stencil(cli::stencil::StencilArgs),
    /// Solve a scene and write fluence, moments, images and a report.
    Solve(cli::solve::SolveArgs),
    /// Self-convergence study: solve at several nested resolutions, tabulate and plot.
    Converge(cli::converge::ConvergeArgs),
    /// Run the fixed benchmark suite (cgnr vs parity-cg side by side); writes bench.csv/md.
    Bench(cli::bench::BenchArgs),
}

fn main() {
    let cli = Cli::parse();
    let result = match &cli.command {
        Command::Latex(a) => cli::derive_cmds::latex(a),
        Command::Equations(a) => cli::derive_cmds::equations(a),
        Command::Supplemental(a) => cli::derive_cmds::supplemental(a),
        Command::Stencil(a) => cli::stencil::run(a),
        Command::Solve(a) => cli::solve::run(a),
        Command::Converge(a) => cli::converge::run(a),
        Command::Bench(a) => cli::bench::run(a),
    };
    if let Err(err) = result {
        eprintln!("error: {err:#}");
        std::process::exit(1);
    }
}
