"""Render the talk's old-versus-new comparisons on ``demo_blends/old_vs_new.blend``.

Usage: python tools/render_old_vs_new.py OUT_DIR [--samples N]

Bakes the scene's probes if they are missing, then renders each pair with BO2 Lighting and
writes ``OUT_DIR/<pair>.png``: the old method on the left, the new on the right, labelled,
through the scene's view transform, and prints the mean absolute difference of each pair:

- normalization: BO1 average irradiance | BO2 directional irradiance
  (slides "Environment map normalization: old method / new method");
- prefilter: BO1 angular Gaussian | BO2 cosine power
  (slides "Environment map pre-filtering: old method / new method");
- env_brdf: BO1 environment "Fresnel" | BO2 EnvironmentBRDF
  (slides "Environment BRDF: old method / new method");
- direct: exact terms (Schlick Fresnel, Schlick-Smith) | BO2 optimized terms
  (bonus slides "Black Ops II: new Fresnel / visibility approximation").
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import bpy
import numpy as np

import bo2_lighting
from bo2_lighting.addon.blender import compare as blender_compare
from bo2_lighting.addon.blender import images as blender_images
from bo2_lighting.addon.blender import probes
from bo2_lighting.addon.core import imaging

ROOT = Path(__file__).resolve().parents[1]
BLEND = ROOT / "demo_blends" / "old_vs_new.blend"
PAIRS = {
    "normalization": ("normalization", ("bo1", "BO1 normalization"),
                      ("bo2", "BO2 normalization")),
    "prefilter": ("prefilter", ("bo1", "BO1 angular Gaussian"), ("bo2", "BO2 cosine power")),
    "env_brdf": ("env_brdf", ("bo1", "BO1 environment Fresnel"),
                 ("bo2", "BO2 environment BRDF")),
    "direct": ("specular_model", ("reference", "exact direct terms"),
               ("bo2", "BO2 optimized terms")),
}


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("out", type=Path)
    parser.add_argument("--samples", type=int, default=8)
    args = parser.parse_args()
    args.out.mkdir(parents=True, exist_ok=True)
    bo2_lighting.register()
    bpy.ops.wm.open_mainfile(filepath=str(BLEND))
    scene = bpy.context.scene
    scene.render.engine = "BO2_LIGHTING"
    scene.bo2.samples = args.samples
    folder = probes.bake_folder(scene)
    if any(not probes.probe_path(folder, o.name).exists() for o in probes.probe_objects(scene)):
        assert bpy.ops.bo2.bake_probes() == {"FINISHED"}
    layer = bpy.context.view_layer.name
    for name, (prop, (old, old_label), (new, new_label)) in PAIRS.items():
        images = []
        for value in (old, new):
            setattr(scene.bo2, prop, value)
            bpy.ops.render.render()
            path = args.out / f".{name}_{value}.exr"
            blender_compare.save_result(scene, path)
            images.append(blender_compare.read_exr(path, layer)["Combined"][..., :3])
            path.unlink()
        setattr(scene.bo2, prop, scene.bo2.bl_rna.properties[prop].default)
        diff = float(np.abs(images[0] - images[1]).mean())
        left, right = blender_images.to_display(scene, images)
        picture = imaging.side_by_side(left, right, ((f"old: {old_label}", "old"),
                                                     (f"new: {new_label}", "new")))
        imaging.write_png(args.out / f"{name}.png", picture)
        print(f"{name:14s} mean |old - new| = {diff:.4f}  -> {args.out / (name + '.png')}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
