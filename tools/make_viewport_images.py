"""Pictures of the viewport for the docs: the look-dev views and the progressive refinement.

Usage: python tools/make_viewport_images.py [--blend demo_blends/room.blend] [--out docs/images]

Bakes the scene's light probes into a temporary folder, then drives the viewport renderer
(``blender/viewport.py``, as the 3D viewport's Rendered shading does) through the scene camera
and writes:
- ``lookdev_views.png``: every look-dev view of the header's selector, labelled;
- ``viewport_refinement.png``: the first image after a change (a quarter of the resolution),
  the first full-resolution sample and the finished image.
Colour views are shown with the Standard view transform (sRGB), data views as they are.
Run with a Python that has ``bpy`` (``.venv/bin/python``).
"""

from __future__ import annotations

import argparse
import sys
import tempfile
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
W, H = 480, 270


def display(image) -> np.ndarray:
    """(H, W, 3) display values of a viewport image (rows bottom to top)."""
    from bo2_lighting.addon.core.formulas.texture import linear_to_srgb

    rgb = np.asarray(image.pixels[::-1, :, :3], np.float32)
    return rgb if image.data else linear_to_srgb(np.clip(rgb, 0.0, 1.0))


def grid(tiles: list[tuple[str, np.ndarray]], columns: int) -> np.ndarray:
    """Labelled tiles, ``columns`` per row, on the docs' dark background."""
    from bo2_lighting.addon.core.review import imaging

    scale = 2
    strip = 8 * scale + 6
    h, w = tiles[0][1].shape[:2]
    rows = -(-len(tiles) // columns)
    gap = 4
    out = np.full((rows * (h + strip + gap), columns * (w + gap) - gap, 3), 0.11, np.float32)
    for k, (label, tile) in enumerate(tiles):
        r, c = divmod(k, columns)
        y, x = r * (h + strip + gap), c * (w + gap)
        imaging.draw_text(out, label, x + 4, y + 3, scale, (0.95, 0.95, 0.95))
        out[y + strip:y + strip + h, x:x + w] = tile
    return out


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--blend", type=Path, default=ROOT / "demo_blends" / "room.blend")
    parser.add_argument("--out", type=Path, default=ROOT / "docs" / "images")
    args = parser.parse_args()

    import bpy

    import bo2_lighting
    from bo2_lighting.addon.blender import bake, probes, viewport
    from bo2_lighting.addon.core import kernels
    from bo2_lighting.addon.core.render import viewport as core_viewport
    from bo2_lighting.addon.core.review import imaging

    bo2_lighting.register()
    bpy.ops.wm.open_mainfile(filepath=str(args.blend.resolve()), load_ui=False)
    scene = bpy.context.scene
    kernels.load()
    with tempfile.TemporaryDirectory() as folder:
        scene.bo2.bake_folder = folder
        scene.bo2.indirect.use = True
        depsgraph = bpy.context.evaluated_depsgraph_get()
        for _ in bake.bake_steps(scene, probes.probe_objects(scene), "BO2"):
            pass
        cam = scene.camera.evaluated_get(depsgraph)
        camera = core_viewport.view_camera(
            cam.matrix_world.inverted(), cam.calc_matrix_camera(depsgraph, x=W, y=H), W, H)

        scene.bo2.viewport.samples = 8
        images = []
        view = viewport.Viewport(on_image=lambda: images.append(view.session.image()))
        view.sync(bpy.context.evaluated_depsgraph_get())
        view.set_camera(camera)
        view.session.wait(600)
        steps = [images[0], next(i for i in images if i.samples == 1), images[-1]]
        labels = ["First image: 1/4 resolution", "Then full resolution, 1 sample",
                  f"Finished: {steps[-1].samples} samples"]
        tiles = []
        for label, image in zip(labels, steps, strict=True):
            small = display(image)  # nearest-neighbour up to W x H, as the viewport stretches it
            rows = np.arange(H) * small.shape[0] // H
            cols = np.arange(W) * small.shape[1] // W
            tiles.append((label, small[rows][:, cols]))
        imaging.write_png(args.out / "viewport_refinement.png", grid(tiles, 3))

        tiles = []
        for key, spec in core_viewport.VIEWS.items():
            view.session.set_view(key)
            tiles.append((spec.label, display(view.session.image())))
        imaging.write_png(args.out / "lookdev_views.png", grid(tiles, 4))
        view.close()
    for name in ("viewport_refinement.png", "lookdev_views.png"):
        print(args.out / name)
    bo2_lighting.unregister()
    return 0


if __name__ == "__main__":
    sys.exit(main())
