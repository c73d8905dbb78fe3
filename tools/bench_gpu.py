"""Benchmark the GPU backend against the CPU path and Cycles, in one run, on a demo scene.

Usage: .venv52/bin/python tools/bench_gpu.py [--blend demo_blends/room.blend]
                                             [--size 960x540] [--final 1920x1080] [--repeat 3]

Needs a ``bpy`` whose ``gpu`` module opens a context in background mode (Blender 5.2 LTS through
EGL or a display: ``gpu_backend.device`` probes it first). Prints, each the median of
``--repeat`` runs (the first image once: it compiles the shaders):
- the first GPU image of the session at the viewport size, shader compiles included;
- a full viewport image (one sample, read back) after a material tweak (the material table
  uploaded again), a camera move (contact and world occlusion drawn again), an object move
  (the frame prepared anew: its buffers on the CPU, its shadow maps' depths and pyramids drawn
  on the GPU), beside the CPU path's one sample with the same preparation kept (its shadow
  maps built on the CPU);
- a final frame at ``--final`` with the scene's samples and every pass read back, GPU and CPU;
- Cycles at the viewport size, 1 and 16 samples (CPU), for scale.
Prints figures only; what a frame needs that the GPU does not draw yet is named instead.
"""

from __future__ import annotations

import argparse
import dataclasses
import statistics
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--blend", type=Path, default=ROOT / "demo_blends" / "room.blend")
    parser.add_argument("--size", default="960x540")
    parser.add_argument("--final", default="1920x1080")
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument("--skip-cycles", action="store_true")
    args = parser.parse_args()
    width, height = (int(v) for v in args.size.lower().split("x"))
    final_w, final_h = (int(v) for v in args.final.lower().split("x"))

    import bpy

    import bo2_lighting
    from bo2_lighting.addon.gpu_backend import device

    found = device.open_context(bpy.app.binary_path)
    if not found.ok:
        print(f"bench_gpu: no GPU context: {found.reason}", file=sys.stderr)
        return 1
    from bo2_lighting.addon.blender import extract, settings
    from bo2_lighting.addon.core import kernels
    from bo2_lighting.addon.core.bakes import bounce
    from bo2_lighting.addon.core.render import pipeline
    from bo2_lighting.addon.core.render.buffers import with_camera, with_materials
    from bo2_lighting.addon.core.render.job import RenderJob
    from bo2_lighting.addon.core.render.visibility import sample_offsets
    from bo2_lighting.addon.gpu_backend import frame as gpu_frame
    from bo2_lighting.addon.gpu_backend import textures

    bo2_lighting.register()
    bpy.ops.wm.open_mainfile(filepath=str(args.blend.resolve()), load_ui=False)
    scene = bpy.context.scene
    scene.render.engine = "BO2_LIGHTING"
    kernels.load()
    print(f"{args.blend.name}: GPU {found.renderer} ({found.backend})")

    def extracted(w, h, purpose):
        scene.render.resolution_x, scene.render.resolution_y = w, h
        scene.render.resolution_percentage = 100
        core, _ = extract.extract_scene(bpy.context.evaluated_depsgraph_get(),
                                        settings.render_settings(scene, purpose),
                                        indirect=scene.bo2.indirect.use)
        return bounce.attach(core, lambda: False)

    core = extracted(width, height, "VIEWPORT")
    start = time.perf_counter()
    frame = pipeline.prepare(RenderJob(core), on_gpu=True)  # the viewport's GPU frame
    prepare_s = time.perf_counter() - start
    why = gpu_frame.unsupported(frame)
    if why:
        print(f"the GPU does not draw {why} yet")
        return 0
    offsets = sample_offsets(4, core.settings.filter_width)

    def one_sample(drawn, camera, targets):
        targets.clear()
        drawn.draw(camera, offsets[:1], targets)
        textures.read(targets.textures["total_combined"])  # waits for the GPU

    cam = core.camera
    start = time.perf_counter()
    drawn = gpu_frame.GPUFrame(frame)
    targets = gpu_frame.Targets(width, height, ("combined",))
    one_sample(drawn, cam, targets)
    print(f"first GPU image {width}x{height}, shaders compiled: "
          f"{time.perf_counter() - start:.3f} s (the frame prepared before: {prepare_s:.3f} s)")

    def moved(k):
        m = cam.world_to_camera.copy()
        m[0, 3] += 0.01 * (k + 1)
        return dataclasses.replace(cam, world_to_camera=m)

    def timed(fn):
        runs = []
        for k in range(args.repeat):
            start = time.perf_counter()
            fn(k)
            runs.append(time.perf_counter() - start)
        return statistics.median(runs)

    def material_tweak(k):
        tweaked = with_materials(frame, frame.scene) or frame
        one_sample(gpu_frame.GPUFrame(tweaked), cam, targets)

    def camera_move(k):
        one_sample(drawn, moved(k), targets)

    def object_move(k):
        fresh = pipeline.prepare(RenderJob(core), on_gpu=True)
        one_sample(gpu_frame.GPUFrame(fresh), cam, targets)

    cpu_frame = pipeline.cpu_maps(RenderJob(core), pipeline.prepare(RenderJob(core),
                                                                    on_gpu=True))

    def cpu_sample(k, prepared=cpu_frame, camera=cam):
        view = prepared if camera is cam else with_camera(prepared, camera)
        pipeline.render_frame(RenderJob(view.scene), frame=view, offsets=offsets[:1])

    rows = [("material tweak", material_tweak, lambda k: cpu_sample(
                k, with_materials(cpu_frame, cpu_frame.scene) or cpu_frame)),
            ("camera move", camera_move, lambda k: cpu_sample(k, cpu_frame, moved(k))),
            ("object move", object_move, lambda k: cpu_sample(
                k, pipeline.prepare(RenderJob(core))))]
    for name, gpu_fn, cpu_fn in rows:
        print(f"viewport {width}x{height}, {name}, full image: GPU {timed(gpu_fn):.3f} s, "
              f"CPU {timed(cpu_fn):.3f} s")

    final = extracted(final_w, final_h, "FINAL")
    samples = max(1, int(final.settings.samples))

    def gpu_final(k):
        prepared = pipeline.prepare(RenderJob(final), on_gpu=True)
        gpu_frame.render(prepared, sample_offsets(samples, final.settings.filter_width))

    def cpu_final(k):
        pipeline.render_frame(RenderJob(final))

    print(f"F12 {final_w}x{final_h}, {samples} samples, every pass read back: "
          f"GPU {timed(gpu_final):.3f} s, CPU {timed(cpu_final):.3f} s")
    if not args.skip_cycles:
        from bench_viewport import cycles  # (this folder is on the path: run as a script)

        cycles(scene, width, height)
    return 0


if __name__ == "__main__":
    sys.exit(main())
