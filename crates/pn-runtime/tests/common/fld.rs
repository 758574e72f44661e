//! FLD test problems shared by the FLD tests.

use pn_runtime::fld::{FldGrid, FldProblem};

/// A sphere of σ_t = 10 (albedo 0.9, uniform emission q = 1 inside) of radius 1/4 in the
/// centre of the vacuum-filled unit cube, `n³` cells.
pub fn sphere_in_vacuum(n: usize) -> FldProblem {
    let grid = FldGrid::cube(n, 1.0).unwrap();
    let len = grid.len();
    let (mut sigma_t, mut sigma_a, mut source) = (vec![0.0; len], vec![0.0; len], vec![0.0; len]);
    for idx in 0..len {
        let x = grid.centre(grid.cell(idx));
        let r2: f64 = x.iter().map(|v| (v - 0.5).powi(2)).sum();
        if r2 < 0.25 * 0.25 {
            sigma_t[idx] = 10.0;
            sigma_a[idx] = 1.0;
            source[idx] = 1.0;
        }
    }
    FldProblem {
        grid,
        sigma_t,
        sigma_a,
        source,
    }
}
