pde loops
param a = 0.5
let D(x) = 1/(3*x)
unknown u = L(0,0)
unknown v at (1, 0, 0)
for k = 0..1: add u: 0*sum(j = 0..k, phase(j)*u)
equation u: -div(D(sigma_t)*grad(u)) + sigma_a*u - a*dx(v) = Q(0,0)
equation v: v - dx(u) = 0
boundary marshak u: u + 2/3*dn(u) = 0
boundary marshak v: v = 0
eliminate v
