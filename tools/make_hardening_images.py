"""Pictures of docs/engine.md's robustness section, rendered in Blender (the ``bpy`` module).

Usage: python tools/make_hardening_images.py [OUT_DIR]   (default docs/images)

``stacked_alpha_shadows.png``: a floor under a point light, two stacked planes of alpha 0.5
over it (left) and one (right), 64 samples: the shadow maps' peeled layers with the thresholds
of each layer shifted (as before: the layers' thresholds correlate, two layers let 0.10 of the
light through in stripes) and permuted per 4 x 4 block (now: 0.25, noise), with the fraction of
light measured under each. ``instances_forest.png``: the forest of ``bench_instances.py`` (fewer
instances), BO2 Lighting beside Cycles.
"""

from __future__ import annotations

import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(Path(__file__).resolve().parent))


def shadow_scene():
    import bpy

    bpy.ops.wm.read_factory_settings(use_empty=True)
    scene = bpy.context.scene
    scene.render.resolution_x, scene.render.resolution_y = 320, 160
    scene.view_settings.view_transform = "Standard"
    world = bpy.data.worlds.new("World")
    scene.world = world

    def plane(size, location, alpha):
        bpy.ops.mesh.primitive_plane_add(size=size, location=location)
        mat = bpy.data.materials.new(f"alpha {alpha}")
        if mat.node_tree is None:
            mat.use_nodes = True
        mat.node_tree.nodes["Principled BSDF"].inputs["Alpha"].default_value = alpha
        mat.node_tree.nodes["Principled BSDF"].inputs["Roughness"].default_value = 1.0
        bpy.context.object.data.materials.append(mat)

    plane(8.0, (0.0, 0.0, 0.0), 1.0)
    for z in (1.0, 1.3):
        plane(1.2, (-1.0, 0.0, z), 0.5)
    plane(1.2, (1.0, 0.0, 1.0), 0.5)
    light = bpy.data.objects.new("Lamp", bpy.data.lights.new("Lamp", "POINT"))
    light.location, light.data.energy, light.data.shadow_soft_size = (0, 0, 4.0), 1500.0, 0.05
    scene.collection.objects.link(light)
    cam = bpy.data.objects.new("Camera", bpy.data.cameras.new("Camera"))
    cam.data.type, cam.data.ortho_scale = "ORTHO", 6.0
    cam.location = (0.0, 0.0, 0.5)  # under the planes, looking down at the floor
    scene.collection.objects.link(cam)
    scene.camera = cam
    scene.render.engine = "BO2_LIGHTING"
    scene.bo2.samples = 64
    scene.bo2.indirect.use = False
    return scene


def render(scene) -> np.ndarray:
    import bpy

    from bo2_lighting.addon.blender import images

    assert bpy.ops.render.render() == {"FINISHED"}
    return images.render_result_pixels(scene)[..., :3]


def shifted_thresholds(px, py, layer):
    """The thresholds before: one interleaved gradient noise pattern shifted per layer."""
    x = np.asarray(px, np.float64) + 5.588238 * layer
    y = np.asarray(py, np.float64) + 5.588238 * layer
    return np.mod(52.9829189 * np.mod(0.06711056 * x + 0.00583715 * y, 1.0), 1.0)


def stacked_alpha_shadows(out: Path) -> None:
    import bo2_lighting
    from bo2_lighting.addon.core.render import transparency
    from bo2_lighting.addon.core.review import imaging

    bo2_lighting.register()
    scene = shadow_scene()
    bo2_lighting.register()
    lit = scene.objects["Lamp"]
    now = render(scene)
    permuted = transparency.ordered_thresholds
    transparency.ordered_thresholds = shifted_thresholds
    try:
        before = render(scene)
    finally:
        transparency.ordered_thresholds = permuted
    lit.data.use_shadow = False
    open_light = render(scene)
    pictures, labels = [], []
    for name, image in (("before: layers shifted", before), ("now: permuted per block", now)):
        frac = image[..., 0] / np.maximum(open_light[..., 0], 1e-6)
        two, one = frac[60:100, 70:90].mean(), frac[60:100, 230:250].mean()
        pictures.append(np.clip(image / max(float(open_light.max()), 1e-6), 0.0, 1.0)
                        ** (1 / 2.2))
        labels.append((f"{name}: two layers {two:.2f}, one {one:.2f}", name))
    imaging.write_png(out / "stacked_alpha_shadows.png", imaging.panels(pictures, labels))


def instances_forest(out: Path) -> None:
    import bench_instances

    from bo2_lighting.addon.blender import images
    from bo2_lighting.addon.core.review import imaging

    with tempfile.TemporaryDirectory() as tmp:
        blend = Path(tmp) / "forest.blend"
        subprocess.run([sys.executable, "-c", bench_instances.BUILD, "forest", "500", str(blend)],
                       check=True, capture_output=True)
        bo2 = Path(sys.executable).parent / "bo2"
        pictures, labels = [], []
        for engine, samples in (("bo2", 16), ("cycles", 32)):
            png = Path(tmp) / f"{engine}.png"
            subprocess.run([str(bo2), "render", str(blend), "-o", str(png), "--engine", engine,
                            "--samples", str(samples)], check=True, capture_output=True)
            pictures.append(images.read_file(png, "Non-Color")[..., :3])  # display values
            name = "BO2 Lighting" if engine == "bo2" else "Cycles"
            labels.append((f"{name}, 62,500 instances, {samples} samples", name))
        imaging.write_png(out / "instances_forest.png", imaging.panels(pictures, labels))


def main() -> int:
    out = Path(sys.argv[1]) if len(sys.argv) > 1 else ROOT / "docs" / "images"
    out.mkdir(parents=True, exist_ok=True)
    instances_forest(out)
    stacked_alpha_shadows(out)
    print(f"wrote {out / 'stacked_alpha_shadows.png'} and {out / 'instances_forest.png'}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
