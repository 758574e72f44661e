# Classical diffusion (CDA), docs/design.md §2.2:
#   −∇·(1/(3σ_tr) ∇φ) + σ_a φ = Q_0^0,   σ_tr = σ_t − σ_s λ_1 p_1.
# Discretized, D is formed from σ_t, σ_s and λ_1 p_1 at the half positions between
# neighbouring unknowns: the same stencil as the built-in `pn solve --method cda`.
pde cda
unknown phi = L(0, 0)
let D = 1/(3*(sigma_t - sigma_s*phase(1)))
equation phi: -div(D*grad(phi)) + sigma_a*phi = Q(0, 0)
# Marshak vacuum boundary (`--bc marshak`), the Robin condition of diffusion: zero incoming
# partial current, φ/4 − J·n/2 = 0 with J = −D∇φ, i.e. φ/2 + D ∂_nφ = 0 (∂_n outward).
boundary marshak phi: 1/2*phi + D*dn(phi) = 0
