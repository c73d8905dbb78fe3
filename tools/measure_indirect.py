"""Indirect light beside Cycles: bake, render both engines, print the figures of docs/probes.md.

Usage: python tools/measure_indirect.py OUT_DIR [BLEND ...] [--bounces N] [--cycles-samples N]
                                        [--cycles-bounces N] [--reuse-cycles] [--no-leak-fixes]
                                        [--lightmaps]

For each .blend (default: the demo room, the closed room, the artist's room and the outdoor
scene of ``demo_blends``): bakes its probes, if it has any, with BO2 Lighting into
OUT_DIR/<name>/bake, renders BO2 Lighting and Cycles (full global
illumination: ``--cycles-bounces`` total, diffuse and glossy bounces, 32 by default, 0 for the
scene's own; the scene's Cycles samples or ``--cycles-samples``) through ``bo2 compare``'s
comparison, and prints

- PSNR of the whole image (display-referred, as ``bo2 compare``);
- the Diffuse Indirect pass's mean relative error (Cycles' times its Diffuse Color);
- the metal surfaces' Combined mean relative error: the pixels whose material has a Pass Index
  of 1 in Cycles' Material Index pass (given here to every material whose Principled BSDF has
  a Metallic of 0.5 or more);

- the same with the world's light on both sides ("world's light included"): Cycles counts the
  world's light that reaches a surface unscattered as direct (Diffuse Direct), BO2 as indirect
  with the probes' (the talk's split), so Cycles' part of it, its Diffuse Direct less that of
  a render of the lamps alone (no world, no bounce: ``cycles_lamps.exr``), is added to Cycles'
  side; over every pixel, then over the pixels within ``CONTACT`` of a contact (a ball of that
  radius resting on the surface, at Cycles' Position and Normal, touches another surface);
- the Combined pass's mean relative error under objects (the same with a ball of ``UNDER``);

the relative errors over blocks of ``BLOCK`` x ``BLOCK`` pixels averaged (both engines alike),
so that Cycles' noise, which averaging divides by ``BLOCK``, stays well below the figures (the
block mean of the metals: over their pixels in the block);

and writes OUT_DIR/<name>/ the comparison's files plus ``indirect.png``: BO2's and Cycles'
Diffuse Indirect side by side. ``--reuse-cycles`` keeps a Cycles render already in the folder.
``--lightmaps`` bakes the lightmaps of the static objects too, after the probes (every
object of these scenes is static: the figures over all geometry are the static surfaces'),
and prints their bake time and files' size. ``--no-leak-fixes`` bakes the volumes without
validity, escape and dilation and looks them up without biases (the behaviour before them).
``--set NAME=VALUE`` sets one of the scene's BO2 settings first, by its path in ``scene.bo2``
(``--set indirect.use_ambient_occlusion=False``, ``--set "indirect.sky_directions='64'"``);
``--probe-set NAME=VALUE`` one of every Volume light probe's (``--probe-set normal_bias=0.0``).

``--before-after`` measures each scene twice against one Cycles render: as it is (``after/``)
and with ``--no-leak-fixes`` and ``--before-bounces`` bounces (``before/``, 1 by default, the
former default), or with the ``--before-set NAME=VALUE`` settings, and writes
``before_after.png``: the Combined and the Diffuse Indirect passes (Cycles' with the world's
light it counts as direct) of before | after | Cycles, and ``metals.png``, the metals' part
of the Combined pass enlarged; ``--docs`` copies them to ``docs/images/indirect_<scene>.png``
and ``metals_<scene>.png``.
"""

from __future__ import annotations

import argparse
import ast
import json
import shutil
import sys
import time
from pathlib import Path

import bpy
import numpy as np

import bo2_lighting
from bo2_lighting.addon.blender import bake_files, props
from bo2_lighting.addon.blender import compare as blender_compare
from bo2_lighting.addon.blender import images as blender_images
from bo2_lighting.addon.core.review import compare, imaging

ROOT = Path(__file__).resolve().parents[1]
BLENDS = [ROOT / "demo_blends" / f"{name}.blend"
          for name in ("room", "closed_room", "artist_room", "outdoor")]
METAL_INDEX = 1
BLOCK = 4
CONTACT = 0.05  # metres: a pixel within this of another surface is at a contact
UNDER = 1.0  # metres: a pixel within this of another surface is under an object
LAMP_SAMPLES = 32


