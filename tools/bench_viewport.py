"""Benchmark the viewport's Rendered shading headless, on the demo room, beside Cycles.

Usage: python tools/bench_viewport.py [--blend demo_blends/room.blend] [--size 960x540]
                                      [--repeat 3]

Drives ``blender/viewport.py`` as ``RenderEngine.view_update`` and ``view_draw`` do, through
the scene camera at the given size, and prints, each the median of ``--repeat`` runs:
- the first extraction (the viewport opening) and the first full image;
- after a change (an object moved, a material tweaked, the camera moved, a setting changed):
  the time on the UI thread (reading the change), to the first image (the reduced preview) and
  to the full-resolution image at one sample, with what the session redid;
- a full image at one sample with nothing kept (the frame prepared anew);
- Cycles rendering the same frame at the same size (CPU, 1 sample and 16 samples), in the same
  run, for scale.
Prints figures only. Run with a Python that has ``bpy`` (``.venv/bin/python``).
"""

from __future__ import annotations

import argparse
import dataclasses
import statistics
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
# The viewport's targets, seconds: the first image after any change, and a full image at one
# sample (the sample that follows the first image).
TARGETS = {": first image": 0.1, ": then one sample": 0.3}


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--blend", type=Path, default=ROOT / "demo_blends" / "room.blend")
    parser.add_argument("--size", default="960x540")
    parser.add_argument("--repeat", type=int, default=3)
    args = parser.parse_args()
    width, height = (int(v) for v in args.size.lower().split("x"))

    import bpy

    import bo2_lighting
    from bo2_lighting.addon.blender import viewport
    from bo2_lighting.addon.core import kernels
    from bo2_lighting.addon.core.render import viewport as core_viewport

    bo2_lighting.register()
    bpy.ops.wm.open_mainfile(filepath=str(args.blend.resolve()), load_ui=False)
    scene = bpy.context.scene
    scene.render.engine = "BO2_LIGHTING"
    scene.bo2.viewport.samples = 1
    kernels.load()

    caught: list = []
    bpy.app.handlers.depsgraph_update_post.append(
        lambda _s, dg: caught.extend(viewport.Update.copy(u) for u in dg.updates))

    def camera(shift=0.0):
        dg = bpy.context.evaluated_depsgraph_get()
        cam = scene.camera.evaluated_get(dg)
        matrix = cam.matrix_world.copy()
        matrix.translation.x += shift
        proj = cam.calc_matrix_camera(dg, x=width, y=height)
        return core_viewport.view_camera(matrix.inverted(), proj, width, height)

    tris = sum(len(m.positions) for m in core_scene_meshes(scene))
    print(f"{args.blend.name}: {tris:,} triangles, {width}x{height}, viewport samples 1, "
          f"{bpy.app.version_string}")

    figures: dict[str, list[float]] = {}

    def record(key, seconds):
        figures.setdefault(key, []).append(seconds)

    objects = [o for o in scene.objects if o.type == "MESH" and o.active_material is not None]
    mover = max(objects, key=lambda o: len(o.data.polygons))
    small = min(objects, key=lambda o: len(o.data.polygons))
    tweak = small.active_material
    principled = next((n for n in tweak.node_tree.nodes if n.type == "BSDF_PRINCIPLED"), None)
    for run in range(args.repeat):
        view = viewport.Viewport()
        start = time.perf_counter()
        view.sync(bpy.context.evaluated_depsgraph_get())
        view.set_camera(camera())
        record("open: extraction (UI thread)", time.perf_counter() - start)
        view.session.wait_for(lambda image: True, 600)
        record("open: first image (no shadows yet)", time.perf_counter() - start)
        view.session.wait(600)
        record("open: full image", time.perf_counter() - start)

        def change(name, act, view=view, run=run, shift=None):
            caught.clear()
            before = dict(view.session.stats)
            act()
            start = time.perf_counter()
            bpy.context.view_layer.update()
            view.sync(bpy.context.evaluated_depsgraph_get(), list(caught))
            if shift is not None:
                view.set_camera(camera(shift))
            number = view.session.updates
            ui = time.perf_counter() - start
            view.session.wait_for(lambda i: i.update == number, 60)
            first = time.perf_counter() - start
            view.session.wait(600)
            full = time.perf_counter() - start
            record(f"{name}: UI thread", ui)
            record(f"{name}: first image", first)
            record(f"{name}: then one sample", full - first)
            if run == 0:
                redone = {k: v - before[k] for k, v in view.session.stats.items()
                          if v != before[k]}
                figures.setdefault("redone", []).append(f"{name}: {redone}")

        change(f"move '{mover.name}'",
               lambda: setattr(mover, "location", (mover.location.x + 0.01, *mover.location[1:])))
        if principled is not None:
            roughness = 0.3 + 0.1 * (run % 3)
            change(f"tweak material '{tweak.name}'", lambda r=roughness: setattr(
                principled.inputs["Roughness"], "default_value", r))
        change("move the view", lambda: None, shift=0.05 * (run + 1))
        model = ("bo2", "reference")[run % 2]
        change("a setting (specular model)",
               lambda m=model: setattr(scene.bo2, "specular_model", m))

        start = time.perf_counter()  # nothing kept: the frame prepared anew, one full image
        view.session.update(dataclasses.replace(view.scene, camera=view.camera),
                            core_viewport.CHANGES)
        view.session.wait(600)
        record("nothing kept: full image", time.perf_counter() - start)
        view.close()

    print(f"{'':52s} {'median s':>9s} {'target':>7s}   runs")
    for key, values in figures.items():
        if key == "redone":
            continue
        target = next((t for suffix, t in TARGETS.items() if key.endswith(suffix)), None)
        mark = "" if target is None else f"{target:7.2f}"
        print(f"{key:52s} {statistics.median(values):9.3f} {mark:>7s}   "
              + " ".join(f"{v:.3f}" for v in values))
    for line in figures.get("redone", []):
        print("redone after", line)
    cycles(scene, width, height)
    return 0


def core_scene_meshes(scene):
    import bpy

    from bo2_lighting.addon.blender import extract

    core, _ = extract.extract_scene(bpy.context.evaluated_depsgraph_get(), camera=False)
    return core.meshes


def cycles(scene, width, height) -> None:
    import bpy

    scene.render.engine = "CYCLES"
    scene.render.resolution_x, scene.render.resolution_y = width, height
    scene.render.resolution_percentage = 100
    scene.cycles.device = "CPU"
    scene.cycles.use_denoising = False
    for samples in (1, 16):
        scene.cycles.samples = samples
        start = time.perf_counter()
        bpy.ops.render.render()
        print(f"Cycles {width}x{height}, {samples} sample{'s' * (samples > 1)} (F12, CPU): "
              f"{time.perf_counter() - start:.3f} s")


if __name__ == "__main__":
    sys.exit(main())
