//! Scalar fields over the domain: constants, analytic functions of position, and voxel grids.
//!
//! Analytic fields are evaluated exactly at the requested (staggered) position, as StaRMAP
//! does (DESIGN.md §3, "Fields"). Voxel grids hold one value per cell centre of the domain
//! and are sampled by trilinear interpolation between cell centres (clamped at the domain
//! edge). When the voxel resolution equals the grid resolution this is exactly the rule of
//! DESIGN.md §3: a value at a cell centre is the voxel, at a face the average of the 2
//! adjacent cells, at an edge the average of 4 and at a corner the average of 8.

use std::sync::Arc;

/// A position in world coordinates (x, y, z).
pub type Point = [f64; 3];

/// An analytic scalar function of position.
pub trait AnalyticField: Send + Sync {
    /// Value at `p`.
    fn eval(&self, p: Point) -> f64;
}

impl<F: Fn(Point) -> f64 + Send + Sync> AnalyticField for F {
    fn eval(&self, p: Point) -> f64 {
        self(p)
    }
}

/// Cell-centred samples over an axis-aligned box, x as the slowest axis
/// (index `(x·ny + y)·nz + z`, the C order of an array of shape `(nx, ny, nz)`).
#[derive(Clone, Debug, PartialEq)]
pub struct VoxelGrid {
    /// Cells per axis (x, y, z); `z == 1` for 2D data.
    pub dims: [usize; 3],
    /// Lower corner of the box the cells tile.
    pub min: Point,
    /// Upper corner of the box the cells tile.
    pub max: Point,
    /// `dims[0]·dims[1]·dims[2]` values.
    pub data: Vec<f64>,
}

impl VoxelGrid {
    /// Creates a grid, checking that `data` has `dims[0]·dims[1]·dims[2]` entries.
    pub fn new(dims: [usize; 3], min: Point, max: Point, data: Vec<f64>) -> anyhow::Result<Self> {
        let n: usize = dims.iter().product();
        anyhow::ensure!(
            dims.iter().all(|&d| d > 0),
            "voxel grid has a zero dimension: {dims:?}"
        );
        anyhow::ensure!(
            data.len() == n,
            "voxel grid {}×{}×{} needs {n} values, got {}",
            dims[0],
            dims[1],
            dims[2],
            data.len()
        );
        Ok(Self {
            dims,
            min,
            max,
            data,
        })
    }

    /// The value of cell `(i, j, k)`.
    pub fn at(&self, i: usize, j: usize, k: usize) -> f64 {
        self.data[(i * self.dims[1] + j) * self.dims[2] + k]
    }

    /// Trilinear interpolation between cell centres, clamped to the outermost centres.
    pub fn sample(&self, p: Point) -> f64 {
        let mut lo = [0usize; 3];
        let mut hi = [0usize; 3];
        let mut t = [0.0f64; 3];
        for d in 0..3 {
            let n = self.dims[d];
            let h = (self.max[d] - self.min[d]) / n as f64;
            // Continuous cell-centre coordinate: centre i sits at u = i.
            let u = if h > 0.0 {
                (p[d] - self.min[d]) / h - 0.5
            } else {
                0.0
            };
            let u = u.clamp(0.0, (n - 1) as f64);
            let f = u.floor();
            lo[d] = f as usize;
            hi[d] = (lo[d] + 1).min(n - 1);
            t[d] = u - f;
        }
        let mut v = 0.0;
        for corner in 0..8 {
            let mut w = 1.0;
            let mut idx = [0usize; 3];
            for d in 0..3 {
                if corner >> d & 1 == 1 {
                    w *= t[d];
                    idx[d] = hi[d];
                } else {
                    w *= 1.0 - t[d];
                    idx[d] = lo[d];
                }
            }
            if w != 0.0 {
                v += w * self.at(idx[0], idx[1], idx[2]);
            }
        }
        v
    }

    /// The first entry that is NaN, infinite or negative, as (cell index, value).
    pub fn first_invalid(&self) -> Option<([usize; 3], f64)> {
        let pos = self.data.iter().position(|v| !v.is_finite() || *v < 0.0)?;
        let k = pos % self.dims[2];
        let j = (pos / self.dims[2]) % self.dims[1];
        let i = pos / (self.dims[2] * self.dims[1]);
        Some(([i, j, k], self.data[pos]))
    }
}

/// A scalar field of the problem description.
#[derive(Clone)]
pub enum Field {
    /// The same value everywhere.
    Constant(f64),
    /// An analytic function, evaluated exactly at each position.
    Analytic(Arc<dyn AnalyticField>),
    /// Cell-centred data, interpolated (averaged) to staggered positions.
    Voxel(Arc<VoxelGrid>),
    /// `factor × field`.
    Scaled(f64, Box<Field>),
}

impl std::fmt::Debug for Field {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Field::Constant(c) => write!(f, "Constant({c})"),
            Field::Analytic(_) => write!(f, "Analytic"),
            Field::Voxel(g) => write!(f, "Voxel({:?})", g.dims),
            Field::Scaled(s, inner) => write!(f, "Scaled({s}, {inner:?})"),
        }
    }
}

impl Field {
    /// An analytic field from a closure.
    pub fn analytic(f: impl Fn(Point) -> f64 + Send + Sync + 'static) -> Self {
        Field::Analytic(Arc::new(f))
    }

    /// Value at `p`.
    pub fn eval(&self, p: Point) -> f64 {
        match self {
            Field::Constant(c) => *c,
            Field::Analytic(f) => f.eval(p),
            Field::Voxel(g) => g.sample(p),
            Field::Scaled(s, inner) => s * inner.eval(p),
        }
    }

    /// Whether the field is sampled from voxel data (averaged) rather than exact.
    pub fn is_voxel(&self) -> bool {
        match self {
            Field::Voxel(_) => true,
            Field::Scaled(_, inner) => inner.is_voxel(),
            _ => false,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn voxel_sampling_averages_adjacent_centres() {
        // 2×2×1 grid on [0,2]×[0,2]×[0,1]: centres at 0.5 and 1.5.
        let g = VoxelGrid::new(
            [2, 2, 1],
            [0.0; 3],
            [2.0, 2.0, 1.0],
            vec![1.0, 2.0, 3.0, 4.0],
        )
        .unwrap();
        assert_eq!(g.sample([0.5, 0.5, 0.5]), 1.0);
        assert_eq!(g.sample([1.5, 0.5, 0.5]), 3.0);
        // Face between x-cells: average of two.
        assert_eq!(g.sample([1.0, 0.5, 0.5]), 2.0);
        // Corner: average of four.
        assert_eq!(g.sample([1.0, 1.0, 0.5]), 2.5);
        // Domain face: clamped to the outermost centre.
        assert_eq!(g.sample([0.0, 0.5, 0.0]), 1.0);
    }

    #[test]
    fn invalid_entries_are_found() {
        let g = VoxelGrid::new([1, 2, 1], [0.0; 3], [1.0; 3], vec![1.0, f64::NAN]).unwrap();
        assert_eq!(g.first_invalid().unwrap().0, [0, 1, 0]);
    }
}
