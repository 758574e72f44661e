//! One application of the distributed `S` to a given vector, gathered onto process 0: the
//! operator-parity check (the same bits on any number of processes and any split).

use super::objects::{gather, PVec};
use super::operator::{Parts, Shell};
use super::Mpi;
use pn_runtime::problem::Problem;
use pn_runtime::Layout;
use pn_stencil::StencilKernel;

/// `S x` on the processes of `mpi` split as `procs` (or balanced), with `x(g)` the value at
/// storage index `g`; on process 0 the result in storage order (0 at the eliminated
/// unknowns), `None` elsewhere.
pub fn apply_once(
    mpi: &Mpi,
    problem: &Problem,
    kernel: &dyn StencilKernel,
    layout: &Layout,
    procs: Option<[usize; 3]>,
    x: impl Fn(usize) -> f64,
) -> anyhow::Result<Option<Vec<f64>>> {
    let parts = Parts::build(mpi, problem, kernel, layout, procs)?;
    let owned = &parts.local.kept.owned;
    let xv = PVec::mpi(owned.len())?;
    xv.fill(&owned.iter().map(|&g| x(g)).collect::<Vec<_>>())?;
    let y = PVec::mpi(owned.len())?;
    let shell = Shell::new(&parts, layout, &xv)?;
    shell.mult(xv.0, y.0)?;
    let gathered = gather(&y, false)?;
    Ok((mpi.rank() == 0).then(|| {
        let mut out = vec![0.0; layout.len()];
        let mut at = 0;
        for r in 0..mpi.size() {
            for g in parts.kept_num.owned(layout, r) {
                out[g] = gathered[at];
                at += 1;
            }
        }
        out
    }))
}
