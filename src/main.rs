//! The `pn` command-line tool: per subcommand its arguments (`cli`) and one call into
//! `pn_drivers`.
//!
//! Output goes through one `std::io::Write` handle on stdout. When the reader of a pipe
//! goes away (`pn equations --order 6 --json | head -c 20`), the write fails with
//! `BrokenPipe` and `pn` ends quietly with status 141 (128 + SIGPIPE), the status a shell
//! reports for a Unix tool killed by SIGPIPE, so that `set -o pipefail` scripts see the
//! same as with `cat` or `grep`.

mod cli;

use clap::{Parser, Subcommand};
use std::io::Write;

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
    Latex(cli::derive::LatexArgs),
    /// Print the expanded P_N system (JSON with --json).
    Equations(cli::derive::EquationsArgs),
    /// Write the generated derivation document (LaTeX).
    Supplemental(cli::derive::SupplementalArgs),
    /// Print a discretized stencil.
    Stencil(cli::stencil::StencilArgs),
    /// Solve a scene and write fluence, moments, images and a report.
    Solve(cli::solve::SolveArgs),
    /// Self-convergence study: solve at several nested resolutions, tabulate and plot.
    Converge(cli::solve::ConvergeArgs),
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
    /// pn against Mitsuba 3 at equal error in wall time: points.csv, error_time.png, results.md.
    Race(Box<cli::race::RaceArgs>),
}

impl Command {
    /// The folders named on the command line that the command will write into (`--out`, the
    /// race's `--cache`), checked before any work starts.
    fn output_folders(&self) -> Vec<&std::path::Path> {
        fn explicit(o: &Option<std::path::PathBuf>) -> Vec<&std::path::Path> {
            o.as_deref().into_iter().collect()
        }
        match self {
            Command::Latex(_) | Command::Equations(_) | Command::Stencil(_) => Vec::new(),
            Command::Supplemental(a) => vec![a.out.as_path()],
            Command::Solve(a) => explicit(&a.flags.out),
            Command::Converge(a) => explicit(&a.flags.out),
            Command::Bench(a) => vec![a.out.as_path()],
            Command::Tradeoff(a) => vec![a.out.as_path()],
            Command::Render(a) => explicit(&a.out),
            Command::Figure(a) => explicit(&a.out),
            Command::ExportMitsuba(a) => vec![a.out.as_path()],
            Command::Compare(a) => explicit(&a.out),
            Command::Race(a) => {
                let mut v = vec![a.out.as_path()];
                v.extend(a.cache.as_deref());
                v
            }
        }
    }
}

/// Runs `command`, printing to `out`.
fn run(command: &Command, env: &cli::Env, out: &mut dyn Write) -> anyhow::Result<()> {
    use pn_drivers as d;
    use pn_lab as lab;
    for dir in command.output_folders() {
        pn_formats::files::check_output_dir(dir)?;
    }
    match command {
        Command::Latex(a) => d::derive_cmds::latex(&a.request(), out),
        Command::Equations(a) => d::derive_cmds::equations(&a.request(), out),
        Command::Supplemental(a) => d::derive_cmds::supplemental(&a.request(), out),
        Command::Stencil(a) => d::stencil::run(&a.request(), out),
        Command::Solve(a) => d::solve::run(&a.request(env), out),
        Command::Converge(a) => d::converge::run(&a.request(env), out),
        Command::Bench(a) => lab::bench::run(&a.request(env), out),
        Command::Tradeoff(a) => lab::tradeoff::run(&a.request(env), out),
        Command::Render(a) => d::render::run(&a.request(env), out),
        Command::Figure(a) => lab::figure::run(&a.request(env), out),
        Command::ExportMitsuba(a) => d::export_mitsuba::run(&a.request(env), out),
        Command::Compare(a) => d::compare::run(&a.request(), out),
        Command::Race(a) => lab::race::run(&a.request(env)?, out),
    }?;
    out.flush()?;
    Ok(())
}

/// Whether `err` comes from writing to a closed pipe.
fn is_broken_pipe(err: &anyhow::Error) -> bool {
    err.chain().any(|e| {
        e.downcast_ref::<std::io::Error>()
            .is_some_and(|io| io.kind() == std::io::ErrorKind::BrokenPipe)
    })
}

/// The exit status after a closed pipe: 128 + SIGPIPE (13).
const BROKEN_PIPE_STATUS: i32 = 141;

fn main() {
    if let Some(message) = pn_runtime::missing_features() {
        eprintln!("error: {message}");
        std::process::exit(1);
    }
    let args = Cli::parse();
    let env = cli::Env::from_process();
    let mut stdout = std::io::stdout();
    // The whole command runs on a worker of the global thread pool (`with_threads` says why).
    let result =
        pn_runtime::with_threads(None, || run(&args.command, &env, &mut stdout)).and_then(|r| r);
    if let Err(err) = result {
        if is_broken_pipe(&err) {
            std::process::exit(BROKEN_PIPE_STATUS);
        }
        eprintln!("error: {err:#}");
        std::process::exit(1);
    }
}
