"""Benchmark a whole frame: BO2 Lighting against Cycles on the same scene, in the same run.

Usage: python tools/bench_render.py [--samples N] [--cycles-samples N] [--skip-cycles]
                                    [--profile N]

Builds a scene of about 120k triangles (a room: floor and walls, 30 smooth spheres, boxes) lit
by a point light (cube shadow map), a spot and a sun, renders it at 1920x1080 with BO2
Lighting and with Cycles (CPU, 128 samples by default), and BO2 Lighting at 3840x2160 for
memory. Each render runs in its own ``bo2 render`` process; the table gives the render time
that process reports (scene loading excluded) and the process's peak resident memory.
``--profile N`` adds the N functions where one thread's 1920x1080 frame spends its time.
Prints figures only.
"""

from __future__ import annotations

import argparse
import os
import re
import subprocess
import sys
import tempfile
from pathlib import Path

BO2 = Path(sys.executable).parent / "bo2"

BUILD = r'''
import math, sys
import bpy
bpy.ops.wm.read_factory_settings(use_empty=True)
scene = bpy.context.scene
def material(name, color, metallic=0.0, roughness=0.5):
    m = bpy.data.materials.new(name)
    if bpy.app.version < (5, 0, 0):
        m.use_nodes = True
    p = m.node_tree.nodes["Principled BSDF"]
    p.inputs["Base Color"].default_value = (*color, 1)
    p.inputs["Metallic"].default_value = metallic
    p.inputs["Roughness"].default_value = roughness
    return m
wall = material("Wall", (0.6, 0.6, 0.55), roughness=0.8)
for size, loc, rot in [(16, (0, 0, 0), (0, 0, 0)), (16, (0, 6, 4), (math.pi / 2, 0, 0)),
                       (16, (-7, 0, 4), (0, math.pi / 2, 0)), (16, (7, 0, 4), (0, math.pi / 2, 0))]:
    bpy.ops.mesh.primitive_plane_add(size=size, location=loc, rotation=rot)
    bpy.context.object.data.materials.append(wall)
mats = [material(f"M{i}", c, m, r) for i, (c, m, r) in enumerate([
    ((0.8, 0.1, 0.1), 0, 0.3), ((1.0, 0.78, 0.34), 1, 0.25), ((0.2, 0.5, 0.8), 0, 0.6),
    ((0.95, 0.64, 0.54), 1, 0.15), ((0.9, 0.9, 0.9), 0, 0.1)])]
for i in range(30):
    x, y = -5 + 2 * (i % 6), -3 + 2 * (i // 6)
    bpy.ops.mesh.primitive_uv_sphere_add(segments=64, ring_count=32, radius=0.6,
                                         location=(x, y, 0.6))
    bpy.ops.object.shade_smooth()
    bpy.context.object.data.materials.append(mats[i % 5])
for i in range(6):
    bpy.ops.mesh.primitive_cube_add(size=0.8, location=(-5 + 2 * i, 4.5, 0.4))
    bpy.context.object.data.materials.append(mats[(i + 2) % 5])
def light(kind, loc, rot, **kw):
    d = bpy.data.lights.new(kind, kind)
    for k, v in kw.items():
        setattr(d, k, v)
    o = bpy.data.objects.new(kind, d)
    o.location, o.rotation_euler = loc, rot
    scene.collection.objects.link(o)
light("POINT", (-2, -1, 3.5), (0, 0, 0), energy=800, shadow_soft_size=0.2)
light("SPOT", (4, -5, 5), (math.radians(50), 0, math.radians(40)), energy=2000,
      spot_size=math.radians(60), shadow_soft_size=0.1)
light("SUN", (0, 0, 10), (math.radians(40), 0, math.radians(-50)), energy=2.0,
      angle=math.radians(2))
cam = bpy.data.objects.new("Camera", bpy.data.cameras.new("Camera"))
cam.location, cam.rotation_euler = (0, -12, 6), (math.radians(65), 0, 0)
scene.collection.objects.link(cam)
scene.camera = cam
scene.render.resolution_x, scene.render.resolution_y = 1920, 1080
scene.render.resolution_percentage = 100
scene.view_settings.view_transform = "Standard"
scene.cycles.device = "CPU"
scene.cycles.use_denoising = False
tris = sum(len(o.data.loop_triangles) for o in scene.objects if o.type == "MESH"
           and not o.data.calc_loop_triangles())
print("TRIANGLES", tris)
bpy.ops.wm.save_as_mainfile(filepath=sys.argv[1])
'''


