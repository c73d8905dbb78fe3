"""Blender for the ``bo2`` command: a .blend loaded with the add-on registered, render options
applied to its scene, one frame rendered to a file, an image file read for SH projection.

Importing this module does not load ``bpy`` (``bo2 --help`` stays instant and a bad path is
reported before Blender starts); each function imports what it needs. Errors meant for the user
as they are raise ``HeadlessError``; Blender's own errors pass unchanged.
"""

from __future__ import annotations

import os
import time
from pathlib import Path

ENGINES = {"bo2": "BO2_LIGHTING", "cycles": "CYCLES"}  # --engine -> render engine
# File name suffix -> image format; OPEN_EXR is written multilayer (every pass), 32-bit float.
IMAGE_FORMATS = {".png": "PNG", ".exr": "OPEN_EXR", ".jpg": "JPEG", ".jpeg": "JPEG",
                 ".tif": "TIFF", ".tiff": "TIFF"}
_BLEND_MAGIC = (b"BLENDER", b"\x1f\x8b", b"\x28\xb5\x2f\xfd")  # plain, gzip, zstd


class HeadlessError(Exception):
    """A failure with a one-line message for the user."""


def check_blend(path: Path) -> None:
    """Fail clearly on a missing, unreadable or non-.blend file before Blender sees it."""
    if path.is_dir():
        raise HeadlessError(f"{path}: is a folder, not a .blend file")
    if not path.is_file():
        raise HeadlessError(f"{path}: no such .blend file")
    try:
        with open(path, "rb") as fh:
            head = fh.read(8)
    except OSError as exc:
        raise HeadlessError(f"{path}: cannot read: {exc.strerror}") from exc
    if not any(head.startswith(m) for m in _BLEND_MAGIC):
        raise HeadlessError(f"{path}: not a Blender file (corrupt or wrong format)")


def load_blend(path: Path, terminal: int = 2):
    """Check ``path``, import ``bpy``, register the add-on and open the file; returns its
    scene. Ctrl-C from then on stops renders and bakes (``interrupt``; ``terminal``: the file
    descriptor of the user's stderr)."""
    check_blend(path)
    import bpy

    from .. import register
    from . import interrupt

    interrupt.install(terminal)  # bpy took Ctrl-C from Python: give it to renders and bakes
    register()
    bpy.ops.wm.open_mainfile(filepath=str(path.resolve()), load_ui=False)
    interrupt.check()
    return bpy.context.scene


def view_layer():
    """The view layer of the loaded file."""
    import bpy

    return bpy.context.view_layer


def depsgraph():
    """The evaluated dependency graph of the loaded file."""
    import bpy

    return bpy.context.evaluated_depsgraph_get()


def has_camera(scene) -> bool:
    """Whether ``scene`` has an active camera (markers can bind another one per frame)."""
    return scene.camera is not None


def current_scene():
    """The loaded file's scene."""
    import bpy

    return bpy.context.scene


def current_frame(scene) -> int:
    """The scene's current frame."""
    return scene.frame_current


def set_frame(scene, frame: int) -> None:
    """Go to ``frame`` (animation and drivers evaluated)."""
    scene.frame_set(frame)


MIN_SIDE, MAX_SIDE = 4, 65536  # Blender's least and greatest resolution_x and resolution_y


def render_size(width: int, height: int) -> tuple[int, int, int] | None:
    """Blender's (resolution_x, resolution_y, resolution_percentage) that give exactly
    ``width`` x ``height`` pixels: sides under ``MIN_SIDE`` are rendered from 2 or 4 times the
    size at 50 or 25 % (Blender's size is x * percentage / 100 in integers). None when no
    such setting exists (one side under 4 pixels and the other too large to grow)."""
    k = next(k for k in (1, 2, 4) if k * min(width, height) >= MIN_SIDE)
    if k * max(width, height) > MAX_SIDE:
        return None
    return k * width, k * height, 100 // k


def set_resolution(scene, resolution: tuple[int, int]) -> None:
    """Output size (width, height) in pixels, exactly (``render_size``)."""
    x, y, percentage = render_size(*resolution)
    scene.render.resolution_x, scene.render.resolution_y = x, y
    scene.render.resolution_percentage = percentage


