"""Render the talk's old-versus-new comparisons, each on a scene made to show it.

Usage: python tools/render_old_vs_new.py OUT_DIR [--samples N]

For each pair: opens its scene (``demo_blends/pair_<name>.blend``, built by
``demo_blends/build_talk_pairs.py`` when missing; the direct terms: ``old_vs_new.blend``),
bakes its probes (their files are checked: a stale bake is baked again), renders the old and
the new method with BO2 Lighting and writes ``OUT_DIR/<pair>.png``: the old method on the left,
the new on the right, labelled, through the scene's view transform, and
``OUT_DIR/<pair>_difference.png``, |old - new| in a colour map. Prints the mean and the 99th
percentile of |old - new| (scene-linear RGB) of each pair:

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
import subprocess
import sys
from pathlib import Path

import bpy
import numpy as np

import bo2_lighting
from bo2_lighting.addon.blender import compare as blender_compare
from bo2_lighting.addon.blender import images as blender_images
from bo2_lighting.addon.blender import probes, props
from bo2_lighting.addon.core.review import compare, imaging

ROOT = Path(__file__).resolve().parents[1]
BLENDS = ROOT / "demo_blends"
PAIRS = {
    "normalization": ("pair_normalization", "indirect.normalization", ("bo1", "BO1 normalization"),
                      ("bo2", "BO2 normalization")),
    "prefilter": ("pair_prefilter", "indirect.prefilter", ("bo1", "BO1 angular Gaussian"),
                  ("bo2", "BO2 cosine power")),
    "env_brdf": ("pair_env_brdf", "indirect.env_brdf", ("bo1", "BO1 environment Fresnel"),
                 ("bo2", "BO2 environment BRDF")),
    "direct": ("old_vs_new", "specular_model", ("reference", "exact direct terms"),
               ("bo2", "BO2 optimized terms")),
}


def open_scene(stem: str):
    blend = BLENDS / f"{stem}.blend"
    if not blend.exists():
        script = "build_talk_pairs.py" if stem.startswith("pair_") else f"build_{stem}.py"
        subprocess.run([sys.executable, str(BLENDS / script)], check=True,
                       capture_output=True)
    bpy.ops.wm.open_mainfile(filepath=str(blend))
    scene = bpy.context.scene
    if any(probes.bake_state(o).state != "BAKED" for o in probes.probe_objects(scene)):
        assert bpy.ops.bo2.bake_probes() == {"FINISHED"}
    return scene


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("out", type=Path)
    parser.add_argument("--samples", type=int, default=8)
    args = parser.parse_args()
    args.out.mkdir(parents=True, exist_ok=True)
    bo2_lighting.register()
    for name, (stem, prop, (old, old_label), (new, new_label)) in PAIRS.items():
        scene = open_scene(stem)
        scene.render.engine = "BO2_LIGHTING"
        scene.bo2.samples = args.samples
        layer = bpy.context.view_layer.name
        images = []
        for value in (old, new):
            props.set_setting(scene, prop, value)
            bpy.ops.render.render()
            path = args.out / f".{name}_{value}.exr"
            blender_compare.save_result(scene, path)
            images.append(blender_compare.read_exr(path, layer)["Combined"][..., :3])
            path.unlink()
        diff = np.abs(images[0] - images[1])
        mean, p99 = float(diff.mean()), float(np.percentile(diff, 99))
        left, right = blender_images.to_display(scene, images)
        picture = imaging.side_by_side(left, right, ((f"old: {old_label}", "old"),
                                                     (f"new: {new_label}", "new")))
        imaging.write_png(args.out / f"{name}.png", picture)
        y = np.abs(compare.luminance(images[0]) - compare.luminance(images[1]))
        top = compare.nice_ceil(float(np.percentile(y, 99.5)) or 1.0)
        imaging.write_png(args.out / f"{name}_difference.png", imaging.heat_map(
            y, top, f"|Y old - Y new|, {old_label} vs {new_label}",
            f"mean {mean:.4f}  99th percentile {p99:.4f} (RGB)"))
        print(f"{name:14s} |old - new|: mean {mean:.4f}, 99th percentile {p99:.4f}  -> "
              f"{args.out / (name + '.png')}", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
