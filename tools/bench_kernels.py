"""Benchmark of the compiled kernels' set-up and of texture preparation.

Usage: python tools/bench_kernels.py

Prints:
- preparing a 2048 x 2048 RGBA 8-bit sRGB texture (its copy and the whole mip chain, filtered
  in linear and stored as 8-bit codes), best of 5, in this process;
- ``bo2 render`` of demo_blends/first_light.blend at 320 x 180 as a user's first render after
  installing (an empty kernel cache: the kernels compile) and as the first render of a later
  session (the cache filled): wall time of the whole command (Blender's start included) and the
  render time the command reports; and the same frame rendered by Cycles for scale.
"""

from __future__ import annotations

import os
import re
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
BO2 = Path(sys.executable).parent / "bo2"
SCENE = ROOT / "demo_blends" / "first_light.blend"


def texture_seconds() -> float:
    from bo2_lighting.addon.core import kernels
    from bo2_lighting.addon.core.formulas import texture

    kernels.load()
    rng = np.random.default_rng(0)
    pixels = rng.integers(0, 256, (2048, 2048, 4)).astype(np.uint8)
    best = float("inf")
    for _ in range(5):
        start = time.perf_counter()
        texture.make_texture(pixels, srgb=True).fill_mips()
        best = min(best, time.perf_counter() - start)
    return best


def render_seconds(cache: Path, out: Path, engine: str = "bo2") -> tuple[float, str, float]:
    """(wall seconds of the command, its stderr, the render seconds it reports)."""
    env = {**os.environ, "XDG_CACHE_HOME": str(cache)}
    env.pop("NUMBA_CACHE_DIR", None)
    start = time.perf_counter()
    run = subprocess.run([str(BO2), "render", str(SCENE), "-o", str(out), "--engine", engine,
                          "--resolution", "320x180"], env=env, capture_output=True, text=True)
    seconds = time.perf_counter() - start
    if run.returncode != 0:
        raise SystemExit(f"bench_kernels: bo2 render failed: {run.stderr.strip()}")
    said = re.search(r"rendered in ([0-9.]+) s", run.stdout)
    return seconds, run.stderr, float(said.group(1)) if said else float("nan")


def main() -> int:
    print(f"texture 2048x2048 RGBA 8-bit sRGB, copy + mips: {texture_seconds() * 1000:.0f} ms "
          "(target 50 ms)")
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        first, err, render = render_seconds(tmp / "cache", tmp / "a.png")
        said = "Compiling BO2 kernels" in err
        print(f"bo2 render 320x180, empty kernel cache (first run): {first:.1f} s, render "
              f"{render:.2f} s (target 20 s; said 'Compiling': {said})")
        warm, _, render = render_seconds(tmp / "cache", tmp / "b.png")
        print(f"bo2 render 320x180, kernels cached (new session): {warm:.1f} s, render "
              f"{render:.2f} s (target 1.0 s for the render)")
        cycles, _, render = render_seconds(tmp / "cache", tmp / "c.png", engine="cycles")
        print(f"Cycles, same command and frame: {cycles:.1f} s, render {render:.2f} s")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
