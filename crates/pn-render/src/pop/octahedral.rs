//! The octahedral parametrisation of the sphere of directions (POP paper §6, its reference
//! \[30\]): the unit sphere folded onto the octahedron `|x| + |y| + |z| = 1`, the upper half
//! (z ≥ 0) projected onto the diamond `|u| + |v| ≤ 1` of the square [−1, 1]², the lower half
//! folded onto the square's four corners.
//!
//! A map of `n × n` square cells (n even) is what the radial grid of a point light uses for
//! its two angular coordinates ([`super::radial`]): every cell has four neighbours, across
//! the square's outer edges the one mirrored about the edge's midpoint (cell `(n−1, j)`'s
//! right neighbour is `(n−1, n−1−j)`, cell `(i, n−1)`'s upper one `(n−1−i, n−1)`): the edges
//! of the square fold onto themselves on the sphere.
//!
//! **Cell solid angles, exactly.** With n even the lines u = 0 and v = 0 (octahedron edges)
//! are cell boundaries and the diamond's edges `|u| + |v| = 1` run along cell diagonals, so
//! each cell is two triangles that lie on one octahedron face each, where the map is affine:
//! a triangle of the map is a flat triangle on the octahedron, and its solid angle seen from
//! the centre is Van Oosterom and Strackee's closed form. The cells' solid angles therefore
//! sum to 4π up to rounding (a unit test), and the map's non-uniformity (cells near the
//! diamond's vertices are smaller) is accounted for exactly.

use std::f64::consts::PI;

/// The direction (unit) of the map point `(u, v)` ∈ [−1, 1]².
pub fn decode(u: f64, v: f64) -> [f64; 3] {
    let p = unnormalised(u, v);
    let n = (p[0] * p[0] + p[1] * p[1] + p[2] * p[2]).sqrt();
    p.map(|c| c / n)
}

/// The point of the octahedron `|x| + |y| + |z| = 1` that `(u, v)` maps to. The map from
/// (u, v) to it preserves area on every face, so the solid angle per unit map area at
/// `(u, v)` is `1/|p|³` (`|p|` the Euclidean length of this point).
pub fn unnormalised(u: f64, v: f64) -> [f64; 3] {
    let z = 1.0 - u.abs() - v.abs();
    if z >= 0.0 {
        [u, v, z]
    } else {
        [
            (1.0 - v.abs()) * u.signum(),
            (1.0 - u.abs()) * v.signum(),
            z,
        ]
    }
}

/// The map point `(u, v)` of the direction `w` (any non-zero length).
pub fn encode(w: [f64; 3]) -> [f64; 2] {
    let n = w[0].abs() + w[1].abs() + w[2].abs();
    let p = w.map(|c| c / n);
    if p[2] >= 0.0 {
        [p[0], p[1]]
    } else {
        [
            (1.0 - p[1].abs()) * sign(p[0]),
            (1.0 - p[0].abs()) * sign(p[1]),
        ]
    }
}

/// +1 for x ≥ 0 (so that the fold of a direction with x = 0 lands on the square).
fn sign(x: f64) -> f64 {
    if x >= 0.0 {
        1.0
    } else {
        -1.0
    }
}

/// The solid angle of the flat triangle (a, b, c) seen from the origin (Van Oosterom and
/// Strackee): `tan(Ω/2) = |a·(b×c)| / (|a||b||c| + (a·b)|c| + (a·c)|b| + (b·c)|a|)`.
pub fn triangle_solid_angle(a: [f64; 3], b: [f64; 3], c: [f64; 3]) -> f64 {
    let dot = |x: [f64; 3], y: [f64; 3]| x[0] * y[0] + x[1] * y[1] + x[2] * y[2];
    let norm = |x: [f64; 3]| dot(x, x).sqrt();
    let bxc = [
        b[1] * c[2] - b[2] * c[1],
        b[2] * c[0] - b[0] * c[2],
        b[0] * c[1] - b[1] * c[0],
    ];
    let (la, lb, lc) = (norm(a), norm(b), norm(c));
    let num = dot(a, bxc).abs();
    let den = la * lb * lc + dot(a, b) * lc + dot(a, c) * lb + dot(b, c) * la;
    2.0 * num.atan2(den)
}

