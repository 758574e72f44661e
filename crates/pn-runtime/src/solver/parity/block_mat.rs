//! The storage of the parity blocks `B` and `C̃` ([`super::split::Split`]).

/// CSR with 32-bit column indices: the blocks are read once per application of `S`, and the
/// products are memory-bound, so 12 instead of 16 bytes per entry saves a quarter of the
/// traffic (and 0.9 GB at 80³ P_5). Row pointers stay `usize` (entries may exceed 2³²).
pub type BlockMat = sprs::CsMatI<f64, u32, usize>;
