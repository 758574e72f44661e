# DP_N, the P_N equations with a diffusive correction (docs/pde-text.md): instead of the
# P_N closure L_{N+1}^k = 0, the band N+1 is kept quasi-statically from its own equation,
#   Σ_d Σ_j M^d_{(N+1,k),(N,j)} ∂_d L_N^j + σ_{N+1} L_{N+1}^k = Q_{N+1}^k
# (no band N+2), and substituted into the band-N equations, which gain the diffusion-like
# term −Σ_{d,e} M^d ∂_d (1/σ_{N+1} M^e ∂_e L_N) (Frank, Hauck & Küpper, "Diffusive corrections
# to P_N approximations", 2016, whose time-dependent DP_N drops ∂_t L_{N+1}). At steady state
# this is exactly P_{N+1} with the band N+1 eliminated: the unknowns of P_N, the accuracy of
# P_{N+1}; the discrete stencils agree away from the boundary, where the eliminated face
# unknowns are closed differently (crates/pn-runtime/tests/dpn.rs).
pde dpn
param N = 3
include pn(N + 1)
for m = -(N + 1)..(N + 1): eliminate L(N + 1, m)
