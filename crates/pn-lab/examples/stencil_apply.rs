//! Times one application of the reduced operator `S` from its stencils
//! (`solver::parity::stencil_s`) on the point source, in f64 and f32, against the
//! roofline byte model: `cargo run --release -p pn-lab --example stencil_apply -- 80 5`.

use pn_kernels::{pn_kernel, Dim, Staggering};
use pn_runtime::assemble_split::assemble_split_stencil;
use pn_runtime::bandwidth::median_seconds;
use pn_runtime::scenes::{builtin, BuiltinOptions};
use pn_runtime::Layout;

fn main() -> anyhow::Result<()> {
    let args: Vec<usize> = std::env::args()
        .skip(1)
        .map(|a| a.parse())
        .collect::<Result<_, _>>()?;
    let (n, order) = (
        args.first().copied().unwrap_or(40),
        args.get(1).copied().unwrap_or(5),
    );
    let opts = BuiltinOptions {
        dim: Some(Dim::Three),
        res: Some(vec![n]),
        ..Default::default()
    };
    let scene = builtin("pointsource", &opts)?;
    let k = pn_kernel(order, Dim::Three, Staggering::Staggered)?;
    let layout = Layout::new(&scene.problem.grid, k.kernel.moments())?;
    let system = assemble_split_stencil(&scene.problem, k.kernel.as_ref(), &layout)??;
    let split = system.split;
    let s = split
        .stencil
        .clone()
        .ok_or_else(|| anyhow::anyhow!("no stencil"))?;
    let (ne, no) = (split.even.len(), split.odd.len());
    let bytes = s.bytes(ne, no) as f64;
    let x: Vec<f64> = (0..ne).map(|i| 1.0 + (i % 7) as f64 * 0.125).collect();
    let mut y = vec![0.0; ne];
    let mut t = vec![0.0; no];
    let t64 = median_seconds(10, 50, 1.0, || {
        s.apply_with(&split.d_e, &split.d_o, &x, &mut y, &mut t)
    });
    let f = |v: &[f64]| v.iter().map(|&a| a as f32).collect::<Vec<f32>>();
    let (de, dd, xs) = (f(&split.d_e), f(&split.d_o), f(&x));
    let mut ys = vec![0f32; ne];
    let mut ts = vec![0f32; no];
    let t32 = median_seconds(10, 50, 1.0, || {
        s.apply_with(&de, &dd, &xs, &mut ys, &mut ts)
    });
    let diff = y
        .iter()
        .zip(&ys)
        .map(|(a, &b)| (a - b as f64).abs())
        .fold(0.0, f64::max);
    let ymax = y.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    println!(
        "{n}^3 P_{order}: n_e {ne} n_o {no}, corrections {}; f64 {:.2} ms ({:.1} GB/s model), f32 {:.2} ms; |y64-y32|/|y| {:.1e}; y checksum {:.6e}",
        s.corrections(),
        t64 * 1e3,
        bytes / t64 / 1e9,
        t32 * 1e3,
        diff / ymax,
        y.iter().sum::<f64>()
    );
    Ok(())
}
