# SP_3, the simplified P_3 equations as two coupled diffusion equations (docs/pde-text.md).
# From the slab P_3 moment equations
#   (n+1)/(2n+1) φ_{n+1}' + n/(2n+1) φ_{n−1}' + σ_n φ_n = Q δ_{n0},  n = 0..3,  φ_4 = 0,
# σ_n = σ_t − σ_s λ_n p_n: the odd equations give φ_1 = −(φ_0 + 2φ_2)'/(3σ_1) and
# φ_3 = −3φ_2'/(7σ_3); substituted into the even ones, with d/dx → ∇:
#   −∇·(1/(3σ_1) ∇(φ_0 + 2φ_2)) + σ_0 φ_0                  = Q_0^0
#   −∇·(9/(35σ_3) ∇φ_2) + σ_2 φ_2 − (2/5) σ_0 φ_0          = −(2/5) Q_0^0
# (the second uses φ_1' = Q − σ_0 φ_0 from n = 0). φ_0 is the fluence; φ_2 is an auxiliary
# unknown, not a spherical-harmonic moment. Only the isotropic source moment enters.
pde sp3
let sigma(n) = sigma_t - sigma_s*phase(n)
unknown phi0 = L(0, 0)
unknown phi2
equation phi0: -div(1/(3*sigma(1)) * grad(phi0 + 2*phi2)) + sigma(0)*phi0 = Q(0, 0)
equation phi2: -div(9/(35*sigma(3)) * grad(phi2)) + sigma(2)*phi2 - 2/5*sigma(0)*phi0 = -2/5*Q(0, 0)
# Marshak vacuum boundary (`--bc marshak`; docs/pde-text.md "Boundary conditions"). With
# outward normal n and ∂_n = n·∇ (at x = 0: n = −e_x, incoming μ = ω·e_x > 0), the slab P_3
# Marshak conditions ∫_{in} P_1 ψ dμ = ∫_{in} P_3 ψ dμ = 0, ψ = Σ (2n+1)/(4π) φ_n P_n(μ), take
# the half-range integrals ∫_0^1 P_1 P_n dμ = 1/2, 1/3, 1/8, 0 and ∫_0^1 P_3 P_n dμ =
# −1/8, 0, 1/8, 1/7 (n = 0..3):
#   φ_0/2 + φ_1^n + 5φ_2/8 = 0,   −φ_0/8 + 5φ_2/8 + φ_3^n = 0,
# with φ_k^n = φ_k·(n·e_x)^k the odd moments along n (the same two conditions on both faces).
# The odd equations above give φ_1^n = −∂_n(φ_0 + 2φ_2)/(3σ_1) and φ_3^n = −3∂_nφ_2/(7σ_3):
#   1/2 φ_0 + 5/8 φ_2 + 1/(3σ_1) ∂_n(φ_0 + 2φ_2) = 0,
#   −1/8 φ_0 + 5/8 φ_2 + 3/(7σ_3) ∂_nφ_2 = 0
# (the standard SP_3 Marshak conditions of Brantley & Larsen 2000, written in the Legendre
# moments φ_0, φ_2; the first is the zero incoming partial current, J·n = φ_0/2 + 5φ_2/8). In a slab they are exactly P_3's Marshak conditions,
# so SP_3 + Marshak is P_3 + Marshak there (crates/pn-runtime/tests/marshak_sp.rs).
boundary marshak phi0: 1/2*phi0 + 5/8*phi2 + 1/(3*sigma(1))*dn(phi0 + 2*phi2) = 0
boundary marshak phi2: -1/8*phi0 + 5/8*phi2 + 3/(7*sigma(3))*dn(phi2) = 0
