"""Benchmark what the world's light costs a frame: defaults against World Occlusion off.

Usage: python tools/bench_world_light.py [BLEND] [--cycles-samples N] [--skip-cycles]
                                         [--repeat N]

Renders BLEND (default: the 127k-triangle ``heavy`` scene of ``tools/build_world_scenes.py``,
three lamps and a colour world, built into a temporary folder) with BO2 Lighting at 960x540
and 1920x1080 in one Blender session, as F12 does: once cold (the first frame: kernels loaded,
the dome's maps and the bounce without probes made), then ``--repeat`` times warm (best
kept), with the defaults, with World Occlusion off, and with the bounce without probes off too;
then with Cycles at 960x540 (``--cycles-samples``, 64 by default) for the speed-up. Prints
seconds and the ratio to World Occlusion off.
"""

from __future__ import annotations

import argparse
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import bpy

ROOT = Path(__file__).resolve().parent.parent
SIZES = ((960, 540), (1920, 1080))


def timed(scene, repeat: int) -> tuple[float, float]:
    """(cold, best warm) seconds of F12."""
    start = time.perf_counter()
    bpy.ops.render.render()
    cold = time.perf_counter() - start
    warm = []
    for _ in range(repeat):
        start = time.perf_counter()
        bpy.ops.render.render()
        warm.append(time.perf_counter() - start)
    return cold, min(warm)


def main() -> int:
    parser = argparse.ArgumentParser()
    parser.add_argument("blend", nargs="?", type=Path)
    parser.add_argument("--cycles-samples", type=int, default=64)
    parser.add_argument("--skip-cycles", action="store_true")
    parser.add_argument("--repeat", type=int, default=2)
    args = parser.parse_args()
    import bo2_lighting

    with tempfile.TemporaryDirectory() as tmp:
        blend = args.blend
        if blend is None:
            blend = Path(tmp) / "heavy.blend"
            subprocess.run([sys.executable, str(ROOT / "tools" / "build_world_scenes.py"), tmp,
                            "heavy"], check=True, capture_output=True)
        bpy.ops.wm.open_mainfile(filepath=str(blend))
        bo2_lighting.register()
        scene = bpy.context.scene
        scene.render.engine = "BO2_LIGHTING"
        scene.render.resolution_percentage = 100
        scene.bo2.bake_folder = str(Path(tmp) / "bake")
        cases = (("defaults", {}), ("World Occlusion off", {"sky_directions": "0"}),
                 ("and no bounce without probes", {"sky_directions": "0",
                                                   "use_implicit_bounce": False}))
        rows = {}
        for width, height in SIZES:
            scene.render.resolution_x, scene.render.resolution_y = width, height
            for name, settings in cases:
                settings = {"sky_directions": "32", "use_implicit_bounce": True, **settings}
                for key, value in settings.items():
                    owner = getattr(scene.bo2, "indirect", scene.bo2)  # (flat in older versions)
                    if hasattr(owner, key):  # (an older version of the add-on: not all)
                        setattr(owner, key, value)
                rows[width, name] = timed(scene, args.repeat)
        tris = 0
        for obj in scene.objects:
            if obj.type == "MESH":
                obj.data.calc_loop_triangles()
                tris += len(obj.data.loop_triangles)
        print(f"{blend.name}: {tris:,} triangles; BO2 Lighting, seconds (cold first frame / "
              "warm)")
        for width, height in SIZES:
            base = rows[width, "World Occlusion off"][1]
            for name, _ in cases:
                cold, warm = rows[width, name]
                print(f"  {width}x{height} {name:<30} {cold:6.2f} / {warm:6.2f}  "
                      f"x{warm / base:.2f} of World Occlusion off")
        if not args.skip_cycles:
            scene.render.resolution_x, scene.render.resolution_y = SIZES[0]
            scene.render.engine = "CYCLES"
            scene.cycles.samples = args.cycles_samples
            scene.cycles.device = "CPU"
            start = time.perf_counter()
            bpy.ops.render.render()
            cycles = time.perf_counter() - start
            bo2 = rows[SIZES[0][0], "defaults"][1]
            print(f"  960x540 Cycles {args.cycles_samples} samples {cycles:6.2f} s: BO2 Lighting "
                  f"{cycles / bo2:.1f} times faster (warm, defaults)")
        bo2_lighting.unregister()
    return 0


if __name__ == "__main__":
    sys.exit(main())
