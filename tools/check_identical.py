"""Show that a change leaves every image bit-identical: bakes and renders of the demo and bench
scenes, compared pixel for pixel with the same run on another revision.

Usage: python tools/check_identical.py OUT [--against OTHER_OUT] [--scenes NAME ...]

Into ``OUT``: each demo scene (``demo_blends/``), the render bench's scene
(``tools/bench_render.py``) and two world scenes (``tools/build_world_scenes.py``: a Sky Texture
with its sun, a look-dev set without probes) are copied, their light probes baked (and the
room's lightmaps), and a frame rendered with every pass (``bo2 render --all-passes``, EXR).
The scenes as built are kept in ``OUT/scenes``; with ``--against`` they are taken from the
other run's (a scene built twice may differ in its last bits). ``OUT/digests.json`` holds the
SHA-256 of every channel of every EXR written, bake files named by their object (without the
random suffix of their file name). With ``--against`` the two folders' digests are compared:
per file either "identical" or the channels that differ with their largest absolute
difference. Exits 1 on any difference. Run it on two revisions (a worktree of the old one,
``PYTHONPATH`` pointing at its package).
"""

from __future__ import annotations

import argparse
import hashlib
import json
import re
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
BO2 = Path(sys.executable).parent / "bo2"
DEMO = ("first_light", "material_spheres", "room", "old_vs_new")
WORLD = ("sky_sun", "asset_set")
RESOLUTION = "480x270"


def _run(cmd: list[str], unless: str | None = None) -> None:
    """Run ``cmd``; exits with its output if it fails (not when its error says ``unless``)."""
    proc = subprocess.run(cmd, capture_output=True, text=True)
    if proc.returncode != 0 and not (unless and unless in proc.stderr):
        sys.stderr.write(proc.stdout[-2000:] + proc.stderr[-4000:])
        raise SystemExit(f"check_identical: failed: {' '.join(cmd)}")


def _scenes(out: Path, names: list[str], built: Path | None) -> list[Path]:
    """The .blend files of ``names``, built or copied into ``out`` (from ``built`` when it
    holds them), each kept as built in ``out/scenes``."""
    blends = []
    for name in names:
        blend = out / f"{name}.blend"
        if built is not None and (built / f"{name}.blend").is_file():
            shutil.copyfile(built / f"{name}.blend", blend)
        elif name in DEMO:
            source = ROOT / "demo_blends" / f"{name}.blend"
            if not source.exists():
                _run([sys.executable, str(ROOT / "demo_blends" / f"build_{name}.py"), str(source)])
            shutil.copyfile(source, blend)
        elif name in WORLD:
            _run([sys.executable, str(ROOT / "tools" / "build_world_scenes.py"), str(out), name])
        elif name == "bench":
            sys.path.insert(0, str(ROOT / "tools"))
            import bench_render
            _run([sys.executable, "-c", bench_render.BUILD, str(blend), "textured"])
        else:
            raise SystemExit(f"check_identical: no scene named {name!r}")
        (out / "scenes").mkdir(exist_ok=True)
        shutil.copyfile(blend, out / "scenes" / blend.name)
        blends.append(blend)
    return blends


def _bake_and_render(blend: Path) -> None:
    _run([str(BO2), "bake", str(blend)], unless="has no Sphere or Volume light probes")
    if blend.stem == "room":
        _run([str(BO2), "bake", str(blend), "--lightmaps"])
    _run([str(BO2), "render", str(blend), "-o", str(blend.with_suffix(".exr")), "--all-passes",
          "--resolution", RESOLUTION])


def _channels(path: Path) -> dict[str, np.ndarray]:
    """{part/channel: pixels} of an OpenEXR file."""
    import OpenEXR
    found = {}
    with OpenEXR.File(str(path), separate_channels=True) as exr:
        for index, part in enumerate(exr.parts):
            for name, channel in part.channels.items():
                found[f"{index}:{part.name()}/{name}"] = np.asarray(channel.pixels)
    return found


def _digests(out: Path) -> dict[str, dict[str, str]]:
    """{file: {channel: SHA-256}}; a bake file by its object's name, its suffix dropped."""
    return {_named(path.relative_to(out)): {
        name: hashlib.sha256(pixels.tobytes()).hexdigest()
        for name, pixels in _channels(path).items()} for path in sorted(out.rglob("*.exr"))}


def _named(path: Path) -> str:
    return re.sub(r"-[0-9a-f]{8}(\.exr)$", r"\1", str(path))


def _files(out: Path) -> dict[str, Path]:
    return {_named(p.relative_to(out)): p for p in out.rglob("*.exr")}


def _compare(out: Path, other: Path) -> int:
    mine = json.loads((out / "digests.json").read_text())
    theirs = json.loads((other / "digests.json").read_text())
    differing = 0
    for name in sorted(set(mine) | set(theirs)):
        if name not in mine or name not in theirs:
            print(f"{name}: only in {out if name in mine else other}")
            differing += 1
            continue
        if mine[name] == theirs[name]:
            print(f"{name}: identical ({len(mine[name])} channels)")
            continue
        differing += 1
        a, b = _channels(_files(out)[name]), _channels(_files(other)[name])
        for channel in sorted(set(a) | set(b)):
            if channel not in a or channel not in b:
                print(f"{name} {channel}: only in one")
            elif mine[name].get(channel) != theirs[name].get(channel):
                delta = np.abs(a[channel].astype(np.float64) - b[channel].astype(np.float64))
                print(f"{name} {channel}: differs, largest |difference| {np.nanmax(delta):.3g}")
    print(f"{len(set(mine) | set(theirs))} files, {differing} differ")
    return 1 if differing else 0


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("out", type=Path)
    parser.add_argument("--against", type=Path, help="another run's OUT to compare with")
    parser.add_argument("--scenes", nargs="+", default=[*DEMO, "bench", *WORLD])
    args = parser.parse_args()
    args.out.mkdir(parents=True, exist_ok=True)
    if not (args.out / "digests.json").exists():
        for name in args.scenes:
            if (args.out / f"{name}.exr").exists():  # done by an earlier run that stopped
                continue
            print(f"baking and rendering {name}", flush=True)
            built = None if args.against is None else args.against / "scenes"
            _bake_and_render(_scenes(args.out, [name], built)[0])
        (args.out / "digests.json").write_text(json.dumps(_digests(args.out), indent=1))
    return _compare(args.out, args.against) if args.against else 0


if __name__ == "__main__":
    sys.exit(main())
