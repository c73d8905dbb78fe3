"""Measure a probe bake and a lightmap bake on a Dask cluster: the scheduler's task rate, a
generated level baked alone and on 1 and 2 local workers, and the time expected on more machines.

Usage: python tools/bench_cluster.py [--volumes N] [--spheres N] [--objects N] [--keep DIR]

The level: ``--objects`` boxes (300) on a ground under a sun and a point light, ``--spheres``
Sphere probes (40) and four Volume probes of ``--volumes`` samples in all (1,960): 2,000
probes' captures per bounce, 2 bounces. Every process renders on one thread (Render >
Performance > Threads: Fixed, 1), so a worker is one core and the figures add up on this
two-core machine. Prints:

1. tasks per second the scheduler sustains with our tasks' arguments (a block of 32 volume
   samples' ``Shot``s each) and no work in them;
2. the bake alone (``bo2 bake``) and with ``--scheduler`` on 1 and 2 workers, seconds;
3. the model T(n) = S + P / n, S the serial part (the client's reading, shipping, dilation and
   gathers between bounces; from the 1- and 2-worker runs), each bounce's phases bounded by
   their task counts (a phase of k tasks keeps at most k workers busy), for 8, 32 and 128
   one-core workers;
4. the level's lightmaps (the boxes and the ground: static) baked alone and on 1 and 2 workers,
   and their model T(n) = S + ceil(k / n) P / k, k the gather tasks of a bounce.
"""

from __future__ import annotations

import argparse
import math
import re
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

BO2 = Path(sys.executable).parent / "bo2"

LEVEL = r'''
import math, sys
import bpy
bpy.ops.wm.read_factory_settings(use_empty=True)
import bo2_lighting
bo2_lighting.register()
scene = bpy.context.scene
scene.render.engine = "BO2_LIGHTING"
scene.render.threads_mode, scene.render.threads = "FIXED", 1
scene.bo2.probes.bounces = 2
scene.bo2.bake_pack = False
objects, spheres, samples = (int(a) for a in sys.argv[2:5])
def material(name, color):
    m = bpy.data.materials.new(name)
    if m.node_tree is None:
        m.use_nodes = True
    m.node_tree.nodes["Principled BSDF"].inputs["Base Color"].default_value = (*color, 1)
    return m
bpy.ops.mesh.primitive_plane_add(size=120)
bpy.context.object.data.materials.append(material("Ground", (0.6, 0.6, 0.6)))
side = math.ceil(math.sqrt(objects))
mats = [material(f"Box {k}", (0.2 + 0.15 * k, 0.5, 0.8 - 0.15 * k)) for k in range(4)]
for k in range(objects):
    x, y = (k % side - side / 2) * 4.0, (k // side - side / 2) * 4.0
    bpy.ops.mesh.primitive_cube_add(size=1.5, location=(x, y, 0.75 + (k % 3) * 0.5))
    bpy.context.object.data.materials.append(mats[k % 4])
for kind, loc, energy in (("SUN", (0, 0, 20), 3.0), ("POINT", (3, -2, 6), 2000.0)):
    data = bpy.data.lights.new(kind, kind)
    data.energy = energy
    obj = bpy.data.objects.new(kind, data)
    obj.location, obj.rotation_euler = loc, (math.radians(40), 0, math.radians(30))
    scene.collection.objects.link(obj)
per = samples // 4
nz = 2
ny = max(1, round(math.sqrt(per / nz)))
nx = per // (ny * nz)
for k in range(4):
    x, y = (k % 2 - 0.5) * 60, (k // 2 - 0.5) * 60
    bpy.ops.object.lightprobe_add(type="VOLUME", location=(x, y, 3))
    v = bpy.context.object
    v.scale = (28, 28, 2.5)
    v.data.resolution_x, v.data.resolution_y, v.data.resolution_z = nx, ny, nz
for k in range(spheres):
    x, y = (k % 8 - 3.5) * 14, (k // 8 - 2) * 14
    bpy.ops.object.lightprobe_add(type="SPHERE", location=(x, y, 2))
cam = bpy.data.objects.new("Camera", bpy.data.cameras.new("Camera"))
cam.location, cam.rotation_euler = (0, -70, 40), (math.radians(60), 0, 0)
scene.collection.objects.link(cam)
scene.camera = cam
count = sum(len(o.data.polygons) * 2 for o in scene.objects if o.type == "MESH")
print("SAMPLES", 4 * nx * ny * nz, "TRIANGLES", count)
bpy.ops.wm.save_as_mainfile(filepath=sys.argv[1])
'''


def noop(*_):
    return None


def task_rate(client, count: int = 2000) -> float:
    """Tasks per second the scheduler runs with a volume block's arguments each."""
    import numpy as np

    from bo2_lighting.addon.core.bakes.bake import Shot

    rng = np.random.default_rng(0)
    block = [Shot(rng.random(3), 16, 0.05, 100.0, "irradiance") for _ in range(32)]
    warm = client.gather(client.map(noop, range(50), [block] * 50, pure=False))
    assert len(warm) == 50
    start = time.perf_counter()
    client.gather(client.map(noop, range(count), [block] * count, pure=False))
    return count / (time.perf_counter() - start)