/// The `n × n` octahedral map's cells (n even): centres, directions and solid angles.
#[derive(Clone, Debug, PartialEq)]
pub struct OctahedralMap {
    /// Cells per side (even).
    pub n: usize,
    /// Unit direction of each cell's centre, index `j·n + i` (i along u).
    pub directions: Vec<[f64; 3]>,
    /// Solid angle of each cell (sums to 4π).
    pub solid_angles: Vec<f64>,
    /// The cell opposite each cell (its centre's direction negated; with n even the
    /// antipode of a cell centre is a cell centre).
    pub antipodes: Vec<usize>,
}

impl OctahedralMap {
    /// The map with `n` cells per side; `n` must be even and positive.
    pub fn new(n: usize) -> anyhow::Result<OctahedralMap> {
        anyhow::ensure!(
            n > 0 && n.is_multiple_of(2),
            "the octahedral map needs an even, positive number of cells per side, got {n}"
        );
        let w = 2.0 / n as f64;
        let mut directions = Vec::with_capacity(n * n);
        let mut solid_angles = Vec::with_capacity(n * n);
        for j in 0..n {
            for i in 0..n {
                let (u0, v0) = (-1.0 + i as f64 * w, -1.0 + j as f64 * w);
                let (u1, v1) = (u0 + w, v0 + w);
                directions.push(decode(u0 + 0.5 * w, v0 + 0.5 * w));
                // Split along the diagonal that the diamond's edge in this quadrant follows:
                // u + v = ±1 (anti-diagonal) where u and v have the same sign, u − v = ±1
                // (main diagonal) elsewhere. Both halves then lie on one face each.
                let same = (u0 + 0.5 * w) * (v0 + 0.5 * w) > 0.0;
                let c = [
                    unnormalised(u0, v0),
                    unnormalised(u1, v0),
                    unnormalised(u1, v1),
                    unnormalised(u0, v1),
                ];
                let omega = if same {
                    triangle_solid_angle(c[0], c[1], c[3]) + triangle_solid_angle(c[1], c[2], c[3])
                } else {
                    triangle_solid_angle(c[0], c[1], c[2]) + triangle_solid_angle(c[0], c[2], c[3])
                };
                solid_angles.push(omega);
            }
        }
        let s = 0.5 * n as f64;
        let antipodes = directions
            .iter()
            .map(|d| {
                let [u, v] = encode(d.map(|c| -c));
                let at = |x: f64| (((x + 1.0) * s - 0.5).round().max(0.0) as usize).min(n - 1);
                at(v) * n + at(u)
            })
            .collect();
        Ok(OctahedralMap {
            n,
            directions,
            solid_angles,
            antipodes,
        })
    }

    /// The four angular neighbours of cell (i, j): +u, −u, +v, −v, mirrored across the
    /// square's outer edges (module docs).
    #[inline]
    pub fn neighbours(&self, i: usize, j: usize) -> [(usize, usize); 4] {
        let n = self.n;
        let m = n - 1;
        [
            if i + 1 < n { (i + 1, j) } else { (m, m - j) },
            if i > 0 { (i - 1, j) } else { (0, m - j) },
            if j + 1 < n { (i, j + 1) } else { (m - i, m) },
            if j > 0 { (i, j - 1) } else { (m - i, 0) },
        ]
    }

    /// The cell (i, j) of the continuous cell indices (i, j) ∈ [−1, n]², read across the
    /// square's outer edges by the fold of [`Self::neighbours`] (the four cells around a
    /// corner of the square, where all four corners meet on the sphere, are the four corner
    /// cells).
    pub fn fold(&self, i: i64, j: i64) -> (usize, usize) {
        let m = self.n as i64 - 1;
        let (mut i, mut j) = (i, j);
        if i > m {
            (i, j) = (m, m - j);
        } else if i < 0 {
            (i, j) = (0, m - j);
        }
        if j > m {
            (i, j) = (m - i, m);
        } else if j < 0 {
            (i, j) = (m - i, 0);
        }
        (i.clamp(0, m) as usize, j.clamp(0, m) as usize)
    }

    /// Continuous cell coordinates of the direction `w` (cell (i, j)'s centre at (i, j)).
    pub fn local(&self, w: [f64; 3]) -> [f64; 2] {
        let [u, v] = encode(w);
        let s = 0.5 * self.n as f64;
        [(u + 1.0) * s - 0.5, (v + 1.0) * s - 0.5]
    }

