#!/usr/bin/env python3
"""Analog Monte Carlo reference for POP's cube (docs/pop-design.md, docs/pop-cube.toml).

The unit cube [0, 1]^3, sigma_t = 4, albedo 1, HG g = 0.7, lit by a directional light of
irradiance 1 travelling along -y through the face y = 1. Prints the integral of the
*collided* fluence over the cube, int phi_c dV = E * A * E[path length after the first
collision, inside the cube] (A = 1, so it is the mean collided path length per entering
photon), and the once-scattered power 1 - e^{-4}. POP's value of the same integral is
h * (injected/2 + sum_m in_flight_after(m)) from its report.json (A_0 is the fluence).

    python3 scripts/pop-cube-mc.py [photons] [seed]
"""
import math
import random
import sys

SIGMA, G = 4.0, 0.7


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
    # Frame around d.
    a = (1.0, 0.0, 0.0) if abs(d[0]) < 0.9 else (0.0, 1.0, 0.0)
    t = (d[1] * a[2] - d[2] * a[1], d[2] * a[0] - d[0] * a[2], d[0] * a[1] - d[1] * a[0])
    n = math.sqrt(sum(c * c for c in t))
    t = tuple(c / n for c in t)
    b = (d[1] * t[2] - d[2] * t[1], d[2] * t[0] - d[0] * t[2], d[0] * t[1] - d[1] * t[0])
    return tuple(
        sin * math.cos(phi) * t[q] + sin * math.sin(phi) * b[q] + cos * d[q] for q in range(3)
    )


def exit_distance(x, w):
    """Distance from x (inside the unit cube) along w to the cube's surface."""
    t = math.inf
    for q in range(3):
        if w[q] > 0:
            t = min(t, (1.0 - x[q]) / w[q])
        elif w[q] < 0:
            t = min(t, -x[q] / w[q])
    return t


def main():
    n = int(sys.argv[1]) if len(sys.argv) > 1 else 200000
    rng = random.Random(int(sys.argv[2]) if len(sys.argv) > 2 else 1)
    total, total2, collided = 0.0, 0.0, 0
    for _ in range(n):
        depth = -math.log(1.0 - rng.random()) / SIGMA
        path = 0.0
        if depth < 1.0:
            collided += 1
            x = (rng.random(), 1.0 - depth, rng.random())
            w = hg_dir((0.0, -1.0, 0.0), G, rng)
            while True:
                s = -math.log(1.0 - rng.random()) / SIGMA
                t = exit_distance(x, w)
                if s >= t:
                    path += t
                    break
                path += s
                x = tuple(x[q] + s * w[q] for q in range(3))
                w = hg_dir(w, G, rng)
        total += path
        total2 += path * path
    mean = total / n
    err = math.sqrt(max(0.0, total2 / n - mean * mean) / n)
    print(f"photons {n}: once-scattered power {collided / n:.5f} (exact {1 - math.exp(-SIGMA):.5f})")
    print(f"int phi_collided dV = {mean:.5f} +- {err:.5f}")


if __name__ == "__main__":
    main()
