"""Time and peak memory of geometry-nodes instances: BO2 Lighting against Cycles, in one run.

Usage: python tools/bench_instances.py [--count 1000] [--samples 4] [--cycles-samples 16]
                                       [--skip-cycles] [--only grid|forest]

Two scenes, built here and rendered by one ``bo2 render`` process each (time as the command
reports it, peak resident memory from the kernel's ``ru_maxrss``):

- grid:   Grid count x count (100 m) -> Instance on Points of a 5 cm Cube (12 triangles each,
          a million instances at the default count), a sun, seen from above at 160x90;
- forest: Distribute Points on Faces (random) over a 200 m ground, a quarter of count^2
          instances of an Ico Sphere (20 triangles) with random rotations and scales (some
          mirrored), a point light and a spot, a camera low over the ground at 320x180.

Prints figures only.
"""

from __future__ import annotations

import argparse
import subprocess
import sys
import tempfile
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from bench_render import BO2, run  # noqa: E402

BUILD = r'''
import math
import sys
import bpy
kind, count, path = sys.argv[1], int(sys.argv[2]), sys.argv[3]
bpy.ops.wm.read_factory_settings(use_empty=True)
scene = bpy.context.scene
tree = bpy.data.node_groups.new("Instances", "GeometryNodeTree")
tree.interface.new_socket("Geometry", in_out="OUTPUT", socket_type="NodeSocketGeometry")
nodes, links = tree.nodes, tree.links
out = nodes.new("NodeGroupOutput")
if kind == "grid":
    grid = nodes.new("GeometryNodeMeshGrid")
    grid.inputs["Size X"].default_value = grid.inputs["Size Y"].default_value = 100.0
    grid.inputs["Vertices X"].default_value = grid.inputs["Vertices Y"].default_value = count
    shape = nodes.new("GeometryNodeMeshCube")
    shape.inputs["Size"].default_value = (0.05, 0.05, 0.05)
    points = grid.outputs["Mesh"]
    scene.render.resolution_x, scene.render.resolution_y = 160, 90
else:
    ground = nodes.new("GeometryNodeMeshGrid")
    ground.inputs["Size X"].default_value = ground.inputs["Size Y"].default_value = 200.0
    scatter = nodes.new("GeometryNodeDistributePointsOnFaces")
    scatter.inputs["Density"].default_value = count * count / 4 / 200.0**2
    links.new(ground.outputs["Mesh"], scatter.inputs["Mesh"])
    shape = nodes.new("GeometryNodeMeshIcoSphere")
    shape.inputs["Radius"].default_value = 0.3
    shape.inputs["Subdivisions"].default_value = 1
    points = scatter.outputs["Points"]
    scene.render.resolution_x, scene.render.resolution_y = 320, 180
on_points = nodes.new("GeometryNodeInstanceOnPoints")
links.new(points, on_points.inputs["Points"])
links.new(shape.outputs["Mesh"], on_points.inputs["Instance"])
result = on_points.outputs["Instances"]
if kind == "forest":
    spin = nodes.new("FunctionNodeRandomValue")
    spin.data_type = "FLOAT_VECTOR"
    spin.inputs["Max"].default_value = (math.pi, math.pi, math.pi)
    rotate = nodes.new("GeometryNodeRotateInstances")
    links.new(result, rotate.inputs["Instances"])
    links.new(spin.outputs["Value"], rotate.inputs["Rotation"])
    size = nodes.new("FunctionNodeRandomValue")
    size.data_type = "FLOAT_VECTOR"
    size.inputs["Min"].default_value = (-1.5, 0.5, 0.5)
    size.inputs["Max"].default_value = (1.5, 2.0, 1.5)
    scale = nodes.new("GeometryNodeScaleInstances")
    links.new(rotate.outputs["Instances"], scale.inputs["Instances"])
    links.new(size.outputs["Value"], scale.inputs["Scale"])
    join = nodes.new("GeometryNodeJoinGeometry")
    links.new(scale.outputs["Instances"], join.inputs[0])
    links.new(ground.outputs["Mesh"], join.inputs[0])
    result = join.outputs[0]
links.new(result, out.inputs["Geometry"])
bpy.ops.mesh.primitive_plane_add(size=1.0)
bpy.context.object.modifiers.new("Instances", "NODES").node_group = tree
cam = bpy.data.objects.new("Camera", bpy.data.cameras.new("Camera"))
scene.collection.objects.link(cam)
scene.camera = cam
if kind == "grid":
    cam.location, cam.rotation_euler = (0.0, -60.0, 40.0), (math.radians(55.0), 0.0, 0.0)
    sun = bpy.data.objects.new("Sun", bpy.data.lights.new("Sun", "SUN"))
    sun.rotation_euler = (math.radians(40.0), 0.0, math.radians(30.0))
    scene.collection.objects.link(sun)
else:
    cam.location = (-60.0, -80.0, 6.0)
    cam.rotation_euler = (math.radians(82.0), 0.0, math.radians(-35.0))
    cam.data.clip_end = 400.0
    for name, kind_, location, energy in (("Lamp", "POINT", (-40.0, -50.0, 8.0), 20000.0),
                                          ("Spot", "SPOT", (0.0, 0.0, 30.0), 200000.0)):
        light = bpy.data.objects.new(name, bpy.data.lights.new(name, kind_))
        light.location, light.data.energy = location, energy
        scene.collection.objects.link(light)
bpy.ops.wm.save_as_mainfile(filepath=path)
'''


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--count", type=int, default=1000, help="grid side (count^2 instances)")
    parser.add_argument("--samples", type=int, default=4)
    parser.add_argument("--cycles-samples", type=int, default=16)
    parser.add_argument("--skip-cycles", action="store_true")
    parser.add_argument("--only", choices=["grid", "forest"])
    args = parser.parse_args()
    scenes = [args.only] if args.only else ["grid", "forest"]
    with tempfile.TemporaryDirectory() as tmp:
        for kind in scenes:
            blend = Path(tmp) / f"{kind}.blend"
            subprocess.run([sys.executable, "-c", BUILD, kind, str(args.count), str(blend)],
                           check=True, capture_output=True)
            cases = [("BO2", ["--engine", "bo2", "--samples", str(args.samples)])]
            if not args.skip_cycles:
                cases.append(("Cycles", ["--engine", "cycles", "--samples",
                                         str(args.cycles_samples)]))
            for name, options in cases:
                image = Path(tmp) / f"{kind}_{name}.png"
                seconds, peak, _ = run([str(BO2), "render", str(blend), "-o", str(image),
                                        *options])
                print(f"{kind:7s} {name:7s} {seconds:8.2f} s {peak:9.0f} MiB", flush=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
