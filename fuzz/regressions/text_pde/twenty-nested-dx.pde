unknown u = L(0,0)
equation u: -lap(u) + sigma_a*u + 0.001*dx(dx(dx(dx(dx(dx(dx(dx(dx(dx(dx(dx(dx(dx(dx(dx(dx(dx(dx(dx(u)))))))))))))))))))) = Q(0,0)
