"""Build the extension zips, one per platform, with Blender's own builder, then check each with
Blender's validator.

Usage: python tools/build_extension.py [--offline]

1. Downloads the Python wheels listed in ``blender_manifest.toml`` (``wheels = [...]``: numba,
   llvmlite, OpenEXR and Dask's compiled dependencies for Python 3.11, 3.13 and 3.14 on every
   platform, and Dask's pure Python wheels) into ``wheels/`` with ``pip download
   --only-binary=:all: --platform TAG --python-version X.Y`` (pure wheels: no platform); the
   manifest is the one list of bundled wheels, this script only fetches what it names.
2. Builds ``dist/<id>-<version>-<platform>.zip`` for each of the manifest's ``platforms``
   (``extension build --split-platforms``: each zip holds its platform's wheels) with
   ``blender --command extension build`` when a ``blender`` binary is on PATH, else with
   ``blender_ext.py build`` from the ``bpy`` wheel.
3. Validates every zip the same way (``extension validate`` / ``blender_ext.py validate``).
Exits non-zero with one line on stderr when any step fails.
"""

from __future__ import annotations

import argparse
import importlib.util
import re
import shutil
import subprocess
import sys
import tomllib
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
WHEEL_RE = re.compile(
    r"^(?P<name>[A-Za-z0-9_.]+)-(?P<version>[^-]+)-(?P<py>cp\d+|py[\d.py]+)-(?P<abi>[^-]+)"
    r"-(?P<plat>[^-]+)\.whl$"
)


def fail(message: str) -> None:
    print(f"build_extension: error: {message}", file=sys.stderr)
    raise SystemExit(1)


def read_manifest() -> dict:
    with open(ROOT / "blender_manifest.toml", "rb") as fh:
        return tomllib.load(fh)


def fetch_wheels(manifest: dict, offline: bool) -> None:
    """Download every wheel the manifest lists that is not in ``wheels/`` yet, and delete the
    wheels it no longer lists (Blender's builder packs every wheel of the folder that fits a
    platform)."""
    listed = {(ROOT / rel).resolve() for rel in manifest.get("wheels", [])}
    for old in (ROOT / "wheels").glob("*.whl"):
        if old.resolve() not in listed:
            old.unlink()
    for rel in manifest.get("wheels", []):
        path = (ROOT / rel).resolve()
        if path.exists():
            continue
        if offline:
            fail(f"missing {rel} and --offline was given")
        m = WHEEL_RE.match(path.name)
        if not m:
            fail(f"cannot parse the wheel file name {path.name}")
        target = []  # a compiled wheel's platform and Python; none for pure Python ("any")
        if m["plat"] != "any":
            py = m["py"][2:]
            target = [arg for tag in m["plat"].split(".") for arg in ("--platform", tag)]
            target += ["--python-version", f"{py[0]}.{py[1:]}", "--implementation", "cp"]
        cmd = [
            sys.executable, "-m", "pip", "download", "--quiet", "--no-deps",
            "--only-binary=:all:", *target,
            "--dest", str(path.parent), f"{m['name']}=={m['version']}",
        ]
        print(f"downloading {path.name}")
        if subprocess.run(cmd).returncode != 0 or not path.exists():
            fail(f"pip could not download {path.name}")


def blender_ext_command() -> list[str]:
    """The command prefix for Blender's extension CLI: the binary if present, else the wheel's."""
    blender = shutil.which("blender")
    if blender:
        return [blender, "--factory-startup", "--command", "extension"]
    spec = importlib.util.find_spec("bpy")
    if spec is None or spec.origin is None:
        fail("neither a 'blender' binary nor the 'bpy' module is available")
    found = sorted(Path(spec.origin).parent.glob("*/scripts/addons_core/bl_pkg/cli/blender_ext.py"))
    if not found:
        fail("blender_ext.py was not found inside the bpy module")
    return [sys.executable, str(found[-1])]


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--offline", action="store_true", help="do not download wheels")
    args = parser.parse_args(argv)

    manifest = read_manifest()
    fetch_wheels(manifest, args.offline)
    dist = ROOT / "dist"
    dist.mkdir(exist_ok=True)
    stem = f"{manifest['id']}-{manifest['version']}"
    zips = [dist / f"{stem}-{p.replace('-', '_')}.zip" for p in manifest["platforms"]]
    for old in dist.glob(f"{stem}*.zip"):
        old.unlink()
    ext = blender_ext_command()
    build = ext + ["build", "--source-dir", str(ROOT), "--output-filepath",
                   str(dist / f"{stem}.zip"), "--split-platforms"]
    if subprocess.run(build, cwd=ROOT).returncode != 0 or not all(z.exists() for z in zips):
        fail("Blender's extension builder failed (see above)")
    for zip_path in zips:
        if subprocess.run(ext + ["validate", str(zip_path)], cwd=ROOT).returncode != 0:
            fail(f"Blender's validator rejected {zip_path.name} (see above)")
        size = zip_path.stat().st_size / 2**20
        print(f"built and validated {zip_path.relative_to(ROOT)} ({size:.0f} MiB)")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
