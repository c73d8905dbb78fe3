"""Benchmark of a big lightmap bake: time, peak memory and how steadily the progress moves.

Usage: python tools/bench_lightmap_bake.py [--resolution 2048] [--rays 16] [--bounces 2]
       [--cycles-samples 4]

The scene is an open room (floor, two walls, a block, a sun, a blue sky) on a 10 km ground 50 m
below it, the ground lightmapped (static) at ``--resolution`` texels on a side: one lightmap of
millions of texels, as an outdoor level's terrain. Each backend bakes in a process of its own
(``bo2 bake``'s code, ``blender.bake.lightmap_steps``), so that each peak memory is its own:
BO2 Lighting's (``core.bakes.lightmap_bake``) and Cycles' (Blender's Bake > Diffuse of the same
layout, ``--cycles-samples`` samples). Printed per backend: seconds, peak resident memory, the
bytes per texel it held above the scene's, and the longest wait between two progress steps
(what an artist watching the bar sees stand still); for BO2, the memory the bake announced
(``core.bakes.lightmap_bake.bake_bytes``).
"""

from __future__ import annotations

import argparse
import json
import math
import subprocess
import sys
import tempfile
import time
from pathlib import Path


def build(folder: Path, resolution: int, rays: int, bounces: int, samples: int):
    """The room on its far ground, saved in ``folder``; returns (scene, ground object)."""
    import bpy

    import bo2_lighting

    bpy.ops.wm.read_factory_settings(use_empty=True)
    bo2_lighting.register()
    scene = bpy.context.scene
    world = bpy.data.worlds.new("Sky")
    if bpy.app.version < (5, 0, 0):
        world.use_nodes = True
    world.node_tree.nodes["Background"].inputs["Color"].default_value = (0.3, 0.4, 0.6, 1.0)
    scene.world = world

    def material(name, color):
        mat = bpy.data.materials.new(name)
        if mat.node_tree is None:
            mat.use_nodes = True
        mat.node_tree.nodes["Principled BSDF"].inputs["Base Color"].default_value = (*color, 1)
        return mat

    for name, size, loc, rot in [("Floor", 4, (0, 0, 0), (0, 0, 0)),
                                 ("Back", 4, (0, 2, 1), (math.pi / 2, 0, 0)),
                                 ("Left", 4, (-2, 0, 1), (0, math.pi / 2, 0)),
                                 ("Ground", 10000, (0, 0, -50), (0, 0, 0))]:
        bpy.ops.mesh.primitive_plane_add(size=size, location=loc, rotation=rot)
        bpy.context.object.name = name
        bpy.context.object.data.materials.append(material(name, (0.7, 0.7, 0.7)))
    bpy.ops.mesh.primitive_cube_add(size=0.8, location=(0.4, 0.6, 0.4))
    bpy.context.object.data.materials.append(material("Red", (0.8, 0.1, 0.1)))
    sun = bpy.data.objects.new("Sun", bpy.data.lights.new("Sun", "SUN"))
    sun.data.energy = 3.0
    sun.rotation_euler = (math.radians(40), 0, math.radians(-30))
    scene.collection.objects.link(sun)
    s = scene.bo2
    s.lightmaps.max_resolution = str(resolution)
    s.lightmaps.density = 1000.0  # the ground's layout is held to the maximum resolution
    s.lightmaps.rays, s.lightmaps.bounces = rays, bounces
    s.probes.cycles_samples = samples
    s.bake_pack = False
    bpy.ops.wm.save_as_mainfile(filepath=str(folder / "far_ground.blend"))
    return scene, scene.objects["Ground"]


def child(args) -> None:
    """One backend's bake, in this process: prints one JSON line of its figures."""
    import resource

    from bo2_lighting.addon.blender import bake
    from bo2_lighting.addon.core.bakes import lightmap_bake
    from bo2_lighting.addon.core.render.job import Warnings

    folder = Path(tempfile.mkdtemp())
    scene, ground = build(folder, args.resolution, args.rays, args.bounces,
                          args.cycles_samples)
    notes = Warnings()
    base = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024
    start = last = time.perf_counter()
    longest, where = 0.0, 0.0
    fraction = 0.0
    steps = bake.lightmap_steps(scene, [ground], warnings=notes,
                                backend=args.child.upper())
    for fraction_now in steps:
        now = time.perf_counter()
        if now - last > longest:
            longest, where = now - last, fraction
        last, fraction = now, fraction_now
    seconds = time.perf_counter() - start
    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024
    from bo2_lighting.addon.core.files import lightmap_file

    meta, lm = lightmap_file.read(bake.bake_files.path(ground))
    texels = meta["width"] * meta["height"]
    print(json.dumps({"seconds": seconds, "peak": peak, "above": peak - base,
                      "texels": texels, "longest": longest, "at": where, "notes": notes.texts(),
                      "announced": lightmap_bake.BAKE_BYTES * texels}))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--resolution", type=int, default=2048)
    parser.add_argument("--rays", type=int, default=16)
    parser.add_argument("--bounces", type=int, default=2)
    parser.add_argument("--cycles-samples", type=int, default=4)
    parser.add_argument("--child", choices=("bo2", "cycles"), help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.child:
        child(args)
        return
    print(f"a 10 km ground's lightmap, {args.resolution} texels on a side at most; "
          f"{args.rays} rays, {args.bounces} bounces (BO2), {args.cycles_samples} samples "
          "(Cycles)")
    for backend in ("bo2", "cycles"):
        proc = subprocess.run([sys.executable, __file__, "--child", backend,
                               "--resolution", str(args.resolution), "--rays", str(args.rays),
                               "--bounces", str(args.bounces),
                               "--cycles-samples", str(args.cycles_samples)],
                              capture_output=True, text=True)
        lines = [line for line in proc.stdout.splitlines() if line.startswith("{")]
        if proc.returncode or not lines:
            print(f"  {backend}: failed: {proc.stderr.strip().splitlines()[-1:]}")
            continue
        r = json.loads(lines[-1])
        print(f"  {backend:6s} {r['texels'] / 1e6:5.1f} M texels: {r['seconds']:7.1f} s, peak "
              f"{r['peak'] / 2**30:5.2f} GiB ({r['above'] / r['texels']:4.0f} B per texel above "
              f"the scene's), longest wait between progress steps {r['longest']:5.1f} s "
              f"(at {r['at'] * 100:.0f}%)")
        for note in r["notes"]:
            print(f"         said: {note}")


if __name__ == "__main__":
    main()
