#!/usr/bin/env python3
"""Analog Monte Carlo reference for POP's radial grids (docs/pop-design.md, "Point lights").

The cube [-1/2, 1/2]^3 (the `box` medium of docs/pop-cube.toml), sigma_t = 4, albedo 1,
HG g = 0.7, lit by a point light of power 4 pi at (0, 0, -2). Prints the integral of the
*collided* fluence over the cube, int phi_c dV = Phi * E[path length after the first
collision, inside the cube, per emitted photon], and the once-scattered power. Photons are
emitted uniformly into the cone about +z that holds the cube (half-angle atan(sqrt(1/2) /
1.5)) and weighted by the cone's share of the sphere. POP's value of the same integral is
sum_c A_0,c V_c over its radial grid's cells.

    python3 scripts/pop-point-mc.py [photons] [seed]

With `ball` first: scenes/sphere.toml's ball (radius 0.8, sigma_t = 5, albedo 0.8, isotropic
phase) lit by a point light of power 20 at its centre; prints the once-scattered power, and
of it the power absorbed after further collisions and the power that escapes.

    python3 scripts/pop-point-mc.py ball [photons] [seed]
"""
import math
import random
import sys

SIGMA, G = 4.0, 0.7
LIGHT = (0.0, 0.0, -2.0)
POWER = 4.0 * math.pi


def hg_dir(d, g, rng):
    """A direction scattered from unit d by HG(g) (Pharr et al.'s sampling)."""
    u = rng.random()
    if abs(g) < 1e-6:
        cos = 1.0 - 2.0 * u
    else:
        s = (1.0 - g * g) / (1.0 + g - 2.0 * g * u)
        cos = (1.0 + g * g - s * s) / (2.0 * g)
    sin = math.sqrt(max(0.0, 1.0 - cos * cos))
    phi = 2.0 * math.pi * rng.random()
    a = (1.0, 0.0, 0.0) if abs(d[0]) < 0.9 else (0.0, 1.0, 0.0)
    t = (d[1] * a[2] - d[2] * a[1], d[2] * a[0] - d[0] * a[2], d[0] * a[1] - d[1] * a[0])
    n = math.sqrt(sum(c * c for c in t))
    t = tuple(c / n for c in t)
    b = (d[1] * t[2] - d[2] * t[1], d[2] * t[0] - d[0] * t[2], d[0] * t[1] - d[1] * t[0])
    return tuple(
        sin * math.cos(phi) * t[q] + sin * math.sin(phi) * b[q] + cos * d[q] for q in range(3)
    )


def slab(x, w):
    """The interval of the ray x + t w inside the cube (t0 > t1 where it misses)."""
    t0, t1 = -math.inf, math.inf
    for q in range(3):
        if w[q] == 0.0:
            if abs(x[q]) > 0.5:
                return 1.0, 0.0
            continue
        a, b = (-0.5 - x[q]) / w[q], (0.5 - x[q]) / w[q]
        t0, t1 = max(t0, min(a, b)), min(t1, max(a, b))
    return t0, t1


def isotropic(rng):
    """A uniformly distributed unit vector."""
    z = 1.0 - 2.0 * rng.random()
    r = math.sqrt(max(0.0, 1.0 - z * z))
    p = 2.0 * math.pi * rng.random()
    return (r * math.cos(p), r * math.sin(p), z)


def ball(n, rng):
    """The light at the centre of scenes/sphere.toml's ball: collided absorbed and escaping."""
    radius, sigma, albedo, power = 0.8, 5.0, 0.8, 20.0
    once, absorbed = 0, 0
    for _ in range(n):
        s = -math.log(1.0 - rng.random()) / sigma
        if s > radius or rng.random() >= albedo:
            continue  # uncollided, or absorbed at the first collision
        once += 1
        x = tuple(s * c for c in isotropic(rng))
        w = isotropic(rng)
        while True:
            step = -math.log(1.0 - rng.random()) / sigma
            b = sum(x[q] * w[q] for q in range(3))
            c = sum(v * v for v in x) - radius * radius
            if step >= -b + math.sqrt(max(0.0, b * b - c)):
                break  # escapes
            x = tuple(x[q] + step * w[q] for q in range(3))
            if rng.random() >= albedo:
                absorbed += 1
                break
            w = isotropic(rng)
    exact = power * albedo * (1.0 - math.exp(-sigma * radius))
    print(f"photons {n}: once-scattered power {power * once / n:.4f} (exact {exact:.4f})")
    print(f"absorbed after further collisions {power * absorbed / n:.4f}, "
          f"escaping {power * (once - absorbed) / n:.4f}")


def main():
    args = sys.argv[1:]
    is_ball = bool(args) and args[0] == "ball"
    if is_ball:
        args = args[1:]
    n = int(args[0]) if args else 200000
    rng = random.Random(int(args[1]) if len(args) > 1 else 1)
    if is_ball:
        ball(n, rng)
        return
    cos_max = math.cos(math.atan(math.sqrt(0.5) / 1.5))
    weight = POWER * (1.0 - cos_max) / 2.0  # the cone's share of the sphere, times Phi
    total, total2, collided = 0.0, 0.0, 0
    for _ in range(n):
        mu = cos_max + (1.0 - cos_max) * rng.random()
        phi = 2.0 * math.pi * rng.random()
        s = math.sqrt(max(0.0, 1.0 - mu * mu))
        w = (s * math.cos(phi), s * math.sin(phi), mu)
        t0, t1 = slab(LIGHT, w)
        path = 0.0
        if t0 < t1:
            depth = -math.log(1.0 - rng.random()) / SIGMA
            if depth < t1 - t0:
                collided += 1
                x = tuple(LIGHT[q] + (t0 + depth) * w[q] for q in range(3))
                w = hg_dir(w, G, rng)
                while True:
                    step = -math.log(1.0 - rng.random()) / SIGMA
                    t = slab(x, w)[1]
                    if step >= t:
                        path += t
                        break
                    path += step
                    x = tuple(x[q] + step * w[q] for q in range(3))
                    w = hg_dir(w, G, rng)
        total += path
        total2 += path * path
    mean = total / n
    err = math.sqrt(max(0.0, total2 / n - mean * mean) / n)
    print(f"photons {n}: once-scattered power {weight * collided / n:.5f}")
    print(f"int phi_collided dV = {weight * mean:.5f} +- {weight * err:.5f}")


if __name__ == "__main__":
    main()
