//! Flux-limited diffusion (Koerner et al. 2014).
