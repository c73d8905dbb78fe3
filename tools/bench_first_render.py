"""Benchmark the first F12 of a Blender session, as a user waits for it, beside Cycles.

Usage: python tools/bench_first_render.py   (a Python with ``bpy``: ``.venv/bin/python``)

A scene of three spheres, a point light, a sun and an unbaked sphere probe at 320x180. Each case
is a fresh Blender session (its own process): the extension registered and the kernels'
preparation started off the UI thread (``kernels.prepare``, as registering does in a window),
the file opened, then F12 (``bpy.ops.render.render``), timed whole:
- after installing: an empty kernel cache, F12 as soon as the file is open (the frame's
  kernels compile in child processes side by side, the render waits for them; the lightmap
  bakes' kernels compile after them, and the bench waits for those before the next case);
- a new session: the cache filled, F12 as soon as the file is open;
- a new session, F12 once the kernels are ready (a user who looks at the scene first);
- Cycles, F12 of the same frame (CPU, 16 samples) in a new session, for scale.
Prints figures only.
"""

from __future__ import annotations

import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

BUILD = r'''
import sys, bpy
bpy.ops.wm.read_factory_settings(use_empty=True)
scene = bpy.context.scene
for k, x in enumerate((-1.5, 0.0, 1.5)):
    bpy.ops.mesh.primitive_uv_sphere_add(radius=0.6, location=(x, 0, 0.6), segments=48,
                                         ring_count=24)
    m = bpy.data.materials.new(f"m{k}")
    if bpy.app.version < (5, 0, 0):
        m.use_nodes = True
    m.node_tree.nodes["Principled BSDF"].inputs["Roughness"].default_value = 0.2 + 0.3 * k
    bpy.context.object.data.materials.append(m)
bpy.ops.mesh.primitive_plane_add(size=12)
bpy.ops.object.light_add(type="POINT", location=(2, -2, 3))
bpy.context.object.data.energy = 800
bpy.ops.object.light_add(type="SUN", rotation=(0.6, 0.2, 0.8))
bpy.context.object.data.energy = 3
kind = "SPHERE" if bpy.app.version >= (4, 1, 0) else "CUBE"
bpy.ops.object.lightprobe_add(type=kind, location=(0, 0, 1))
bpy.ops.object.camera_add(location=(0, -7, 2.5), rotation=(1.3, 0, 0))
scene.camera = bpy.context.object
world = bpy.data.worlds.new("World")
world.color = (0.3, 0.35, 0.45)
scene.world = world
scene.render.resolution_x, scene.render.resolution_y = 320, 180
scene.render.resolution_percentage = 100
scene.cycles.samples = 16
scene.cycles.device = "CPU"
bpy.ops.wm.save_as_mainfile(filepath=sys.argv[-1])
'''

F12 = r'''
import sys, time
import bpy
import bo2_lighting
blend, engine, wait = sys.argv[-3], sys.argv[-2], sys.argv[-1] == "wait"
bo2_lighting.register()
from bo2_lighting.addon.core import kernels
kernels.prepare()  # as registering does in a window (a background Blender, as here, does not)
bpy.ops.wm.open_mainfile(filepath=blend, load_ui=False)
bpy.context.scene.render.engine = engine
if wait:
    while kernels.status():
        time.sleep(0.05)
start = time.perf_counter()
bpy.ops.render.render()
print(f"F12 {time.perf_counter() - start:.3f}")
'''


def f12(blend: Path, cache: Path, engine: str = "BO2_LIGHTING", wait: bool = False) -> float:
    """Seconds of F12 in a fresh session with kernel cache ``cache``."""
    env = {**os.environ, "NUMBA_CACHE_DIR": str(cache)}
    run = subprocess.run([sys.executable, "-c", F12, str(blend), engine,
                          "wait" if wait else "now"], env=env, capture_output=True, text=True)
    said = [line for line in run.stdout.splitlines() if line.startswith("F12 ")]
    if run.returncode != 0 or not said:
        raise SystemExit(f"bench_first_render: failed:\n{run.stdout}{run.stderr}")
    return float(said[-1].split()[1])


CACHED = ("from bo2_lighting.addon.core import kernels; "
          "print(kernels.is_cached())")


def settle(cache: Path, timeout: float = 600.0) -> float:
    """Wait until the cache ``cache`` holds every kernel module (the lightmap bakes' one
    compiles after the frame's, in a child that outlives a session ended at once); seconds
    waited."""
    env = {**os.environ, "NUMBA_CACHE_DIR": str(cache)}
    start = time.perf_counter()
    while time.perf_counter() - start < timeout:
        run = subprocess.run([sys.executable, "-c", CACHED], env=env, capture_output=True,
                             text=True)
        if run.stdout.strip() == "True":
            break
        time.sleep(0.5)
    return time.perf_counter() - start


def main() -> int:
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        blend = tmp / "first.blend"
        subprocess.run([sys.executable, "-c", BUILD, str(blend)], check=True,
                       capture_output=True)
        cache = tmp / "kernels"
        print("three spheres, a point light, a sun, an unbaked sphere probe; 320x180; "
              "F12 (bpy.ops.render.render) timed whole, each in a fresh session")
        print(f"after installing (empty kernel cache), F12 at once: "
              f"{f12(blend, cache):.2f} s (target 20 s)")
        print(f"  the lightmap bakes' kernels ready:                {settle(cache):.1f} s later")
        print(f"a new session, F12 at once:                         "
              f"{f12(blend, cache):.2f} s (target 1.0 s)")
        print(f"a new session, F12 once the kernels are ready:      "
              f"{f12(blend, cache, wait=True):.2f} s")
        print(f"Cycles, 16 samples, a new session:                  "
              f"{f12(blend, cache, 'CYCLES'):.2f} s")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
