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
