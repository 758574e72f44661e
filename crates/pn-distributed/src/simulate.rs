//! Every process of a partition in one process, the ghost exchanges done by copying
//! through vectors in storage order: the reference the MPI runs are checked against, and
//! what the default build tests (no MPI needed).

use crate::local::LocalReduced;
use crate::partition::Decomposition;
use pn_runtime::problem::Problem;
use pn_runtime::Layout;
use pn_stencil::StencilKernel;

/// All processes' parts of the reduced system.
#[derive(Clone, Debug)]
pub struct SimulatedRanks {
    /// One part per process, in rank order.
    pub parts: Vec<LocalReduced>,
    len: usize,
}

impl SimulatedRanks {
    /// Builds every process's part.
    pub fn build(
        problem: &Problem,
        kernel: &dyn StencilKernel,
        layout: &Layout,
        dec: &Decomposition,
    ) -> anyhow::Result<Self> {
        let parts = (0..dec.ranks())
            .map(|r| LocalReduced::build(problem, kernel, layout, dec, r))
            .collect::<anyhow::Result<_>>()?;
        Ok(Self {
            parts,
            len: layout.len(),
        })
    }

    /// The owned values and the ghosts of `part` read from a vector in storage order.
    fn extended(owned: &[usize], ghosts: &[usize], global: &[f64]) -> Vec<f64> {
        owned.iter().chain(ghosts).map(|&g| global[g]).collect()
    }

    /// `S x` (or `A x` for a system solved as it stands) with `x` and the result in storage order (entries of eliminated unknowns in `x`
    /// are ignored, those of the result are 0): each process's rows from its owned values
    /// and ghosts, as on separate processes.
    pub fn apply(&self, x: &[f64]) -> Vec<f64> {
        let mut t_global = vec![0.0; self.len];
        for p in &self.parts {
            let x_ext = Self::extended(&p.kept.owned, &p.kept.ghosts, x);
            let mut t = vec![0.0; p.elim.owned.len()];
            p.apply_c(&x_ext, &mut t);
            for (&g, v) in p.elim.owned.iter().zip(t) {
                t_global[g] = v;
            }
        }
        let mut y = vec![0.0; self.len];
        for p in self.parts.iter().filter(|p| p.is_direct()) {
            let x_ext = Self::extended(&p.kept.owned, &p.kept.ghosts, x);
            let mut out = vec![0.0; p.kept.owned.len()];
            p.apply_direct(&x_ext, &mut out);
            for (&g, v) in p.kept.owned.iter().zip(out) {
                y[g] = v;
            }
        }
        for p in self.parts.iter().filter(|p| !p.is_direct()) {
            let x_own: Vec<f64> = p.kept.owned.iter().map(|&g| x[g]).collect();
            let t_ext = Self::extended(&p.elim.owned, &p.elim.ghosts, &t_global);
            let mut out = vec![0.0; p.kept.owned.len()];
            p.apply_b(&x_own, &t_ext, &mut out);
            for (&g, v) in p.kept.owned.iter().zip(out) {
                y[g] = v;
            }
        }
        y
    }

    /// The reduced right-hand side in storage order (0 at eliminated unknowns).
    pub fn reduced_rhs(&self) -> Vec<f64> {
        let mut s = vec![0.0; self.len];
        for p in &self.parts {
            for (&g, v) in p.elim.owned.iter().zip(p.scaled_odd_rhs()) {
                s[g] = v;
            }
        }
        let mut f = vec![0.0; self.len];
        for p in &self.parts {
            let s_ext = Self::extended(&p.elim.owned, &p.elim.ghosts, &s);
            for (&g, v) in p.kept.owned.iter().zip(p.reduced_rhs(&s_ext)) {
                f[g] = v;
            }
        }
        f
    }
}