def blocks(image: np.ndarray, mask: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Means of ``image`` (H, W, C) over BLOCK x BLOCK blocks (over the ``mask`` (H, W) pixels
    of each): (H / BLOCK, W / BLOCK, C) and the blocks that hold any pixel (bool)."""
    h, w = (s - s % BLOCK for s in image.shape[:2])
    m = np.ones((h, w), np.float64) if mask is None else mask[:h, :w].astype(np.float64)
    shape = (h // BLOCK, BLOCK, w // BLOCK, BLOCK)
    count = m.reshape(shape).sum((1, 3))
    total = (image[:h, :w].astype(np.float64) * m[..., None]).reshape(*shape, -1).sum((1, 3))
    return total / np.maximum(count, 1.0)[..., None], count > 0


def lamps_only(scene, layer, path: Path) -> None:
    """Render with Cycles the scene's lamps' direct light alone (no world, no bounce) into the
    EXR at ``path``: the part of Cycles' Diffuse Direct pass that is not the world's."""
    r, c = scene.render, scene.cycles
    saved = (r.engine, scene.world, c.samples, c.max_bounces, layer.use_pass_diffuse_direct)
    try:
        r.engine, scene.world, c.samples, c.max_bounces = "CYCLES", None, LAMP_SAMPLES, 0
        layer.use_pass_diffuse_direct = True
        bpy.ops.render.render(layer=layer.name)
        blender_compare.save_result(scene, path)
    finally:
        (r.engine, scene.world, c.samples, c.max_bounces,
         layer.use_pass_diffuse_direct) = saved


def contact_masks(scene, position: np.ndarray, normal: np.ndarray):
    """(H, W) bool masks from Cycles' Position and Normal passes: the pixels within
    ``CONTACT`` of a contact (the ball of that radius resting on the surface touches another
    surface), and those ``UNDER`` an object (the same with a ball of ``UNDER`` metres)."""
    from mathutils import Vector
    from mathutils.bvhtree import BVHTree

    depsgraph = bpy.context.evaluated_depsgraph_get()
    verts, polys = [], []
    for obj in depsgraph.objects:
        if obj.type != "MESH":
            continue
        mesh = obj.to_mesh()
        m = obj.matrix_world
        base = len(verts)
        verts += [m @ v.co for v in mesh.vertices]
        polys += [[base + i for i in p.vertices] for p in mesh.polygons]
        obj.to_mesh_clear()
    tree = BVHTree.FromPolygons(verts, polys)
    h, w = position.shape[:2]
    masks = np.zeros((2, h, w), bool)
    p = position.reshape(-1, 3)
    n = normal.reshape(-1, 3)
    ok = np.flatnonzero(np.isfinite(p).all(1) & (np.abs(n).sum(1) > 0.5))
    for k, radius in enumerate((CONTACT, UNDER)):
        flat = masks[k].reshape(-1)
        for i in ok:
            centre = Vector(p[i] + radius * n[i])
            hit = tree.find_nearest(centre, radius * 0.98)
            flat[i] = hit[0] is not None
    return masks[0], masks[1]


def no_leak_fixes(scene) -> None:
    """Volume probes as before validity: nothing invalid, no look-up biases."""
    for obj in scene.objects:
        if obj.type == "LIGHT_PROBE" and obj.data.type == "VOLUME":
            d = obj.data
            d.dilation_threshold, d.escape_bias = 0.0, 0.0
            d.normal_bias = d.view_bias = 0.0
            d.facing_bias = 1e6  # every sample weighs alike: plain trilinear


def measure(blend: Path, out: Path, args, bounces: int = 0, leak_fixes: bool = True,
            reuse_cycles: bool = False, settings: tuple = ()) -> dict:
    """Bake, render both engines into ``out`` and measure (the module docstring); the figures,
    and the passes of both engines under "bo2" and "cycles", and Cycles' diffuse light of the
    world that reaches a surface unscattered under "world_direct". ``settings``: NAME=VALUE
    items of the scene's BO2 settings, after ``--set``'s."""
    bpy.ops.wm.open_mainfile(filepath=str(blend))
    scene = bpy.context.scene
    scene.render.engine = "BO2_LIGHTING"
    scene.bo2.bake_folder = str(out / "bake")
    if bounces:
        scene.bo2.probes.bounces = bounces
    if args.cycles_samples:
        scene.cycles.samples = args.cycles_samples
    if args.cycles_bounces:
        c = scene.cycles
        c.max_bounces = c.diffuse_bounces = c.glossy_bounces = args.cycles_bounces
    if not leak_fixes:
        no_leak_fixes(scene)
    for item in [*args.set, *settings]:  # NAME=VALUE of BO2 settings, as Python literals
        name, _, value = item.partition("=")
        props.set_setting(scene, name, ast.literal_eval(value))
    for item in args.probe_set:  # NAME=VALUE of every Volume probe's data
        name, _, value = item.partition("=")
        for obj in scene.objects:
            if obj.type == "LIGHT_PROBE" and obj.data.type == "VOLUME":
                setattr(obj.data, name, ast.literal_eval(value))
    for mat in bpy.data.materials:
        nodes = mat.node_tree.nodes if mat.node_tree else []
        if any(n.type == "BSDF_PRINCIPLED" and n.inputs["Metallic"].default_value >= 0.5
               for n in nodes):
            mat.pass_index = METAL_INDEX
    start = time.perf_counter()
    if any(o.type == "LIGHT_PROBE" for o in scene.objects):  # an open scene may have none
        assert bpy.ops.bo2.bake_probes() == {"FINISHED"}
    bake_seconds = time.perf_counter() - start
    lightmap_seconds, lightmap_bytes, seam_figures = 0.0, 0, {}
    if args.lightmaps:
        start = time.perf_counter()
        assert bpy.ops.bo2.bake_lightmaps() == {"FINISHED"}
        lightmap_seconds = time.perf_counter() - start
        folder = bake_files.file_folder(scene) / bake_files.LIGHTMAPS
        lightmap_bytes = sum(p.stat().st_size for p in folder.iterdir())
        seam_figures = lightmap_seams(folder)
    layer = bpy.context.view_layer
    job = blender_compare.Comparison(scene, layer, out)
    cycles_info = out / "cycles_info.json"
    try:
        job.finish("bo2", blender_compare.render_sync(job, "bo2"))
        if reuse_cycles and cycles_info.exists() and (out / "cycles.exr").exists():
            job.info["cycles"] = json.loads(cycles_info.read_text())
        else:
            job.finish("cycles", blender_compare.render_sync(job, "cycles"))
            cycles_info.write_text(json.dumps(job.info["cycles"]))
        result = job.analyse()
    finally:
        job.restore()
    bo2 = blender_compare.read_exr(out / "bo2.exr", layer.name)
    cyc = blender_compare.read_exr(out / "cycles.exr", layer.name)
    lamps_path = out / "cycles_lamps.exr"
    if not (reuse_cycles and lamps_path.exists()):
        lamps_only(scene, layer, lamps_path)
    lamps = blender_compare.read_exr(lamps_path, layer.name)
    contact, under = contact_masks(scene, cyc["Position"], cyc["Normal"])
    metal = np.rint(cyc["IndexMA"][..., 0]) == METAL_INDEX
    (a, kept), (b, _) = (blocks(x["Combined"][..., :3], metal) for x in (bo2, cyc))
    metal_error = compare.mean_relative_error(a[kept], b[kept]) if kept.any() else float("nan")
    pairs = compare.light_pairs(bo2, cyc)
    pair = pairs["DiffInd"]
    # Cycles counts the world's light that reaches a surface unscattered as direct; BO2 counts
    # it as indirect, with the probes' (the talk's split): Cycles' share of it is its direct
    # diffuse less that of the lamps alone
    world_direct = np.maximum(cyc["DiffDir"] - lamps["DiffDir"], 0.0) * cyc["DiffCol"]
    fair = (pair[0], pair[1] + world_direct)
    geometry = np.isfinite(cyc["Depth"][..., 0]) & (cyc["Depth"][..., 0] < 1e9)

    def region_error(a, b, mask):
        (x, kept), (y, _) = blocks(a, mask), blocks(b, mask)
        return compare.mean_relative_error(x[kept], y[kept]) if kept.any() else float("nan")

    left, right = blender_images.to_display(scene, list(fair))
    imaging.write_png(out / "indirect.png", imaging.side_by_side(
        left, right, (("BO2 Diffuse Indirect",) * 3, ("Cycles Diffuse Indirect",) * 3)))
    figures = {
        "psnr_db": result["image"]["psnr_db"],
        "diffuse_indirect_mre": compare.mean_relative_error(*(blocks(x)[0] for x in pair)),
        "indirect_world_mre": region_error(*fair, geometry),
        "contact_mre": region_error(*fair, contact & geometry),
        "contact_pixels": int((contact & geometry).sum()),
        "under_combined_mre": region_error(bo2["Combined"][..., :3],
                                           cyc["Combined"][..., :3], under & geometry),
        "under_pixels": int((under & geometry).sum()),
        "metal_combined_mre": metal_error,
        "metal_pixels": int(metal.sum()),
        "bake_seconds": bake_seconds,
        "lightmap_seconds": lightmap_seconds,
        "lightmap_bytes": lightmap_bytes,
        **seam_figures,
        "bo2_seconds": job.info["bo2"]["render_seconds"],
        "cycles_seconds": job.info["cycles"]["render_seconds"],
        "cycles_samples": job.info["cycles"]["samples"],
        "bo2": bo2, "cycles": cyc, "world_direct": world_direct,
    }
    return figures


def lightmap_seams(folder: Path) -> dict:
    """The lightmaps' seams: across every seam of every object (``lightmap.seam_jumps``), the
    largest jump, the share of seam points whose jump exceeds the gradient beside them, and
    the memory the images and UVs take in a frame."""
    from bo2_lighting.addon.blender import extract
    from bo2_lighting.addon.core.files import lightmap_file
    from bo2_lighting.addon.core.lighting import lightmap

    core, _ = extract.extract_scene(bpy.context.evaluated_depsgraph_get(), camera=False,
                                    indirect=False)
    meshes = {m.name: m for m in core.meshes}
    jumps, besides, memory = [], [], 0
    for path in sorted(folder.glob("*.exr")):
        meta, lm = lightmap_file.read(path)
        memory += lm.image.nbytes + lm.uvs.nbytes
        mesh = meshes.get(meta["object"])
        if mesh is None or len(mesh.positions) != len(lm.uvs):
            continue
        jump, beside = lightmap.seam_jumps(lm.image, lightmap.seams(mesh.positions, lm.uvs))
        scale = max(float(np.percentile(lm.image[..., :3], 99)), 1e-6)  # relative to the map
        jumps.append(jump / scale)
        besides.append(beside / scale)
    jump, beside = (np.concatenate(a) if a else np.zeros(0) for a in (jumps, besides))
    return {"seam_max_jump": float(jump.max(initial=0.0)),
            "seam_max_beside": float(beside.max(initial=0.0)),
            "seam_over_beside": float((jump > beside).mean()) if len(jump) else 0.0,
            "seam_points": int(len(jump)), "lightmap_frame_bytes": int(memory)}


def line(name: str, f: dict) -> str:
    lightmaps = (f", lightmaps {f['lightmap_seconds']:.1f} s "
                 f"({f['lightmap_bytes'] / 2**20:.2f} MiB of files, "
                 f"{f['lightmap_frame_bytes'] / 2**20:.2f} MiB in a frame; seams: largest jump "
                 f"{f['seam_max_jump']:.3f}, largest gradient beside {f['seam_max_beside']:.3f},"
                 f" jump above the gradient at {f['seam_over_beside'] * 100:.1f}% of "
                 f"{f['seam_points']} points)" if f["lightmap_seconds"] else "")
    return (f"{name}: PSNR {f['psnr_db']:.2f} dB, Diffuse Indirect mean relative error "
            f"{f['diffuse_indirect_mre']:.3f} (world's light included "
            f"{f['indirect_world_mre']:.3f}; within {CONTACT * 100:.0f} cm of a contact "
            f"{f['contact_mre']:.3f}, {f['contact_pixels']} px), metals' Combined "
            f"{f['metal_combined_mre']:.3f} ({f['metal_pixels']} px), Combined under objects "
            f"{f['under_combined_mre']:.3f} ({f['under_pixels']} px); bake "
            f"{f['bake_seconds']:.1f} s{lightmaps}, BO2 {f['bo2_seconds']:.2f} s, Cycles "
            f"{f['cycles_seconds']:.1f} s ({f['cycles_samples']} samples)")


def before_after(blend: Path, out: Path, args) -> None:
    after = measure(blend, out / "after", args, args.bounces, reuse_cycles=args.reuse_cycles)
    (out / "before").mkdir(parents=True, exist_ok=True)
    for name in ("cycles.exr", "cycles_info.json", "cycles_lamps.exr"):
        shutil.copyfile(out / "after" / name, out / "before" / name)
    if args.before_set:  # before: the same bake with these settings
        before = measure(blend, out / "before", args, args.bounces, reuse_cycles=True,
                         settings=tuple(args.before_set))
        told = ", ".join(args.before_set)
    else:  # before: no leak fixes, fewer bounces
        before = measure(blend, out / "before", args, args.before_bounces, leak_fixes=False,
                         reuse_cycles=True)
        told = (f"{args.before_bounces} bounce{'s' if args.before_bounces != 1 else ''}, "
                "no leak fixes")
    print(line(f"{blend.stem} before", before), flush=True)
    print(line(f"{blend.stem} after", after), flush=True)
    rows = []
    for name, color in (("Combined", None), ("DiffInd", "DiffCol")):
        cycles = after["cycles"][name][..., :3] * (after["cycles"][color] if color else 1.0)
        if color:  # with the world's light that Cycles counts as direct (``measure``)
            cycles = cycles + after["world_direct"]
        images = [before["bo2"][name][..., :3], after["bo2"][name][..., :3], cycles]
        what = "" if name == "Combined" else " Diffuse Indirect"
        rows.append(imaging.panels(blender_images.to_display(bpy.context.scene, images), (
            (f"before{what}: {told}", f"before{what}"),
            (f"after{what}", "after"), (f"Cycles{what}", "Cycles"))))
    picture = np.concatenate(rows, 0)
    imaging.write_png(out / "before_after.png", picture)
    metal = np.rint(after["cycles"]["IndexMA"][..., 0]) == METAL_INDEX
    ys, xs = np.nonzero(metal)
    crops = None
    if len(ys):
        box = (slice(max(ys.min() - 4, 0), ys.max() + 5), slice(max(xs.min() - 4, 0), xs.max() + 5))
        images = [before["bo2"]["Combined"][box][..., :3], after["bo2"]["Combined"][box][..., :3],
                  after["cycles"]["Combined"][box][..., :3]]
        zoom = max(1, 240 // images[0].shape[0])
        crops = imaging.panels([np.kron(d, np.ones((zoom, zoom, 1), np.float32))
                                for d in blender_images.to_display(bpy.context.scene, images)],
                               (("before",), ("after",), ("Cycles",)))
        imaging.write_png(out / "metals.png", crops)
    if args.docs:
        imaging.write_png(ROOT / "docs" / "images" / f"indirect_{blend.stem}.png", picture)
        if crops is not None:
            imaging.write_png(ROOT / "docs" / "images" / f"metals_{blend.stem}.png", crops)


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("out", type=Path)
    parser.add_argument("blends", type=Path, nargs="*")
    parser.add_argument("--bounces", type=int, default=0)
    parser.add_argument("--cycles-samples", type=int, default=0)
    parser.add_argument("--cycles-bounces", type=int, default=32)
    parser.add_argument("--reuse-cycles", action="store_true")
    parser.add_argument("--lightmaps", action="store_true")
    parser.add_argument("--no-leak-fixes", action="store_true")
    parser.add_argument("--before-after", action="store_true")
    parser.add_argument("--before-bounces", type=int, default=1)
    parser.add_argument("--before-set", action="append", default=[], metavar="NAME=VALUE",
                        help="--before-after: before is the same bake with these settings")
    parser.add_argument("--docs", action="store_true")
    parser.add_argument("--set", action="append", default=[], metavar="NAME=VALUE",
                        help="a BO2 setting of the scene, e.g. use_specular_occlusion=False")
    parser.add_argument("--probe-set", action="append", default=[], metavar="NAME=VALUE",
                        help="a setting of every Volume light probe, e.g. normal_bias=0.0")
    args = parser.parse_args()
    bo2_lighting.register()
    for blend in args.blends or BLENDS:
        out = args.out / blend.stem
        if not args.reuse_cycles and out.exists():
            shutil.rmtree(out)
        out.mkdir(parents=True, exist_ok=True)
        if args.before_after:
            before_after(blend.resolve(), out, args)
            continue
        f = measure(blend.resolve(), out, args, args.bounces, not args.no_leak_fixes,
                    args.reuse_cycles)
        print(line(blend.stem, f), flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
