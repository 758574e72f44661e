//! Geometric aggregation: 2×2×2 (2×2 in 2D) neighbouring positions of one moment grid
//! form one coarse unknown.
//!
//! Every unknown of the staggered layout is a moment (its *class*) at an integer position
//! of that moment's grid (`pn_runtime::layout`; [`Geometry`] is built from the layout by
//! [`crate::solver::pn_layout`]). Grouping positions `2c, 2c+1` per axis
//! of the same class gives the tentative (piecewise-constant) prolongation `P`: column
//! `I` is 1 on the members of aggregate `I`. The near-null space of the diffusion-like
//! even-parity operator is locally constant per moment (docs/design.md §5: for P_1 it is CDA),
//! which `P` reproduces exactly. Axes with a single position are not coarsened.

/// Class and grid position of every unknown of one level.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Geometry {
    /// Class (moment) of each unknown.
    pub class: Vec<u32>,
    /// Position of each unknown on its class's grid.
    pub coords: Vec<[u32; 3]>,
}

impl Geometry {
    /// Number of unknowns.
    pub fn len(&self) -> usize {
        self.class.len()
    }

    /// Whether there are no unknowns.
    pub fn is_empty(&self) -> bool {
        self.class.is_empty()
    }
}

/// The aggregation of one level: fine unknown → coarse unknown.
#[derive(Clone, Debug)]
pub struct Aggregation {
    /// Coarse index of each fine unknown.
    pub agg: Vec<u32>,
    /// Fine members of each aggregate, CSR style: `members[ptr[I]..ptr[I+1]]`.
    pub ptr: Vec<usize>,
    /// See `ptr`.
    pub members: Vec<u32>,
    /// Geometry of the coarse unknowns.
    pub coarse: Geometry,
}

impl Aggregation {
    /// Number of coarse unknowns.
    pub fn coarse_len(&self) -> usize {
        self.ptr.len() - 1
    }
}

/// Aggregates `geom` by halving every axis on which some class has more than one position.
pub fn aggregate(geom: &Geometry) -> Aggregation {
    let classes = geom
        .class
        .iter()
        .map(|&c| c as usize + 1)
        .max()
        .unwrap_or(0);
    // Extent per class and axis.
    let mut ext = vec![[0u32; 3]; classes];
    for (&c, x) in geom.class.iter().zip(&geom.coords) {
        for d in 0..3 {
            ext[c as usize][d] = ext[c as usize][d].max(x[d] + 1);
        }
    }
    // Coarsen an axis only where it has more than one position (2D grids keep z).
    let halve: [bool; 3] = std::array::from_fn(|d| ext.iter().any(|e| e[d] > 1));
    let coarse_of = |x: &[u32; 3]| -> [u32; 3] {
        std::array::from_fn(|d| if halve[d] { x[d] / 2 } else { x[d] })
    };
    let cext: Vec<[u32; 3]> = ext
        .iter()
        .map(|e| coarse_of(&e.map(|v| v.max(1) - 1)).map(|v| v + 1))
        .collect();
    // Dense numbering of the coarse boxes; positions nobody occupies are compacted away.
    let mut box_offset = vec![0usize; classes + 1];
    for c in 0..classes {
        box_offset[c + 1] = box_offset[c] + cext[c].iter().map(|&v| v as usize).product::<usize>();
    }
    let slot = |c: u32, x: [u32; 3]| {
        let e = cext[c as usize];
        box_offset[c as usize]
            + ((x[0] as usize * e[1] as usize) + x[1] as usize) * e[2] as usize
            + x[2] as usize
    };
    let mut id = vec![u32::MAX; box_offset[classes]];
    let mut coarse = Geometry {
        class: Vec::new(),
        coords: Vec::new(),
    };
    let mut agg = Vec::with_capacity(geom.len());
    for (&c, x) in geom.class.iter().zip(&geom.coords) {
        let cx = coarse_of(x);
        let s = slot(c, cx);
        if id[s] == u32::MAX {
            id[s] = coarse.class.len() as u32;
            coarse.class.push(c);
            coarse.coords.push(cx);
        }
        agg.push(id[s]);
    }
    // Members by counting sort.
    let nc = coarse.class.len();
    let mut ptr = vec![0usize; nc + 1];
    for &a in &agg {
        ptr[a as usize + 1] += 1;
    }
    for i in 0..nc {
        ptr[i + 1] += ptr[i];
    }
    let mut fill = ptr.clone();
    let mut members = vec![0u32; agg.len()];
    for (i, &a) in agg.iter().enumerate() {
        members[fill[a as usize]] = i as u32;
        fill[a as usize] += 1;
    }
    Aggregation {
        agg,
        ptr,
        members,
        coarse,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn aggregates_per_class_and_keeps_flat_axes() {
        // Class 0 on a 3×2×1 grid, class 1 on a 2×2×1 grid (2D: z is never halved).
        let mut g = Geometry {
            class: Vec::new(),
            coords: Vec::new(),
        };
        for (c, (nx, ny)) in [(0u32, (3u32, 2u32)), (1, (2, 2))] {
            for i in 0..nx {
                for j in 0..ny {
                    g.class.push(c);
                    g.coords.push([i, j, 0]);
                }
            }
        }
        let a = aggregate(&g);
        // Class 0: x {0,1},{2} × y {0,1} → 2 aggregates; class 1: 1 aggregate.
        assert_eq!(a.coarse_len(), 3);
        assert_eq!(a.agg[..6], [0, 0, 0, 0, 1, 1]);
        assert_eq!(a.agg[6..], [2, 2, 2, 2]);
        assert_eq!(a.coarse.coords, vec![[0, 0, 0], [1, 0, 0], [0, 0, 0]]);
        assert_eq!(&a.members[a.ptr[1]..a.ptr[2]], &[4, 5]);
        // Never merges classes.
        for (i, &c) in a.agg.iter().enumerate() {
            assert_eq!(a.coarse.class[c as usize], g.class[i]);
        }
    }
}
