# SP_1, the simplified P_1 equation (docs/pde-text.md): with σ_n = σ_t − σ_s λ_n p_n,
#   −∇·(1/(3σ_1) ∇φ_0) + σ_0 φ_0 = Q_0^0.
# Algebraically CDA (σ_0 = σ_a for a normalised phase function); written in the SP_N form
# to check that SP_1 = P_1 = CDA.
pde sp1
let sigma(n) = sigma_t - sigma_s*phase(n)
unknown phi0 = L(0, 0)
equation phi0: -div(1/(3*sigma(1)) * grad(phi0)) + sigma(0)*phi0 = Q(0, 0)
# Marshak vacuum boundary (`--bc marshak`): the P_1 condition ∫_{in} P_1 ψ dμ = 0, i.e.
# φ_0/2 + φ_1^n = 0 with φ_1^n = −∂_nφ_0/(3σ_1) (zero incoming partial current, J·n = φ_0/2).
boundary marshak phi0: 1/2*phi0 + 1/(3*sigma(1))*dn(phi0) = 0
