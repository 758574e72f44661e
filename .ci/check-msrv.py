#!/usr/bin/env python3
"""The declared minimum Rust version (MSRV) is true and every member uses it.

`[workspace.package] rust-version` in the root Cargo.toml is the MSRV. This check fails if
  * a workspace member does not inherit it (`rust-version.workspace = true`), or
  * a locked dependency (`cargo metadata`, i.e. the versions in Cargo.lock) declares a higher
    `rust-version` than the workspace.
What the code itself needs is checked by clippy's `incompatible_msrv` lint (std APIs newer
than the MSRV), which .ci/run runs under `-D warnings` once members inherit rust-version.
Language features newer than the MSRV (e.g. let-chains, 1.88 and edition 2024) are refused
by rustc for the edition in use.

Only one toolchain (1.95) exists on the machines this was written on, so nothing here
builds with the MSRV toolchain itself; with rustup, `cargo +<msrv> check --workspace` would
be the direct test.
"""
import json
import subprocess
import sys
import tomllib
from pathlib import Path

root = Path(__file__).resolve().parent.parent


def version(v: str) -> tuple:
    parts = [int(x) for x in v.split(".")]
    return tuple(parts + [0] * (3 - len(parts)))


def main() -> int:
    meta = json.loads(
        subprocess.run(
            ["cargo", "metadata", "--format-version", "1", "--locked"],
            cwd=root, check=True, capture_output=True, text=True,
        ).stdout
    )
    ws_toml = tomllib.loads((root / "Cargo.toml").read_text())
    msrv = ws_toml.get("workspace", {}).get("package", {}).get("rust-version")
    if not msrv:
        print("check-msrv: [workspace.package] rust-version is not set", file=sys.stderr)
        return 1
    errors = []
    members = set(meta["workspace_members"])
    for pkg in meta["packages"]:
        if pkg["id"] in members:
            manifest = tomllib.loads(Path(pkg["manifest_path"]).read_text())
            rv = manifest.get("package", {}).get("rust-version")
            if rv != {"workspace": True}:
                errors.append(
                    f"{pkg['name']} ({pkg['manifest_path']}): rust-version is {rv!r}, "
                    "want `rust-version.workspace = true`"
                )
        elif pkg.get("rust_version") and version(pkg["rust_version"]) > version(msrv):
            errors.append(
                f"dependency {pkg['name']} {pkg['version']} needs Rust {pkg['rust_version']}, "
                f"above the workspace's rust-version {msrv}"
            )
    for e in errors:
        print(f"check-msrv: {e}", file=sys.stderr)
    if not errors:
        print(f"check-msrv: ok (rust-version {msrv}, {len(members)} members inherit it)")
    return 1 if errors else 0


if __name__ == "__main__":
    sys.exit(main())
