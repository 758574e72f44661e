//! Finding the parity classes from the matrix alone.
//!
//! The off-diagonal couplings of a staggered P_N matrix form a bipartite graph (even-l ↔
//! odd-l, docs/design.md §5), so a breadth-first 2-colouring of each connected component
//! recovers the two classes up to a swap per component. Either class can be eliminated as
//! long as its diagonal is invertible; per component we eliminate the class whose smallest
//! |diagonal| is larger. For P_N that is the odd class: its diagonal is σ_t, while the even
//! one has σ_t − σ_s λ_l p_l (σ_a for l = 0, zero in a purely scattering region), and it
//! leaves the diffusion-like even system.

use super::split::ParityError;
use sprs::CsMat;
use std::collections::VecDeque;

/// The mask of the classes to keep (`true`) and eliminate (`false`), or why the
/// off-diagonal coupling graph is not bipartite.
pub fn detect_mask(a: &CsMat<f64>) -> Result<Vec<bool>, ParityError> {
    let n = a.rows();
    if a.cols() != n {
        return Err(ParityError::NotSquare {
            rows: n,
            cols: a.cols(),
        });
    }
    let csr = if a.is_csr() {
        std::borrow::Cow::Borrowed(a)
    } else {
        std::borrow::Cow::Owned(a.to_csr())
    };
    // Undirected graph: the pattern of A plus that of Aᵀ, without the diagonal.
    let t = csr.transpose_view().to_csr();
    let mut diag = vec![0.0f64; n];
    for (i, row) in csr.outer_iterator().enumerate() {
        for (j, &v) in row.iter() {
            if i == j {
                diag[i] += v;
            }
        }
    }
    let (p1, i1, v1) = (
        csr.indptr().raw_storage().to_vec(),
        csr.indices(),
        csr.data(),
    );
    let (p2, i2, v2) = (t.indptr().raw_storage().to_vec(), t.indices(), t.data());
    let mut color = vec![u8::MAX; n];
    let mut keep = vec![false; n];
    let mut queue = VecDeque::new();
    let mut component = Vec::new();
    for start in 0..n {
        if color[start] != u8::MAX {
            continue;
        }
        color[start] = 0;
        queue.push_back(start);
        component.clear();
        while let Some(i) = queue.pop_front() {
            component.push(i);
            let neighbours = (p1[i]..p1[i + 1])
                .map(|k| (i1[k], v1[k]))
                .chain((p2[i]..p2[i + 1]).map(|k| (i2[k], v2[k])));
            for (j, v) in neighbours {
                if j == i || v == 0.0 {
                    continue;
                }
                if color[j] == u8::MAX {
                    color[j] = 1 - color[i];
                    queue.push_back(j);
                } else if color[j] == color[i] {
                    return Err(ParityError::SameParityCoupling {
                        row: i,
                        col: j,
                        parity: "the same class of a 2-colouring",
                        value: v,
                    });
                }
            }
        }
        // Eliminate the class with the larger minimum |diagonal| (keep the other).
        let mut min = [f64::INFINITY; 2];
        for &i in &component {
            let c = color[i] as usize;
            min[c] = min[c].min(diag[i].abs());
        }
        let eliminate = if min[0] > min[1] { 0 } else { 1 };
        for &i in &component {
            keep[i] = color[i] as usize != eliminate;
        }
    }
    Ok(keep)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn recovers_classes_and_rejects_odd_cycles() {
        // e0 o0 e1 with diag(e) = [0, 0.5] (pure scatterer at e0), diag(o) = 2.
        let a = CsMat::new(
            (3, 3),
            vec![0, 2, 5, 7],
            vec![0, 1, 0, 1, 2, 1, 2],
            vec![0.0, 1.0, -1.0, 2.0, 1.0, -1.0, 0.5],
        );
        assert_eq!(detect_mask(&a).unwrap(), vec![true, false, true]);
        // A triangle of couplings cannot be 2-coloured.
        let tri = CsMat::new(
            (3, 3),
            vec![0, 2, 4, 6],
            vec![0, 1, 1, 2, 0, 2],
            vec![1.0, 1.0, 1.0, 1.0, 1.0, 1.0],
        );
        assert!(matches!(
            detect_mask(&tri),
            Err(ParityError::SameParityCoupling { .. })
        ));
    }
}
