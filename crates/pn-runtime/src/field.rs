//! Scalar fields over the domain: constants, analytic functions of position, and voxel grids.
//!
//! Analytic fields are evaluated exactly at the requested (staggered) position, as StaRMAP
//! does (docs/design.md §3, "Fields"). Voxel grids hold one value per cell centre of the domain
//! and are sampled by trilinear interpolation between cell centres (clamped at the domain
//! edge). When the voxel resolution equals the grid resolution this is exactly the rule of
//! docs/design.md §3: a value at a cell centre is the voxel, at a face the average of the 2
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
        let h = [0, 1, 2].map(|d| (self.max[d] - self.min[d]) / self.dims[d] as f64);
        trilinear_corners(p, self.min, h, self.dims)
            .into_iter()
            .filter(|&(_, w)| w != 0.0)
            .map(|(idx, w)| w * self.at(idx[0], idx[1], idx[2]))
            .sum()
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

/// How analytic fields are sampled at staggered positions (`--sampling`).
///
/// * `Exact` (default): the field's value at the staggered point, as StaRMAP does
///   (docs/design.md §3, "Fields").
/// * `Average(n)`: the mean of the field over the control volume around the staggered
///   point — the box of one cell size `h` per active axis centred on the point — by the
///   midpoint rule on `n` sub-boxes per axis (`n^d` evaluations). A piecewise-constant field
///   with one interface through the box is averaged with an error of at most `1/n` of the
///   jump per crossing sub-row. With `n = 8` in 2D (64 samples) the volume fraction of a
///   straight axis-aligned interface is resolved to 1/8.
///
/// Constant and voxel fields are not affected (voxel data is already averaged, see
/// [`VoxelGrid::sample`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum Sampling {
    /// Exact evaluation at the staggered point.
    #[default]
    Exact,
    /// Cell average by `n` midpoint samples per active axis.
    Average(usize),
}

/// Sub-samples per axis of `--sampling average` without a count: 8 in 2D (64 samples),
/// 4 in 3D (64 samples, so that 3D assembly costs no more than 2D per position).
pub fn default_average_samples(axes: usize) -> usize {
    if axes >= 3 {
        4
    } else {
        8
    }
}

impl Sampling {
    /// `exact`, `average` or `average:N`; `average` without N is stored as `Average(0)` and
    /// resolved by [`Sampling::resolved`] once the dimension is known.
    pub fn parse(s: &str) -> anyhow::Result<Self> {
        match s {
            "exact" => Ok(Sampling::Exact),
            "average" => Ok(Sampling::Average(0)),
            _ => {
                if let Some(n) = s.strip_prefix("average:") {
                    let n: usize = n.parse().map_err(|_| {
                        anyhow::anyhow!("bad sample count {n:?} in --sampling {s:?}")
                    })?;
                    anyhow::ensure!(
                        (1..=64).contains(&n),
                        "--sampling average:N needs 1 ≤ N ≤ 64, got {n}"
                    );
                    Ok(Sampling::Average(n))
                } else {
                    anyhow::bail!("unknown sampling {s:?} (expected exact, average or average:N)")
                }
            }
        }
    }

    /// `Average(0)` replaced by the default count for `axes` active axes.
    pub fn resolved(self, axes: usize) -> Self {
        match self {
            Sampling::Average(0) => Sampling::Average(default_average_samples(axes)),
            s => s,
        }
    }

    /// A short name for reports: `exact` or `average:N`.
    pub fn name(&self) -> String {
        match self {
            Sampling::Exact => "exact".into(),
            Sampling::Average(n) => format!("average:{n}"),
        }
    }
}

impl std::str::FromStr for Sampling {
    type Err = anyhow::Error;
    fn from_str(s: &str) -> anyhow::Result<Self> {
        Sampling::parse(s)
    }
}

/// The mean of an analytic field over an axis-aligned box of size `size` centred on the
/// evaluation point, by the midpoint rule on `n` sub-boxes per axis (axes with size 0 are
/// not sampled).
pub struct BoxAverage {
    inner: Arc<dyn AnalyticField>,
    /// Offsets of the sample points from the box centre.
    offsets: Vec<Point>,
}

