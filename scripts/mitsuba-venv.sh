#!/usr/bin/env bash
# Creates (once) a Python virtual environment with Mitsuba 3 for the ground-truth renders of
# `pn export-mitsuba` / `pn compare` and tests/mitsuba_*.rs, plus pyoidn (Intel Open Image
# Denoise) for the denoised curve of `pn race`, and prints its interpreter.
#
#   scripts/mitsuba-venv.sh            # -> <repo>/.venv-mitsuba/bin/python
#   PN_MITSUBA_VENV=/some/dir scripts/mitsuba-venv.sh
#
# Idempotent: an existing venv that already imports the pinned versions is left alone.
# Only the `scalar_rgb` variant is used (runs on any CPU; no LLVM or CUDA needed).
set -euo pipefail
repo="$(cd "$(dirname "$0")/.." && pwd)"
venv="${PN_MITSUBA_VENV:-$repo/.venv-mitsuba}"
version="3.9.1"
oidn_version="2.5.1.0"
python="${PYTHON:-python3}"

have_version() {
    [ -x "$venv/bin/python" ] &&
        "$venv/bin/python" -c "import mitsuba, sys; sys.exit(mitsuba.__version__ != '$version')" \
            >/dev/null 2>&1
}

have_oidn() {
    [ -x "$venv/bin/python" ] &&
        "$venv/bin/python" -c "import importlib.metadata as m, sys, pyoidn
sys.exit(m.version('pyoidn') != '$oidn_version')" >/dev/null 2>&1
}

if ! have_version || ! have_oidn; then
    echo "mitsuba-venv: installing mitsuba==$version pyoidn==$oidn_version into $venv" >&2
    if [ ! -x "$venv/bin/python" ]; then
        "$python" -m venv "$venv" || {
            echo "mitsuba-venv: '$python -m venv' failed (Debian: apt-get install python3-venv)" >&2
            exit 1
        }
    fi
    "$venv/bin/python" -m pip install --quiet --disable-pip-version-check \
        "mitsuba==$version" "pyoidn==$oidn_version" >&2
    "$venv/bin/python" -c "import mitsuba as mi; mi.set_variant('scalar_rgb')" >&2
    "$venv/bin/python" -c "import numpy as np, pyoidn
pyoidn.denoise(np.full((4, 4, 3), 0.5, dtype=np.float32), hdr=True)" >&2
fi
echo "$venv/bin/python"
