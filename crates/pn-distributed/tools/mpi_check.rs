//! `mpirun -np K pn-mpi-check SCENE RES ORDER BC [PXxPYxPZ]`: applies the distributed
//! reduced operator once to a fixed probe vector and prints, on process 0, a digest of the
//! result's bits (tests/mpi.rs compares it across process counts and splits).

use pn_distributed::petsc::{probe::apply_once, Mpi};
use pn_runtime::problem::Boundary;
use pn_runtime::scenes::{builtin, BuiltinOptions};
use pn_runtime::Layout;
use pn_stencil::{Dim, Staggering};

fn parse_procs(s: &str) -> anyhow::Result<[usize; 3]> {
    let v: Vec<usize> = s.split('x').map(str::parse).collect::<Result<_, _>>()?;
    anyhow::ensure!(v.len() == 3, "want PXxPYxPZ, got {s}");
    Ok([v[0], v[1], v[2]])
}

fn main() -> anyhow::Result<()> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    anyhow::ensure!(
        args.len() == 4 || args.len() == 5,
        "usage: pn-mpi-check SCENE RES ORDER BC [PXxPYxPZ]"
    );
    let opts = BuiltinOptions {
        dim: Some(Dim::Three),
        res: Some(vec![args[1].parse()?]),
        ..BuiltinOptions::default()
    };
    let mut problem = builtin(&args[0], &opts)?.problem;
    problem.boundary = args[3].parse::<Boundary>()?;
    let order: usize = args[2].parse()?;
    let choice = pn_kernels::pn_kernel(order, Dim::Three, Staggering::Staggered)?;
    let kernel = choice.kernel.as_ref();
    let layout = Layout::new(&problem.grid, kernel.moments())?;
    let procs = args.get(4).map(|s| parse_procs(s)).transpose()?;
    let mpi = Mpi::init()?;
    let probe = |g: usize| ((g as f64 * 0.618_033_988_75).fract() - 0.5) * (1.0 + (g % 7) as f64);
    let y = match apply_once(&mpi, &problem, kernel, &layout, procs, probe) {
        Ok(y) => y,
        Err(e) => {
            eprintln!("error: {e:#}");
            mpi.abort(1)
        }
    };
    if let Some(y) = y {
        // FNV-1a over the bits of every value, in storage order.
        let mut h: u64 = 0xcbf2_9ce4_8422_2325;
        for v in &y {
            for b in v.to_bits().to_le_bytes() {
                h = (h ^ b as u64).wrapping_mul(0x0100_0000_01b3);
            }
        }
        let nonzero = y.iter().filter(|v| **v != 0.0).count();
        println!("digest {h:016x} values {} nonzero {nonzero}", y.len());
    }
    Ok(())
}
