//! Operator parity under MPI (feature `petsc`; `.ci/run` runs it with OpenMPI): one
//! application of the distributed reduced operator on 1–4 processes, split 2×1×1, 3×1×1,
//! 4×1×1 and 1×2×2, has the same bits as the in-process reference on one box
//! ([`SimulatedRanks`]) — an odd grid (37³), Neumann, Marshak and Dirichlet faces on the
//! boxes' edges.
#![cfg(feature = "petsc")]
#![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)]

use pn_distributed::{Decomposition, SimulatedRanks};
use pn_runtime::problem::Boundary;
use pn_runtime::scenes::{builtin, BuiltinOptions};
use pn_runtime::Layout;
use pn_stencil::{Dim, Staggering};
use std::process::Command;

/// `mpirun -np K pn-mpi-check …` (OpenMPI; as root in a container it needs
/// OMPI_ALLOW_RUN_AS_ROOT, which `.ci/run` sets).
fn mpi_digest(
    ranks: usize,
    scene: &str,
    res: usize,
    order: usize,
    bc: &str,
    procs: &str,
) -> String {
    let out = Command::new("mpirun")
        .args(["--oversubscribe", "-np", &ranks.to_string()])
        .arg(env!("CARGO_BIN_EXE_pn-mpi-check"))
        .args([scene, &res.to_string(), &order.to_string(), bc, procs])
        .output()
        .expect("mpirun (OpenMPI's openmpi-bin) must be installed for the petsc feature's tests");
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success(),
        "{ranks} processes {procs}: {}\n{stdout}",
        String::from_utf8_lossy(&out.stderr)
    );
    let line = stdout
        .lines()
        .find(|l| l.starts_with("digest "))
        .expect("a digest line");
    line.to_string()
}

/// The digest line of the in-process reference on one box, as `pn-mpi-check` prints it.
fn reference_digest(scene: &str, res: usize, order: usize, bc: &str) -> String {
    let opts = BuiltinOptions {
        dim: Some(Dim::Three),
        res: Some(vec![res]),
        ..BuiltinOptions::default()
    };
    let mut p = builtin(scene, &opts).unwrap().problem;
    p.boundary = bc.parse::<Boundary>().unwrap();
    let choice = pn_kernels::pn_kernel(order, Dim::Three, Staggering::Staggered).unwrap();
    let layout = Layout::new(&p.grid, choice.kernel.moments()).unwrap();
    let one = SimulatedRanks::build(
        &p,
        choice.kernel.as_ref(),
        &layout,
        &Decomposition::new(p.grid.res, [1; 3]).unwrap(),
    )
    .unwrap();
    let x: Vec<f64> = (0..layout.len())
        .map(|g| ((g as f64 * 0.618_033_988_75).fract() - 0.5) * (1.0 + (g % 7) as f64))
        .collect();
    let y = one.apply(&x);
    let mut h: u64 = 0xcbf2_9ce4_8422_2325;
    for v in &y {
        for b in v.to_bits().to_le_bytes() {
            h = (h ^ b as u64).wrapping_mul(0x0100_0000_01b3);
        }
    }
    let nonzero = y.iter().filter(|v| **v != 0.0).count();
    format!("digest {h:016x} values {} nonzero {nonzero}", y.len())
}

fn check(scene: &str, res: usize, order: usize, bc: &str, runs: &[(usize, &str)]) {
    let want = reference_digest(scene, res, order, bc);
    for &(ranks, procs) in runs {
        let got = mpi_digest(ranks, scene, res, order, bc, procs);
        assert_eq!(
            got, want,
            "{scene} {res}³ P_{order} {bc}: {ranks} processes {procs}"
        );
    }
}

#[test]
fn odd_grid_neumann_on_1_to_4_processes() {
    check(
        "checkerboard3d",
        37,
        3,
        "neumann",
        &[
            (1, "1x1x1"),
            (2, "2x1x1"),
            (3, "3x1x1"),
            (4, "4x1x1"),
            (4, "1x2x2"),
        ],
    );
}

#[test]
fn marshak_and_dirichlet_faces_on_box_edges() {
    check(
        "pointsource",
        13,
        3,
        "marshak",
        &[(2, "1x2x1"), (4, "4x1x1"), (4, "1x2x2")],
    );
    check(
        "pointsource",
        12,
        1,
        "dirichlet",
        &[(3, "1x1x3"), (4, "2x2x1")],
    );
}
