//! Memory estimate of a solve, computed before anything is allocated, and the limit
//! `pn solve --max-memory` checks it against.
//!
//! The estimate counts the large buffers only (all in f64 values and `usize` indices):
//! * the matrix A in CSR form: `nnz·(8 + 8) + (n + 1)·8` bytes, counted **three times**
//!   (the per-chunk buffers of the parallel assembly coexist with the final CSR arrays,
//!   and CGNR keeps Aᵀ beside A);
//! * the solver vectors: [`SOLVER_VECTORS`] vectors of n values (CGNR uses x, r, s, p, q
//!   and b; parity-CG a few more for the split system and its preconditioner);
//! * the cell-centred outputs: every moment at every cell, twice (moments and fluence
//!   images / arrays being written).
//!
//! That is [`estimate`], the bound for any solver. [`estimate_for_solver`] counts what the
//! chosen solver holds instead: the parity solvers assemble straight into the even/odd
//! blocks ([`crate::assemble_split`]), so A appears once and never beside its blocks; the
//! matrix-free solvers store no matrix at all.
//!
//! `nnz` is bounded by the number of stencil terms per row (the pattern length), so the
//! estimate is an upper bound up to the solver's own small allocations. Everything is
//! computed in `f64`/`u128` so absurd resolutions cannot overflow.

use crate::problem::Grid;
use pn_stencil::StencilKernel;

/// Vectors of length n the solvers keep alive at once (upper bound over cgnr/parity-cg).
pub const SOLVER_VECTORS: u128 = 10;

/// Default `--max-memory` as a fraction of the physical memory (`MemTotal`).
pub const DEFAULT_FRACTION_OF_PHYSICAL: f64 = 0.8;

/// Fallback limit when `/proc/meminfo` cannot be read (8 GiB).
pub const FALLBACK_LIMIT_BYTES: u64 = 8 << 30;

/// The estimated size of a solve.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct MemoryEstimate {
    /// Number of unknowns n.
    pub unknowns: u128,
    /// Upper bound on the stored non-zeros of A (Σ rows × stencil terms of the row).
    pub nonzeros: u128,
    /// Estimated peak bytes (see module docs).
    pub bytes: u128,
}

impl std::fmt::Display for MemoryEstimate {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "{} unknowns, ≤ {} non-zeros, about {}",
            self.unknowns,
            self.nonzeros,
            human_bytes(self.bytes)
        )
    }
}

/// Unknowns, stored non-zeros (upper bound) and cells of `kernel` on `grid`.
fn sizes(grid: &Grid, kernel: &dyn StencilKernel) -> (u128, u128, u128) {
    let cells: u128 = grid.res.iter().map(|&r| r as u128).product();
    let mut unknowns: u128 = 0;
    let mut nonzeros: u128 = 0;
    for (row, mp) in kernel.moments().iter().enumerate() {
        let positions: u128 = (0..3)
            .map(|d| grid.res[d] as u128 + mp.shift[d] as u128)
            .product();
        unknowns = unknowns.saturating_add(positions);
        let terms = kernel.pattern(row).len().max(1) as u128;
        nonzeros = nonzeros.saturating_add(positions.saturating_mul(terms));
    }
    (cells, unknowns, nonzeros)
}

/// Estimates the memory a solve of `kernel` on `grid` needs with the assembled matrix
/// (the bound for any solver). Allocates nothing that grows with the grid.
pub fn estimate(grid: &Grid, kernel: &dyn StencilKernel) -> MemoryEstimate {
    let (cells, unknowns, nonzeros) = sizes(grid, kernel);
    let csr = nonzeros
        .saturating_mul(16)
        .saturating_add((unknowns + 1).saturating_mul(8));
    let vectors = unknowns.saturating_mul(8 * SOLVER_VECTORS);
    let outputs = cells.saturating_mul(kernel.moments().len() as u128 * 8 * 2);
    let bytes = csr
        .saturating_mul(3)
        .saturating_add(vectors)
        .saturating_add(outputs);
    MemoryEstimate {
        unknowns,
        nonzeros,
        bytes,
    }
}

/// Coarse multigrid levels hold at most this fraction of the fine blocks' entries
/// (measured: 0.22 on the 80³ P_5 point source, 51.6 M coarse entries for 238.6 M in A).
pub const MULTIGRID_FRACTION: f64 = 0.35;

/// Vectors of the even unknowns the parity solvers keep besides the Krylov basis
/// (iterate, rhs, preconditioned residual, multigrid work, probes).
pub const PARITY_VECTORS: u128 = 12;

