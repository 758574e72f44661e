//! The `pn` command-line tool.
use clap::{Parser, Subcommand};
use pn_drivers as cli;

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
    /// Error vs time on the point source for method × resolution × tolerance;
    /// writes tradeoff.csv/png.
    Tradeoff(cli::tradeoff::TradeoffArgs),
    /// Render a scene (TOML or built-in) with single + multiple scattering; image.exr/png, report.json.
    Render(Box<cli::render::RenderArgs>),
    /// The comparison figure: one scene with CDA, FLD, P_1, P_3, P_5 (and Mitsuba); figure.png, table.csv/md.
    Figure(Box<cli::figure::FigureArgs>),
    /// Write a scene for Mitsuba 3 (density.vol + render_mitsuba.py); --run renders it.
    ExportMitsuba(cli::export_mitsuba::ExportMitsubaArgs),
    /// Compare two EXR images: RMSE, relative MSE, mean relative error; difference image.
    Compare(cli::compare::CompareArgs),
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
        Command::Tradeoff(a) => cli::tradeoff::run(a),
        Command::Render(a) => cli::render::run(a),
        Command::Figure(a) => cli::figure::run(a),
        Command::ExportMitsuba(a) => cli::export_mitsuba::run(a),
        Command::Compare(a) => cli::compare::run(a),
    };
    if let Err(err) = result {
        eprintln!("error: {err:#}");
        std::process::exit(1);
    }
}