# One thread's profile of the 1920x1080 frame through the core pipeline (the scene extracted as
# the engine extracts it): the functions where the time goes.
PROFILE = r"""
import cProfile, dataclasses, pstats, sys
import bpy
import bo2_lighting
from bo2_lighting.addon.blender import extract
from bo2_lighting.addon.core import kernels, pipeline
bo2_lighting.register()
bpy.ops.wm.open_mainfile(filepath=sys.argv[1])
kernels.load()
scene = bpy.context.scene
frame, _ = extract.extract_scene(bpy.context.evaluated_depsgraph_get(),
                                 indirect=scene.bo2.use_indirect)
frame = dataclasses.replace(frame, settings=dataclasses.replace(frame.settings, threads=1))
profile = cProfile.Profile()
profile.enable()
pipeline.render_frame(frame)
profile.disable()
pstats.Stats(profile).sort_stats("tottime").print_stats(int(sys.argv[2]))
"""


def run(cmd: list[str]) -> tuple[float, float, str]:
    """Run a command; returns (seconds it reports, peak RSS in MiB, stdout)."""
    with tempfile.TemporaryFile("w+") as out:
        proc = subprocess.Popen(cmd, stdout=out, stderr=subprocess.STDOUT, text=True)
        _, status, usage = os.wait4(proc.pid, 0)
        out.seek(0)
        text = out.read()
    if os.waitstatus_to_exitcode(status) != 0:
        raise SystemExit(f"bench_render: failed: {' '.join(cmd)}\n{text}")
    match = re.search(r"rendered in ([0-9.]+) s", text)
    return (float(match[1]) if match else float("nan")), usage.ru_maxrss / 1024.0, text


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--samples", type=int, default=4,
                        help="BO2 Lighting samples per pixel (the engine's default)")
    parser.add_argument("--cycles-samples", type=int, default=128)
    parser.add_argument("--skip-cycles", action="store_true")
    parser.add_argument("--profile", type=int, metavar="N", default=0,
                        help="also print the N functions that take most of one thread's time")
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        blend = Path(tmp) / "bench.blend"
        build = subprocess.run([sys.executable, "-c", BUILD, str(blend)], capture_output=True,
                               text=True, check=True)
        tris = re.search(r"TRIANGLES (\d+)", build.stdout)[1]
        cases = [("BO2 1920x1080", ["--engine", "bo2", "--samples", str(args.samples)]),
                 ("BO2 3840x2160", ["--engine", "bo2", "--samples", str(args.samples),
                                    "--resolution", "3840x2160"])]
        if not args.skip_cycles:
            cases.append(("Cycles 1920x1080", ["--engine", "cycles", "--samples",
                                               str(args.cycles_samples)]))
        rows = []
        for name, extra in cases:
            print(f"rendering {name} ...", flush=True)
            seconds, peak, _ = run([str(BO2), "render", str(blend), "-o",
                                    str(Path(tmp) / "frame.png"), *extra])
            rows.append((name, seconds, peak))
        if args.profile:
            subprocess.run([sys.executable, "-c", PROFILE, str(blend), str(args.profile)],
                           check=True)
    print(f"\nscene: {tris} triangles; point (cube shadows), spot and sun lights; "
          f"BO2 {args.samples} samples, Cycles {args.cycles_samples} samples (CPU)")
    print(f"{'case':<20} {'render s':>9} {'peak MiB':>9}")
    for name, seconds, peak in rows:
        print(f"{name:<20} {seconds:9.2f} {peak:9.0f}")
    if not args.skip_cycles:
        print(f"speed-up at 1920x1080: Cycles / BO2 = {rows[2][1] / rows[0][1]:.1f}x")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
