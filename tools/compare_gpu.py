"""The GPU backend against the CPU path on the demo scenes: every pass's PSNR, the pixels of
Combined off by more than 4/255 after the view transform (outside edges), and pictures.

Usage: .venv52/bin/python tools/compare_gpu.py [--scenes room,first_light,...] [--scale 0.5]
                                               [--assets A.glb B.blend ...] [--out out/gpu]
                                               [--sheet PNG]

Needs a ``bpy`` whose ``gpu`` module opens a context in background mode (Blender 5.2 LTS).
Each scene is extracted as F12 extracts it, prepared once, and rendered by
``pipeline.render_frame`` (CPU) and ``gpu_backend.frame.render`` (GPU) from the same frame;
``<out>/<scene>.png`` shows CPU | GPU | the difference x 10 (sRGB). ``--assets``: glTF files
(imported with Blender's importer) or .blend files without a camera, each staged as
``tools/make_asset_images.py`` stages it (one sun, a framing camera) at 320x240.
``--sheet``: every picture also in one PNG, one row per scene.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
SCENES = ("first_light", "room", "closed_room", "artist_room", "outdoor", "material_spheres")


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--scenes", default=",".join(SCENES))
    parser.add_argument("--scale", type=float, default=0.5)
    parser.add_argument("--assets", nargs="*", type=Path, default=[])
    parser.add_argument("--out", type=Path, default=ROOT / "out" / "gpu")
    parser.add_argument("--sheet", type=Path)
    args = parser.parse_args()

    import bpy

    import bo2_lighting
    from bo2_lighting.addon.gpu_backend import device

    found = device.open_context(bpy.app.binary_path)
    if not found.ok:
        print(f"compare_gpu: no GPU context: {found.reason}", file=sys.stderr)
        return 1
    sys.path.insert(0, str(ROOT / "tests" / "gpu"))
    import compare

    from bo2_lighting.addon.blender import extract, settings
    from bo2_lighting.addon.core import kernels
    from bo2_lighting.addon.core.bakes import bounce
    from bo2_lighting.addon.core.render import pipeline
    from bo2_lighting.addon.core.render.job import RenderJob
    from bo2_lighting.addon.core.render.visibility import sample_offsets
    from bo2_lighting.addon.core.review import imaging
    from bo2_lighting.addon.gpu_backend import frame as gpu_frame

    bo2_lighting.register()
    kernels.load()
    args.out.mkdir(parents=True, exist_ok=True)
    print(f"GPU: {found.renderer}")
    sys.path.insert(0, str(ROOT / "tools"))
    from make_asset_images import stage

    jobs = [(name, ROOT / "demo_blends" / f"{name}.blend")
            for name in args.scenes.split(",") if name]
    sheet = []
    for name, path in jobs + [(p.stem, p) for p in args.assets]:
        if path.suffix == ".blend":
            bpy.ops.wm.open_mainfile(filepath=str(path), load_ui=False)
        else:
            bpy.ops.wm.read_factory_settings(use_empty=True)
            bo2_lighting.register()
            bpy.ops.import_scene.gltf(filepath=str(path))
        scene = bpy.context.scene
        if path in args.assets:
            scene.render.engine = "BO2_LIGHTING"
            stage(scene, 320, 240)
        else:
            scene.render.resolution_percentage = round(100 * args.scale)
        core, _ = extract.extract_scene(bpy.context.evaluated_depsgraph_get(),
                                        settings.render_settings(scene, "FINAL"),
                                        indirect=scene.bo2.indirect.use)
        core = bounce.attach(core, lambda: False)
        frame = pipeline.prepare(RenderJob(core))
        why = gpu_frame.unsupported(frame)
        if why:
            print(f"{name}: the GPU does not draw {why} yet")
            continue
        cpu = pipeline.render_frame(RenderJob(core), frame=frame)
        gpu_passes = gpu_frame.render(frame, sample_offsets(
            max(1, core.settings.samples), core.settings.filter_width))
        psnr = {p: round(float(compare.psnr(image, cpu[p][..., :image.shape[-1]])), 1)
                for p, image in gpu_passes.items()}
        off, edges = compare.off_pixels(gpu_passes, cpu)
        cam = core.camera
        print(f"{name} {cam.width}x{cam.height}: PSNR {psnr}; Combined off by > 4/255: "
              f"{off} of {cam.width * cam.height} pixels (edges left out: {edges})")
        a = compare.srgb(cpu["Combined"][..., :3])
        b = compare.srgb(gpu_passes["Combined"][..., :3])
        picture = np.concatenate([a, b, np.clip(10 * np.abs(a - b), 0, 1)], axis=1)
        imaging.write_png(args.out / f"{name}.png", picture)
        sheet.append(picture)
    if args.sheet and sheet:
        width = max(p.shape[1] for p in sheet)
        imaging.write_png(args.sheet, np.concatenate(
            [np.pad(p, ((0, 0), (0, width - p.shape[1]), (0, 0))) for p in sheet]))
    return 0


if __name__ == "__main__":
    sys.exit(main())