/// Like [`estimate`], for the memory `solver` actually holds:
/// * parity solvers on a stencil with the parity structure
///   ([`crate::assemble_split::has_parity_structure`]): the blocks B and D_o⁻¹C once (A is
///   never assembled), the index maps (4 per unknown), the multigrid levels
///   ([`MULTIGRID_FRACTION`]), the GMRES basis ([`pn_krylov::gmres::gmres_restart`]
///   + 1 vectors of the even unknowns, counted as half of all) and [`PARITY_VECTORS`];
/// * matrix-free solvers: a weight per unknown (the varying collision weights) and the
///   solver vectors;
/// * the others: [`estimate`].
///
/// Plus, in every case, the cell-centred outputs.
pub fn estimate_for_solver(
    grid: &Grid,
    kernel: &dyn StencilKernel,
    solver: crate::solver::SolverKind,
) -> MemoryEstimate {
    use crate::solver::SolverKind as K;
    let (cells, unknowns, nonzeros) = sizes(grid, kernel);
    let outputs = cells.saturating_mul(kernel.moments().len() as u128 * 8 * 2);
    let parity = matches!(solver, K::ParityCg | K::ParityMg | K::ParityIlu)
        && crate::assemble_split::has_parity_structure(kernel);
    let bytes = if parity {
        let blocks = nonzeros.saturating_mul(16);
        let maps = unknowns.saturating_mul(8 * 4);
        let multigrid = (blocks as f64 * MULTIGRID_FRACTION) as u128;
        let even = unknowns / 2 + 1;
        let restart =
            pn_krylov::gmres::gmres_restart(usize::try_from(even).unwrap_or(usize::MAX)) as u128;
        let krylov = even.saturating_mul(8 * (restart + 1 + PARITY_VECTORS));
        let full_vectors = unknowns.saturating_mul(8 * 3);
        blocks
            .saturating_add(maps)
            .saturating_add(multigrid)
            .saturating_add(krylov)
            .saturating_add(full_vectors)
    } else if solver.is_matrix_free() {
        unknowns.saturating_mul(8 * (SOLVER_VECTORS + 1))
    } else {
        return estimate(grid, kernel);
    };
    MemoryEstimate {
        unknowns,
        nonzeros,
        bytes: bytes.saturating_add(outputs),
    }
}

/// Values per cell flux-limited diffusion keeps (coefficients, source, iterate, diffusion
/// coefficients per axis, limiter work arrays, Krylov vectors of the Picard variant):
/// a generous upper bound over its Gauss–Seidel and Picard solvers.
pub const FLD_VALUES_PER_CELL: u128 = 24;

/// Estimates the memory of flux-limited diffusion (`--method fld`) on `grid`: one unknown
/// per cell, a (2·axes + 1)-point matrix counted three times as in [`estimate`] (Picard
/// solves), plus [`FLD_VALUES_PER_CELL`] values per cell.
pub fn estimate_fld(grid: &Grid) -> MemoryEstimate {
    let cells: u128 = grid.res.iter().map(|&r| r as u128).product();
    let nonzeros = cells.saturating_mul(2 * grid.dim.axes() as u128 + 1);
    let csr = nonzeros
        .saturating_mul(16)
        .saturating_add((cells + 1).saturating_mul(8));
    let bytes = csr
        .saturating_mul(3)
        .saturating_add(cells.saturating_mul(8 * FLD_VALUES_PER_CELL));
    MemoryEstimate {
        unknowns: cells,
        nonzeros,
        bytes,
    }
}

/// Physical memory in bytes (`MemTotal` from `/proc/meminfo`), if available.
pub fn physical_memory_bytes() -> Option<u64> {
    let info = std::fs::read_to_string("/proc/meminfo").ok()?;
    parse_meminfo_total(&info)
}

/// Memory available now in bytes (`MemAvailable` from `/proc/meminfo`), if reported.
pub fn available_memory_bytes() -> Option<u64> {
    let info = std::fs::read_to_string("/proc/meminfo").ok()?;
    parse_meminfo_field(&info, "MemAvailable")
}

/// Parses the `MemTotal:  <kB> kB` line of a `/proc/meminfo` text.
pub fn parse_meminfo_total(info: &str) -> Option<u64> {
    parse_meminfo_field(info, "MemTotal")
}

