"""Benchmark a whole frame: BO2 Lighting against Cycles on the same scene, in the same run.

Usage: python tools/bench_render.py [--samples N] [--cycles-samples N] [--skip-cycles]
                                    [--profile N]

Builds a scene of about 120k triangles (a room: floor and walls with the textured node chain of
an imported PBR asset, 30 smooth spheres, boxes) lit by a point light (cube shadow map), a spot
and a sun, and renders it at 1920x1080 with BO2 Lighting and with Cycles (CPU, 128 samples by
default), with BO2 Lighting at 3840x2160 for memory, and with BO2 Lighting again with constant
wall materials ("plain": what the materials cost). Each render runs in its own ``bo2 render``
process; the table gives the render time that process reports (scene loading excluded) and the
process's peak resident memory. ``--profile N`` adds the N functions where one thread's
1920x1080 frame spends its time, and the share of the material programs' evaluation.
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
import numpy as np
def image(name, fn, colorspace, size=1024):
    img = bpy.data.images.new(name, size, size)
    img.colorspace_settings.name = colorspace  # before the pixels: it regenerates the image
    y, x = np.mgrid[0:size, 0:size] / size
    rgba = np.ones((size, size, 4), np.float32)
    rgba[..., :3] = fn(x, y)
    img.pixels.foreach_set(rgba.ravel())
    img.pack()
    return img
def textured(name):
    """What an imported PBR asset brings: tiled base colour, a packed occlusion-roughness-
    metallic image split by Separate Color, a tangent-space normal map."""
    m = material(name, (0.6, 0.6, 0.55))
    nodes, links = m.node_tree.nodes, m.node_tree.links
    p = nodes["Principled BSDF"]
    uv = nodes.new("ShaderNodeTexCoord").outputs["UV"]
    mapping = nodes.new("ShaderNodeMapping")
    mapping.inputs["Scale"].default_value = (4.0, 4.0, 1.0)
    links.new(uv, mapping.inputs["Vector"])
    wave = lambda x, y: 0.5 + 0.5 * np.sin(40 * x) * np.sin(40 * y)
    maps = {"base": image("base", lambda x, y: np.stack([0.3 + 0.4 * wave(x, y), 0.5 * x + 0.2,
                                                         0.4 * y + 0.2], -1), "sRGB"),
            "orm": image("orm", lambda x, y: np.stack([np.ones_like(x), 0.2 + 0.6 * wave(x, y),
                                                       (wave(x, y) > 0.8) * 1.0], -1),
                         "Non-Color"),
            "normal": image("normal", lambda x, y: np.stack([0.5 + 0.2 * np.cos(40 * x),
                                                             0.5 + 0.2 * np.cos(40 * y),
                                                             np.full_like(x, 0.95)], -1),
                            "Non-Color")}
    tex = {}
    for key, img in maps.items():
        tex[key] = nodes.new("ShaderNodeTexImage")
        tex[key].image = img
        links.new(mapping.outputs[0], tex[key].inputs["Vector"])
    links.new(tex["base"].outputs["Color"], p.inputs["Base Color"])
    split = nodes.new("ShaderNodeSeparateColor")
    links.new(tex["orm"].outputs["Color"], split.inputs[0])
    links.new(split.outputs[1], p.inputs["Roughness"])
    links.new(split.outputs[2], p.inputs["Metallic"])
    nmap = nodes.new("ShaderNodeNormalMap")
    links.new(tex["normal"].outputs["Color"], nmap.inputs["Color"])
    links.new(nmap.outputs[0], p.inputs["Normal"])
    return m
wall = textured("Wall") if sys.argv[2] == "textured" else material("Wall", (0.6, 0.6, 0.55))
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
from bo2_lighting.addon.core import kernels
from bo2_lighting.addon.core.render import pipeline
from bo2_lighting.addon.core.render.job import RenderJob
bo2_lighting.register()
bpy.ops.wm.open_mainfile(filepath=sys.argv[1])
kernels.load()
scene = bpy.context.scene
frame, _ = extract.extract_scene(bpy.context.evaluated_depsgraph_get(),
                                 indirect=scene.bo2.indirect.use)
frame = dataclasses.replace(frame, settings=dataclasses.replace(frame.settings, threads=1))
profile = cProfile.Profile()
profile.enable()
pipeline.render_frame(RenderJob(frame))
profile.disable()
stats = pstats.Stats(profile)
stats.sort_stats("tottime").print_stats(int(sys.argv[2]))
total = sum(v[2] for v in stats.stats.values())
materials = sum(v[3] for k, v in stats.stats.items() if k[2] == "_materials")
print(f"MATERIALS {materials:.3f} s of {total:.3f} s ({100 * materials / total:.1f}%)")
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
        build = subprocess.run([sys.executable, "-c", BUILD, str(blend), "textured"],
                               capture_output=True, text=True, check=True)
        tris = re.search(r"TRIANGLES (\d+)", build.stdout)[1]
        plain = Path(tmp) / "plain.blend"  # the same walls with constant materials
        subprocess.run([sys.executable, "-c", BUILD, str(plain), "plain"], capture_output=True,
                       text=True, check=True)
        cases = [("BO2 1920x1080", ["--engine", "bo2", "--samples", str(args.samples)]),
                 ("BO2 3840x2160", ["--engine", "bo2", "--samples", str(args.samples),
                                    "--resolution", "3840x2160"])]
        if not args.skip_cycles:
            cases.append(("Cycles 1920x1080", ["--engine", "cycles", "--samples",
                                               str(args.cycles_samples)]))
        cases.append(("BO2 1920x1080 plain", ["--engine", "bo2", "--samples",
                                              str(args.samples)]))
        rows = []
        for name, extra in cases:
            print(f"rendering {name} ...", flush=True)
            seconds, peak, _ = run([str(BO2), "render", str(plain if "plain" in name else blend),
                                    "-o", str(Path(tmp) / "frame.png"), *extra])
            rows.append((name, seconds, peak))
        if args.profile:
            subprocess.run([sys.executable, "-c", PROFILE, str(blend), str(args.profile)],
                           check=True)
    print(f"\nscene: {tris} triangles; point (cube shadows), spot and sun lights; "
          f"BO2 {args.samples} samples, Cycles {args.cycles_samples} samples (CPU)")
    print(f"{'case':<20} {'render s':>9} {'peak MiB':>9}")
    for name, seconds, peak in rows:
        print(f"{name:<20} {seconds:9.2f} {peak:9.0f}")
    textured, plain = rows[0][1], rows[-1][1]
    print(f"the walls' textured materials cost {textured - plain:.2f} s of the "
          f"{textured:.2f} s frame ({100 * (textured - plain) / textured:.0f}%; 'plain': the "
          "same scene with constant wall materials)")
    if not args.skip_cycles:
        print(f"speed-up at 1920x1080: Cycles / BO2 = {rows[2][1] / rows[0][1]:.1f}x")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