def bake(blend: Path, *extra: str) -> float:
    """``bo2 bake`` of ``blend``: the seconds it reports."""
    proc = subprocess.run([str(BO2), "bake", str(blend), *extra], capture_output=True,
                          text=True)
    if proc.returncode != 0:
        raise SystemExit(f"bench_cluster: bo2 bake failed: {proc.stderr.strip()[-400:]}")
    return float(re.search(r" in ([0-9.]+) s", proc.stdout)[1])


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--volumes", type=int, default=1960)
    parser.add_argument("--spheres", type=int, default=40)
    parser.add_argument("--objects", type=int, default=300)
    parser.add_argument("--keep", type=Path, help="keep the level here")
    args = parser.parse_args()
    import distributed

    from bo2_lighting.addon.cluster import session

    with tempfile.TemporaryDirectory() as tmp:
        folder = args.keep or Path(tmp)
        folder.mkdir(parents=True, exist_ok=True)
        blend = folder / "level.blend"
        built = subprocess.run([sys.executable, "-c", LEVEL, str(blend), str(args.objects),
                                str(args.spheres), str(args.volumes)],
                               capture_output=True, text=True, check=True)
        samples, triangles = map(int, re.search(r"SAMPLES (\d+) TRIANGLES (\d+)",
                                                built.stdout).groups())
        print(f"level: {args.objects} boxes, {triangles} triangles, {args.spheres} sphere "
              f"probes, 4 volumes of {samples} samples in all: {args.spheres + samples} "
              f"captures per bounce, 2 bounces", flush=True)
        alone = bake(blend)
        print(f"alone (bo2 bake, one thread): {alone:.1f} s", flush=True)
        times, rate = {}, 0.0
        for n in (1, 2):
            with distributed.LocalCluster(n_workers=n, threads_per_worker=1, processes=True,
                                          dashboard_address=":0",
                                          preload=["bo2_lighting.addon.cluster.tasks"]
                                          ) as local, distributed.Client(local) as client:
                if n == 2:
                    rate = task_rate(client)
                times[n] = bake(blend, "--scheduler", local.scheduler_address)
                print(f"{n} worker{'s' * (n > 1)}: {times[n]:.1f} s", flush=True)
        ship = measure_ship(blend)
        maps = {0: bake(blend, "--lightmaps")}
        print(f"lightmaps alone: {maps[0]:.1f} s", flush=True)
        for n in (1, 2):
            with distributed.LocalCluster(n_workers=n, threads_per_worker=1, processes=True,
                                          dashboard_address=":0",
                                          preload=["bo2_lighting.addon.cluster.tasks"]
                                          ) as local:
                maps[n] = bake(blend, "--lightmaps", "--scheduler", local.scheduler_address)
                print(f"lightmaps, {n} worker{'s' * (n > 1)}: {maps[n]:.1f} s", flush=True)
        texels = lightmap_texels(blend)
    parallel = 2.0 * (times[1] - times[2])
    serial = times[1] - parallel
    volume_tasks = math.ceil(samples / session.SHOT_BLOCK)
    look_tasks = math.ceil(samples / session.LOOK_BLOCK)
    phases = [look_tasks] + [volume_tasks, args.spheres] * 2  # the looks, then 2 bounces
    work = [samples, samples, args.spheres, samples, args.spheres]
    unit = parallel / sum(work)  # seconds of one capture or look, on one worker
    per_task = [unit * w / t for w, t in zip(work, phases, strict=True)]
    print(f"\nscheduler: {rate:.0f} tasks/s with a block of {session.SHOT_BLOCK} samples' "
          f"arguments each")
    print(f"shipping the .blend (packed, saved, sent): {ship:.2f} s")
    print(f"model: serial {serial:.1f} s + parallel {parallel:.1f} s of work "
          f"(phases of {', '.join(map(str, phases))} tasks)")
    print(f"{'workers':>8} {'expected s':>11}")
    for n in (1, 2, 8, 32, 128):
        expect = serial + sum(math.ceil(t / n) * d for t, d in zip(phases, per_task,
                                                                   strict=True))
        expect += sum(phases) / rate
        print(f"{n:>8} {expect:11.1f}")
    from bo2_lighting.addon.core.bakes import lightmap_bake

    tasks = math.ceil(texels / (session.GATHER_BLOCK * lightmap_bake.GATHER_CHUNK))
    parallel = 2.0 * (maps[1] - maps[2])
    serial = maps[1] - parallel
    print(f"\nlightmaps: {texels} texels, {tasks} gather tasks a bounce; model: serial "
          f"{serial:.1f} s + parallel {parallel:.1f} s")
    print(f"{'workers':>8} {'expected s':>11}")
    for n in (1, 2, 8, 32, 128):
        print(f"{n:>8} {serial + math.ceil(tasks / n) * parallel / tasks:11.1f}")
    return 0


def lightmap_texels(blend: Path) -> int:
    """The texels of the lightmaps baked beside ``blend``."""
    from bo2_lighting.addon.core.files import lightmap_file

    files = sorted((blend.parent / "bo2_bake").rglob("lightmaps/*.exr"))
    return sum(int(np.prod(lightmap_file.read(p)[1].image.shape[:2])) for p in files)


def measure_ship(blend: Path) -> float:
    """Seconds ``Cluster.ship`` takes for ``blend`` (to a scheduler with one worker)."""
    script = (
        "import sys, time, distributed\n"
        "from pathlib import Path\n"
        "from bo2_lighting.addon.cli import load_blend\n"
        "from bo2_lighting.addon.cluster.session import Cluster\n"
        "with distributed.LocalCluster(n_workers=1, processes=True, dashboard_address=':0',"
        " preload=['bo2_lighting.addon.cluster.tasks']) as local:\n"
        "    load_blend(Path(sys.argv[1]))\n"
        "    c = Cluster(local.scheduler_address)\n"
        "    start = time.perf_counter(); c.ship()\n"
        "    print('SHIP', time.perf_counter() - start); c.close()\n")
    proc = subprocess.run([sys.executable, "-c", script, str(blend)], capture_output=True,
                          text=True, check=True)
    return float(re.search(r"SHIP ([0-9.]+)", proc.stdout)[1])


if __name__ == "__main__":
    raise SystemExit(main())