/// Parses the `<field>:  <kB> kB` line of a `/proc/meminfo` text, in bytes.
pub fn parse_meminfo_field(info: &str, field: &str) -> Option<u64> {
    let line = info
        .lines()
        .find(|l| l.strip_prefix(field).is_some_and(|r| r.starts_with(':')))?;
    let kb: u64 = line.split_whitespace().nth(1)?.parse().ok()?;
    kb.checked_mul(1024)
}

/// The default limit: [`DEFAULT_FRACTION_OF_PHYSICAL`] of the physical memory, or
/// [`FALLBACK_LIMIT_BYTES`] where that is unknown.
pub fn default_limit_bytes() -> u64 {
    physical_memory_bytes()
        .map(|b| (b as f64 * DEFAULT_FRACTION_OF_PHYSICAL) as u64)
        .unwrap_or(FALLBACK_LIMIT_BYTES)
}

/// Parses a size: a plain number of bytes or a number with a unit `K`, `M`, `G`, `T`
/// (powers of 1024, optional `B`/`iB` suffix, case-insensitive), e.g. `512M`, `1.5GiB`.
pub fn parse_size(s: &str) -> anyhow::Result<u64> {
    let t = s.trim();
    let lower = t.to_ascii_lowercase();
    let stripped = lower
        .strip_suffix("ib")
        .or_else(|| lower.strip_suffix('b'))
        .unwrap_or(&lower);
    let (num, mult) = match stripped.chars().last() {
        Some('k') => (&stripped[..stripped.len() - 1], 1u64 << 10),
        Some('m') => (&stripped[..stripped.len() - 1], 1u64 << 20),
        Some('g') => (&stripped[..stripped.len() - 1], 1u64 << 30),
        Some('t') => (&stripped[..stripped.len() - 1], 1u64 << 40),
        _ => (stripped, 1),
    };
    let v: f64 = num.trim().parse().map_err(|_| {
        anyhow::anyhow!("bad memory size {s:?} (expected e.g. 4096, 512M, 2G or 1.5GiB)")
    })?;
    anyhow::ensure!(
        v.is_finite() && v > 0.0,
        "memory size must be positive, got {s:?}"
    );
    let bytes = v * mult as f64;
    anyhow::ensure!(bytes < u64::MAX as f64, "memory size {s:?} is too large");
    Ok(bytes as u64)
}

/// Refuses a solve whose estimate exceeds `limit` bytes, with the estimate in the message.
pub fn check_limit(est: &MemoryEstimate, limit: u64) -> anyhow::Result<()> {
    anyhow::ensure!(
        est.bytes <= limit as u128,
        "the problem needs {est}, more than the memory limit of {} \
         (raise it with --max-memory, or lower --res / --order)",
        human_bytes(limit as u128)
    );
    Ok(())
}

/// `1.50 GiB`-style formatting.
pub fn human_bytes(b: u128) -> String {
    const UNITS: [&str; 7] = ["B", "KiB", "MiB", "GiB", "TiB", "PiB", "EiB"];
    let mut v = b as f64;
    let mut u = 0;
    while v >= 1024.0 && u + 1 < UNITS.len() {
        v /= 1024.0;
        u += 1;
    }
    if u == 0 {
        format!("{b} B")
    } else {
        format!("{v:.2} {}", UNITS[u])
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sizes_parse() {
        assert_eq!(parse_size("4096").unwrap(), 4096);
        assert_eq!(parse_size("512M").unwrap(), 512 << 20);
        assert_eq!(parse_size("2g").unwrap(), 2 << 30);
        assert_eq!(parse_size("1.5GiB").unwrap(), 3 << 29);
        assert_eq!(parse_size("3KB").unwrap(), 3072);
        for bad in ["", "x", "-1G", "0", "nanM", "1e400"] {
            assert!(parse_size(bad).is_err(), "{bad}");
        }
    }

    #[test]
    fn meminfo() {
        let t = "MemTotal:       24500000 kB\nMemFree: 1 kB\n";
        assert_eq!(parse_meminfo_total(t), Some(24_500_000 * 1024));
        assert_eq!(parse_meminfo_total("nothing"), None);
        let t = "MemTotal: 8 kB\nMemAvailable:    3 kB\n";
        assert_eq!(parse_meminfo_field(t, "MemAvailable"), Some(3 * 1024));
        assert_eq!(parse_meminfo_field(t, "MemFree"), None);
    }

    #[test]
    fn human() {
        assert_eq!(human_bytes(12), "12 B");
        assert_eq!(human_bytes(3 << 30), "3.00 GiB");
    }
}
