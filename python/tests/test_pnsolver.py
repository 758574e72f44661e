"""The Python package against the `pn` binary and its own promises.

Run from the repository root after `pip install .[test]` and `cargo build --release --bin pn`:
`python -m pytest python/tests`. The `pn` binary is `$PN_BIN`, else target/release/pn; a
missing binary fails the comparison test (it does not skip).
"""

import json
import os
import pathlib
import subprocess
import sys
import threading
import time

import numpy as np
import pytest

import pnsolver

ROOT = pathlib.Path(__file__).resolve().parents[2]
PN = os.environ.get("PN_BIN", str(ROOT / "target" / "release" / "pn"))

# A small scene: a 12³ box of density 1 in a 16³ array, P_3 on a 10³ solve grid.
SETTINGS = {
    "medium": {"bbox_min": [-1.0, -1.0, -1.0], "bbox_max": [1.0, 1.0, 1.0],
               "sigma_t_scale": 8.0, "albedo": 0.9},
    "phase": {"kind": "hg", "g": 0.3},
    "light": [{"kind": "directional", "direction": [0.3, -1.0, -0.2], "irradiance": 1.0}],
    "camera": {"position": [0.0, 0.0, 4.0], "target": [0.0, 0.0, 0.0], "up": [0.0, 1.0, 0.0],
               "fov": 40.0, "width": 16, "height": 16},
    "solve": {"method": "pn", "order": 3, "resolution": [10, 10, 10], "tolerance": 1e-8},
}


def density():
    d = np.zeros((16, 16, 16))
    d[2:14, 3:15, 1:13] = 1.0
    d[5, 7, 9] = 3.0  # asymmetric, so that a transposed axis would show
    return d


def test_the_same_scene_gives_the_same_moments_as_pn_render(tmp_path):
    """Python's solution equals `pn render --save-moments` on the same scene file, with one
    thread each (the same arithmetic in the same order: exact, bound 1e-12)."""
    assert os.path.exists(PN), f"no pn binary at {PN}: cargo build --release --bin pn"
    out = tmp_path / "render"
    subprocess.run([PN, "render", "sphere", "--threads", "1", "--save-moments",
                    "--out", str(out)], check=True, capture_output=True)
    cli = np.load(out / "moments.npy")
    scene = pnsolver.Scene.load("sphere")
    py = pnsolver.render(scene, threads=1)
    assert py["moments"].shape == cli.shape
    assert np.max(np.abs(py["moments"] - cli)) <= 1e-12 * np.max(np.abs(cli))
    report = json.loads((out / "report.json").read_text())
    assert py["report"]["mean_radiance"] == report["mean_radiance"]
    assert py["image"].shape == (64, 64) and py["image"].dtype == np.float32
    # solve() gives the same solution without the image.
    sol = pnsolver.solve(scene, threads=1)
    assert "image" not in sol
    np.testing.assert_array_equal(sol["moments"], py["moments"])
    np.testing.assert_allclose(sol["fluence"], np.sqrt(4 * np.pi) * py["moments"][..., 0])
    assert list(sol["grid_res"]) == list(cli.shape[:3])


def test_a_density_array_equals_the_same_data_through_an_npy_file(tmp_path):
    d = density()
    np.save(tmp_path / "d.npy", d)
    a = np.full(d.shape, 0.8)
    a[:8] = 0.95
    np.save(tmp_path / "a.npy", a)
    toml = f"""
[medium]
kind = "grid"
file = "d.npy"
albedo_file = "a.npy"
bbox_min = [-1.0, -1.0, -1.0]
bbox_max = [1.0, 1.0, 1.0]
sigma_t_scale = 8.0
[phase]
kind = "hg"
g = 0.3
[[light]]
kind = "directional"
direction = [0.3, -1.0, -0.2]
irradiance = 1.0
[camera]
position = [0.0, 0.0, 4.0]
target = [0.0, 0.0, 0.0]
up = [0.0, 1.0, 0.0]
fov = 40.0
width = 16
height = 16
[solve]
method = "pn"
order = 3
resolution = [10, 10, 10]
tolerance = 1e-8
"""
    (tmp_path / "s.toml").write_text(toml)
    from_file = pnsolver.render(pnsolver.Scene.load(str(tmp_path / "s.toml")), threads=1)
    settings = json.loads(json.dumps(SETTINGS))
    del settings["medium"]["albedo"]
    from_array = pnsolver.render(pnsolver.Scene(settings, density=d, albedo=a), threads=1)
    np.testing.assert_array_equal(from_array["image"], from_file["image"])
    np.testing.assert_array_equal(from_array["moments"], from_file["moments"])
    # float32 input reads the same values.
    f32 = pnsolver.render(pnsolver.Scene(settings, density=d.astype(np.float32),
                                         albedo=a.astype(np.float32)), threads=1)
    np.testing.assert_array_equal(f32["image"], from_file["image"])


def test_coloured_scenes_give_rgb_images_and_one_solution_per_channel():
    settings = json.loads(json.dumps(SETTINGS))
    settings["medium"]["albedo"] = [0.95, 0.8, 0.6]
    scene = pnsolver.Scene(settings, density=density())
    assert scene.coloured
    out = pnsolver.render(scene, threads=1)
    assert out["image"].shape == (16, 16, 3)
    means = out["image"].reshape(-1, 3).mean(axis=0)
    assert means[0] > means[1] > means[2] > 0
    with pytest.raises(ValueError, match="one solution per channel"):
        pnsolver.solve(scene)
    green = pnsolver.render(scene.channel(1), threads=1)
    # The coloured render starts green's iteration from red's solution (same σ_t), the
    # channel alone from zero: two solves to the relative residual 1e-8, equal to about
    # that, not bit for bit (1e-7 relative was seen in a few pixels).
    np.testing.assert_allclose(green["image"], out["image"][..., 1], rtol=1e-6, atol=1e-12)