impl BoxAverage {
    /// Averages `inner` over boxes of `size` (one entry per axis; 0 = no extent) with `n`
    /// midpoints per axis of non-zero extent.
    pub fn new(inner: Arc<dyn AnalyticField>, size: Point, n: usize) -> Self {
        let n = n.max(1);
        let per_axis: Vec<Vec<f64>> = (0..3)
            .map(|d| {
                if size[d] > 0.0 {
                    (0..n)
                        .map(|i| ((i as f64 + 0.5) / n as f64 - 0.5) * size[d])
                        .collect()
                } else {
                    vec![0.0]
                }
            })
            .collect();
        let mut offsets = Vec::new();
        for &a in &per_axis[0] {
            for &b in &per_axis[1] {
                for &c in &per_axis[2] {
                    offsets.push([a, b, c]);
                }
            }
        }
        Self { inner, offsets }
    }
}

impl AnalyticField for BoxAverage {
    fn eval(&self, p: Point) -> f64 {
        let sum: f64 = self
            .offsets
            .iter()
            .map(|o| self.inner.eval([p[0] + o[0], p[1] + o[1], p[2] + o[2]]))
            .sum();
        sum / self.offsets.len() as f64
    }
}

impl Field {
    /// This field with `sampling` applied to its analytic parts, for control volumes of
    /// `size` (the cell size per active axis, 0 on inactive axes). `Exact` returns a clone;
    /// resolve `Average(0)` with [`Sampling::resolved`] first (here it means one sample).
    pub fn with_sampling(&self, sampling: Sampling, size: Point) -> Field {
        match (sampling, self) {
            (Sampling::Exact, _) => self.clone(),
            (Sampling::Average(n), Field::Analytic(f)) => {
                Field::Analytic(Arc::new(BoxAverage::new(f.clone(), size, n)))
            }
            (_, Field::Scaled(s, inner)) => {
                Field::Scaled(*s, Box::new(inner.with_sampling(sampling, size)))
            }
            (_, Field::Constant(_) | Field::Voxel(_)) => self.clone(),
        }
    }
}

/// The eight cell-centre neighbours of `p` on a grid of `dims` cells of size `h` starting at
/// `min`, with their trilinear weights (clamped to the outermost centres, so weights of
/// coinciding corners may be 0): `Σ w·value(idx)` interpolates between cell centres.
pub fn trilinear_corners(
    p: Point,
    min: Point,
    h: [f64; 3],
    dims: [usize; 3],
) -> [([usize; 3], f64); 8] {
    let mut lo = [0usize; 3];
    let mut hi = [0usize; 3];
    let mut t = [0.0f64; 3];
    for d in 0..3 {
        let n = dims[d];
        // Continuous cell-centre coordinate: centre i sits at u = i.
        let u = if h[d] > 0.0 {
            (p[d] - min[d]) / h[d] - 0.5
        } else {
            0.0
        };
        let u = u.clamp(0.0, (n - 1) as f64);
        let f = u.floor();
        lo[d] = f as usize;
        hi[d] = (lo[d] + 1).min(n - 1);
        t[d] = u - f;
    }
    std::array::from_fn(|corner| {
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
        (idx, w)
    })
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

    #[test]
    fn box_average_of_a_step_is_the_volume_fraction() {
        // Step at x = 0.3 inside the box [0, 1] around 0.5: of the 8 midpoints (i+0.5)/8
        // only 0.0625 and 0.1875 lie below 0.3, so the indicator x < 0.3 averages to 2/8.
        let f = Field::analytic(|p: Point| if p[0] < 0.3 { 1.0 } else { 0.0 });
        let avg = f.with_sampling(Sampling::Average(8), [1.0, 1.0, 0.0]);
        assert_eq!(avg.eval([0.5, 0.5, 0.5]), 0.25);
        // A linear field is averaged exactly by the midpoint rule (its value at the centre).
        let lin = Field::analytic(|p: Point| 2.0 * p[0] - 3.0 * p[1] + 0.5);
        let avg = lin.with_sampling(Sampling::Average(4), [0.2, 0.4, 0.0]);
        assert!((avg.eval([1.0, 2.0, 0.5]) - lin.eval([1.0, 2.0, 0.5])).abs() < 1e-14);
        // Exact sampling is the field itself.
        let ex = lin.with_sampling(Sampling::Exact, [0.2, 0.4, 0.0]);
        assert_eq!(ex.eval([0.3, 0.7, 0.0]), lin.eval([0.3, 0.7, 0.0]));
    }

    #[test]
    fn sampling_parses() {
        assert_eq!(Sampling::parse("exact").unwrap(), Sampling::Exact);
        assert_eq!(
            Sampling::parse("average").unwrap().resolved(2),
            Sampling::Average(8)
        );
        assert_eq!(Sampling::parse("average:3").unwrap(), Sampling::Average(3));
        assert!(Sampling::parse("average:0").is_err());
        assert!(Sampling::parse("mean").is_err());
    }
}
