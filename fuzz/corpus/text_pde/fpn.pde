# Filtered P_N (docs/pde-text.md): the derived P_N equations with a filter term added to the
# collision of every moment with l > 0,
#     σ_f f(l/(N+1)) L_l^m,
# as StaRMAP's exponential filter σ(η) = ε^(η^p) (f = −ln σ / −ln ε = η^p), applied once per
# time step ('full' position) and taken to steady state. σ_f is set so that band N is damped
# at the rate f_eff (StaRMAP's "filter effective opacity"): the added term is f_eff (l/N)^p,
# which vanishes for every fixed l as N grows, so filtered P_N converges like P_N.
# Defaults: StaRMAP's checkerboard example (starmap_2d_ex_lattice_filter.m: f_eff = 5, p = 2).
pde fpn
param N = 3
param f_eff = 5
param p = 2
include pn(N)
let eta(l) = l/(N + 1)
let f(x) = x^p
let sigma_f = f_eff/f(eta(N))
for l = 1..N, m = -l..l: add L(l, m): sigma_f*f(eta(l))*L(l, m)