    /// The mean solid angle of a cell, 4π/n².
    pub fn mean_solid_angle(&self) -> f64 {
        4.0 * PI / (self.n * self.n) as f64
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// encode and decode are inverse on the sphere (1e-14), including the folded lower half.
    #[test]
    fn encode_and_decode_are_inverse() {
        for w in [
            [0.3f64, -0.5, 0.81],
            [-0.7, 0.2, -0.3],
            [0.0, 0.0, -1.0],
            [0.1, 0.9, -0.2],
            [-0.4, -0.4, -0.8],
            [1.0, 0.0, 0.0],
        ] {
            let n = (w[0] * w[0] + w[1] * w[1] + w[2] * w[2]).sqrt();
            let w = w.map(|c| c / n);
            let [u, v] = encode(w);
            assert!(u.abs() <= 1.0 && v.abs() <= 1.0);
            let back = decode(u, v);
            for (a, b) in back.iter().zip(&w) {
                assert!((a - b).abs() < 1e-14, "{w:?} → ({u}, {v}) → {back:?}");
            }
        }
    }

    /// The cells' solid angles sum to 4π (1e-12 relative) for several n; by the symmetry of
    /// the octahedron the four cells (i, j), (n−1−i, j), (i, n−1−j), (n−1−i, n−1−j) have the
    /// same solid angle; the largest and smallest cells differ (the map is not equal-area)
    /// by less than 3√3, the ratio of the solid angle per map area `1/|p|³` at the
    /// octahedron's face centres (|p| = 1/√3) and at its vertices (|p| = 1).
    #[test]
    fn solid_angles_sum_to_four_pi() {
        for n in [2, 4, 8, 20, 32] {
            let m = OctahedralMap::new(n).unwrap();
            let total: f64 = m.solid_angles.iter().sum();
            assert!(
                (total - 4.0 * PI).abs() < 1e-12 * 4.0 * PI,
                "n {n}: {total}"
            );
            for j in 0..n {
                for i in 0..n {
                    let o = m.solid_angles[j * n + i];
                    for (a, b) in [(n - 1 - i, j), (i, n - 1 - j), (n - 1 - i, n - 1 - j)] {
                        assert!((m.solid_angles[b * n + a] - o).abs() < 1e-14);
                    }
                }
            }
            let (lo, hi) = m
                .solid_angles
                .iter()
                .fold((f64::INFINITY, 0.0f64), |(a, b), v| (a.min(*v), b.max(*v)));
            assert!(hi / lo < 27.0f64.sqrt(), "n {n}: {lo} .. {hi}");
        }
        assert!(OctahedralMap::new(5).is_err());
        assert!(OctahedralMap::new(0).is_err());
    }

    /// The antipode of every cell is a cell whose centre's direction is exactly opposite
    /// (1e−14), and taking it twice gives the cell back.
    #[test]
    fn antipodes_are_opposite_cells() {
        for n in [2, 4, 10, 20] {
            let m = OctahedralMap::new(n).unwrap();
            for (c, &a) in m.antipodes.iter().enumerate() {
                assert_eq!(m.antipodes[a], c, "n {n}: {c} ↔ {a}");
                let (p, q) = (m.directions[c], m.directions[a]);
                for (x, y) in p.iter().zip(&q) {
                    assert!((x + y).abs() < 1e-14, "n {n}: {c} {p:?} vs {a} {q:?}");
                }
            }
        }
    }

    /// The neighbour relation is symmetric with multiplicity (what is sent is gathered) and
    /// neighbours are close on the sphere: the centre of a cell and of each neighbour are
    /// at most three mean cell widths apart.
    #[test]
    fn neighbours_are_symmetric_and_close() {
        for n in [2, 4, 10] {
            let m = OctahedralMap::new(n).unwrap();
            let width = m.mean_solid_angle().sqrt();
            for j in 0..n {
                for i in 0..n {
                    for (a, b) in m.neighbours(i, j) {
                        let forth = m.neighbours(i, j).iter().filter(|x| **x == (a, b)).count();
                        let back = m.neighbours(a, b).iter().filter(|x| **x == (i, j)).count();
                        assert_eq!(forth, back, "n {n}: ({i}, {j}) ↔ ({a}, {b})");
                        let (p, q) = (m.directions[j * n + i], m.directions[b * n + a]);
                        let c = (p[0] * q[0] + p[1] * q[1] + p[2] * q[2]).clamp(-1.0, 1.0);
                        assert!(c.acos() <= 3.0 * width, "n {n}: ({i}, {j}) ↔ ({a}, {b})");
                    }
                }
            }
        }
    }
}