@pytest.mark.parametrize("make, message", [
    (lambda: np.zeros((4, 4, 4), dtype=np.int64), "float64 or float32"),
    (lambda: np.zeros((4, 4)), r"shape \(nx, ny, nz\)"),
    (lambda: np.full((4, 4, 4), np.nan), "finite and non-negative"),
    (lambda: -np.ones((4, 4, 4)), "finite and non-negative"),
    (lambda: [[[1.0]]], "numpy array"),
])
def test_malformed_arrays_raise_value_error(make, message):
    with pytest.raises(ValueError, match=message):
        pnsolver.Scene(SETTINGS, density=make())


@pytest.mark.parametrize("change, message", [
    (lambda s: s["solve"].update(method="magic"), "magic"),
    (lambda s: s["solve"].update(order=0), "order must lie"),
    (lambda s: s["medium"].update(albedo=1.5), r"\[0, 1\]"),
    (lambda s: s["medium"].update(file="x.vol"), "does not apply to a density array"),
    (lambda s: s["medium"].pop("bbox_min"), "needs medium.bbox_min"),
    (lambda s: s.update(zoom=2), "zoom"),
])
def test_bad_settings_raise_value_error_and_the_interpreter_goes_on(change, message):
    settings = json.loads(json.dumps(SETTINGS))
    change(settings)
    with pytest.raises(ValueError, match=message):
        pnsolver.Scene(settings, density=density())
    # Still usable afterwards.
    assert pnsolver.solve(pnsolver.Scene(SETTINGS, density=density()))["moments"] is not None


def test_unknown_builtin_and_bad_channel():
    with pytest.raises(ValueError, match="built-in"):
        pnsolver.Scene.load("no-such-scene")
    with pytest.raises(ValueError, match="channel must be"):
        pnsolver.Scene.load("sphere").channel(3)


def test_the_interpreter_lock_is_released_during_a_solve():
    """While a solve runs in a thread, the main thread keeps running Python code: with the
    lock held it would not get a single step until the solve ends."""
    scene = pnsolver.Scene.load("sphere")
    result = {}
    t = threading.Thread(target=lambda: result.update(pnsolver.solve(scene, threads=1)))
    t0 = time.perf_counter()
    t.start()
    ticks = 0
    while t.is_alive():
        ticks += 1
        time.sleep(0.001)
    elapsed = time.perf_counter() - t0
    t.join()
    assert result["moments"] is not None
    # A tick takes ≥ 1 ms; the solve takes ≳ 0.3 s: at least a few dozen ticks.
    assert elapsed > 0.1 and ticks >= 20, (elapsed, ticks)


def test_the_example_runs_and_writes_its_figure(tmp_path):
    png = tmp_path / "slice.png"
    r = subprocess.run([sys.executable, str(ROOT / "python" / "examples" / "solve_numpy_cloud.py"),
                        str(png)], capture_output=True, text=True, check=True)
    assert "iterations" in r.stdout and png.stat().st_size > 1000
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_ctrl_c_interrupts_a_solve_and_the_interpreter_goes_on():
    """KeyboardInterrupt (here from _thread.interrupt_main, as Ctrl-C would) ends the call
    within a fraction of the solve's time; the next call works."""
    import _thread
    import signal
    # interrupt_main() does nothing where SIGINT is ignored (a shell's background job):
    # install Python's own handler for this test.
    previous = signal.signal(signal.SIGINT, signal.default_int_handler)
    try:
        _interrupt_a_solve(_thread)
    finally:
        signal.signal(signal.SIGINT, previous)


def _interrupt_a_solve(_thread):
    scene = pnsolver.Scene.load("sphere")
    t0 = time.perf_counter()
    pnsolver.solve(scene, threads=1)
    full = time.perf_counter() - t0
    timer = threading.Timer(0.05, _thread.interrupt_main)
    timer.start()
    t0 = time.perf_counter()
    with pytest.raises(KeyboardInterrupt):
        pnsolver.solve(scene, threads=1)
    interrupted = time.perf_counter() - t0
    timer.join()
    assert interrupted < 0.5 * full, (interrupted, full)
    assert pnsolver.solve(pnsolver.Scene(SETTINGS, density=density()))["moments"] is not None


def test_a_progress_callback_sees_every_iteration():
    """callback(iteration, relative_residual) for each solver iteration: 1, 2, …, the
    report's count, ending at the residual the report states."""
    seen = []
    sol = pnsolver.solve(pnsolver.Scene.load("sphere"), threads=2,
                         callback=lambda it, rel: seen.append((it, rel)))
    s = sol["report"]["solver"]
    assert [it for it, _ in seen] == list(range(1, s["iterations"] + 1))
    assert seen[-1][1] <= s["tolerance"] and seen[0][1] > 10 * s["tolerance"]


def test_an_exception_in_the_callback_ends_the_call_and_the_interpreter_goes_on():
    def stop(it, rel):
        if it == 3:
            raise RuntimeError("enough at iteration 3")

    with pytest.raises(RuntimeError, match="enough at iteration 3"):
        pnsolver.solve(pnsolver.Scene.load("sphere"), threads=1, callback=stop)
    sol = pnsolver.solve(pnsolver.Scene.load("sphere"), threads=1)
    assert sol["report"]["solver"]["converged"]