def set_samples(scene, engine: str, samples: int) -> None:
    """Samples per pixel of ``engine`` ("bo2" or "cycles")."""
    if engine == "cycles":
        scene.cycles.samples = samples
    else:
        scene.bo2.samples = samples


def enable_all_passes(layer, engine: str) -> None:
    """Turn on every pass the chosen engine writes (BO2: the engine's passes but Combined, which
    stays as the view layer has it; Cycles: the same names without the BO2 material passes;
    both: the three Cryptomatte passes)."""
    from ..core.render.cryptomatte import KINDS
    from ..core.render.passes import PASSES
    from . import passes

    for name in PASSES:
        if name == "Combined":
            continue
        if engine == "bo2" or not passes.FLAGS[name].startswith("bo2."):
            passes.set_enabled(layer, name)
    for kind in KINDS:
        setattr(layer, f"use_pass_cryptomatte_{kind.lower()}", True)


def apply_render_options(scene, engine: str, resolution: tuple[int, int] | None = None,
                         samples: int | None = None, specular_model: str | None = None,
                         all_passes: bool = False) -> None:
    """``bo2 render``'s options on the loaded scene: ``engine`` ("bo2" or "cycles"), and where
    given the resolution, its samples, the BO2 specular model and every pass on."""
    scene.render.engine = ENGINES[engine]
    if resolution:
        set_resolution(scene, resolution)
    if specular_model:
        scene.bo2.specular_model = specular_model
    if samples:
        set_samples(scene, engine, samples)
    if all_passes:
        enable_all_passes(view_layer(), engine)


def apply_comparison_options(scene, frame: int | None = None,
                             resolution: tuple[int, int] | None = None,
                             samples: int | None = None,
                             cycles_samples: int | None = None) -> None:
    """``bo2 compare``'s and ``bo2 report``'s options on the loaded scene, where given: the
    frame, the resolution, BO2's samples and Cycles'."""
    if frame is not None:
        set_frame(scene, frame)
    if resolution:
        set_resolution(scene, resolution)
    if samples:
        set_samples(scene, "bo2", samples)
    if cycles_samples:
        set_samples(scene, "cycles", cycles_samples)


def render_frame(scene, path: Path, fmt: str) -> tuple[float, list[str]]:
    """Render the scene's current frame and write it to ``path`` (replaced atomically) as
    ``fmt``, a value of ``IMAGE_FORMATS``; returns the render time in seconds and the engine's
    warnings (BO2 Lighting's; none for Cycles).
    Raises ``images.ImageError`` when the image cannot be written."""
    import bpy

    from . import engine, images, interrupt, worlds

    if scene.render.engine == "BO2_LIGHTING":
        worlds.ensure(scene)  # a world of any nodes: rendered by Cycles first
    start = time.perf_counter()
    with engine.listening() as said:
        bpy.ops.render.render(write_still=False)
    seconds = time.perf_counter() - start
    interrupt.check()  # a render stopped by Ctrl-C is not written
    warnings = [m.text for m in said.messages if m.kind == "WARNING"]
    with interrupt.writing():
        if fmt == "OPEN_EXR":
            images.save_render_result(scene, path.resolve(), "OPEN_EXR_MULTILAYER", "32")
        else:
            images.save_render_result(scene, path.resolve(), fmt)
    return seconds, warnings


def read_equirect(path: Path):
    """Read an image as Blender does (``bpy.data.images.load``), for SH projection.

    Float images (HDR, EXR) are scene-linear already; 8-bit images in the sRGB colour space are
    decoded to linear (``Image.pixels`` holds their encoded values), other 8-bit images are
    taken as linear data.

    path:    image file
    returns: (H, W, 3) float32 linear RGB, row 0 at the top (a greyscale image is repeated)
    """
    import numpy as np

    if path.is_dir():
        raise HeadlessError(f"{path}: is a directory, not an image")
    if not path.is_file():
        raise HeadlessError(f"{path}: no such image file")
    if not os.access(path, os.R_OK):
        raise HeadlessError(f"{path}: cannot read the file (permission denied)")
    from . import images

    try:
        pixels = images.read_file(path.resolve(), linear=True)
    except images.ImageError:
        raise HeadlessError(f"{path}: not an image Blender can read") from None
    rgb = pixels[..., :3] if pixels.shape[2] >= 3 else np.repeat(pixels[..., :1], 3, -1)
    return np.ascontiguousarray(rgb, np.float32)
