#!/usr/bin/env python3
"""Coloured render with an achromatic sigma_t against three grey renders of its channels.

Measures what the warm start across colour channels buys (docs/inputs.md, "Sharing between
channels"): `pn render scenes/rgbcloud-achromatic.toml` against the three grey scenes that
have the same medium, light and settings with one channel's albedo and irradiance each,
run alternately for several rounds so that both see the same machine load. Prints one line
per round (CG iterations, summed solve seconds, wall seconds, ratios) and the medians.

Usage: scripts/bench-rgb-warm-start.py [--pn target/release/pn] [--rounds 9] [--work DIR]
"""

import argparse
import json
import re
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
SCENE = ROOT / "scenes" / "rgbcloud-achromatic.toml"


def grey_scene(text: str, channel: int) -> str:
    """The scene text with the albedo and irradiance triples replaced by one channel's value."""

    def pick(match: re.Match) -> str:
        values = [v.strip() for v in match.group(2).split(",")]
        return f"{match.group(1)}{values[channel]}"

    out, n = re.subn(r"^(albedo\s*=\s*)\[([^\]]*)\]", pick, text, flags=re.M)
    out, m = re.subn(r"^(irradiance\s*=\s*)\[([^\]]*)\]", pick, out, flags=re.M)
    if n != 1 or m != 1:
        sys.exit(f"{SCENE}: expected one albedo and one irradiance triple")
    return out


def render(pn: str, scene: Path, out: Path) -> dict:
    start = time.perf_counter()
    subprocess.run([pn, "render", str(scene), "--out", str(out)], check=True,
                   stdout=subprocess.DEVNULL)
    wall = time.perf_counter() - start
    report = json.loads((out / "report.json").read_text())
    channels = report.get("channels") or [report]
    iterations = sum(c["solver"]["iterations"] for c in channels if c.get("solver"))
    solve = sum(c["seconds"]["solve"] for c in channels if c.get("seconds"))
    return {"iterations": iterations, "solve": solve, "wall": wall}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--pn", default=str(ROOT / "target" / "release" / "pn"))
    parser.add_argument("--rounds", type=int, default=9)
    parser.add_argument("--work", type=Path, default=None,
                        help="directory for the scenes and outputs (default: a temporary one)")
    args = parser.parse_args()
    work = args.work or Path(tempfile.mkdtemp(prefix="pn-warm-start-"))
    work.mkdir(parents=True, exist_ok=True)
    text = SCENE.read_text()
    # The density is generated from the [medium] seed, so the scene files need no other paths.
    greys = []
    for c in range(3):
        path = work / f"grey-{c}.toml"
        path.write_text(grey_scene(text, c))
        greys.append(path)
    ratios = {"iterations": [], "solve": [], "wall": []}
    print("round  rgb: iters solve_s wall_s | 3 grey: iters solve_s wall_s | ratios")
    for r in range(args.rounds):
        rgb = render(args.pn, SCENE, work / "rgb")
        grey = {"iterations": 0, "solve": 0.0, "wall": 0.0}
        for c, path in enumerate(greys):
            g = render(args.pn, path, work / f"grey-{c}")
            for k in grey:
                grey[k] += g[k]
        for k in ratios:
            ratios[k].append(rgb[k] / grey[k])
        print(f"{r:5d}  {rgb['iterations']:5d} {rgb['solve']:7.2f} {rgb['wall']:6.2f} | "
              f"{grey['iterations']:5d} {grey['solve']:7.2f} {grey['wall']:6.2f} | "
              f"{ratios['iterations'][-1]:.3f} {ratios['solve'][-1]:.3f} "
              f"{ratios['wall'][-1]:.3f}")
    print("median ratios (coloured / three grey): "
          + ", ".join(f"{k} {statistics.median(v):.3f}" for k, v in ratios.items()))


if __name__ == "__main__":
    main()
