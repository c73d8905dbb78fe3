"""Compare with Cycles: render one frame with BO2 Lighting and with Cycles, same camera and
resolution, and write both renders and their comparison into a folder (docs/compare.md).

The folder receives ``bo2.exr`` and ``cycles.exr`` (multilayer, 32-bit float, scene-linear,
every pass), ``side_by_side.png``, ``split.png`` and ``difference.png`` (display pictures) and
``metrics.json``. Pictures and display-referred metrics go through the scene's colour management:
the linear pixels are put in a float image and saved with ``Image.save_render`` as a 16-bit PNG,
which applies the scene's view transform, look, exposure, gamma and curves exactly as Blender's
render output does, then read back as display values (``images.to_display``); metrics and the
report are ``core.review.compare``, the pictures ``core.review.imaging``. The compositor is not
applied: the comparison is of the view layer's passes.

Cycles' Diffuse and Glossy light passes exclude the surface colour (Blender composites
DiffDir x DiffCol); BO2 Lighting's include it. BO2's light passes are therefore compared with
Cycles' pass times its colour pass (``"cycles_times_color": true`` in metrics.json).

``Comparison`` does it step by step: ``run`` synchronously (``bo2 compare``, scripts), the
operator ``BO2_OT_compare_cycles`` (``operators.py``) as Blender's own render jobs.
"""

from __future__ import annotations

import json
import os
import time
from pathlib import Path

import bpy

from ..core.render.passes import PASSES
from ..core.review import compare as core
from ..core.review import imaging
from ..core.system import atomic
from . import images, interrupt, passes, worlds
from . import settings as settings_of

# key -> (engine identifier, label, EXR file name)
ENGINES = {"bo2": ("BO2_LIGHTING", "BO2 Lighting", "bo2.exr"),
           "cycles": ("CYCLES", "Cycles", "cycles.exr")}
PICTURES = ("side_by_side.png", "split.png", "difference.png")
READ = (*PASSES, *passes.CYCLES_COLOR)  # the passes read back from both EXRs


class CompareError(Exception):
    """A comparison that cannot go on: one line for the user."""


# ---------------------------------------------------------------------------------------------
# Files


def output_folder(scene, setting: str = "compare_folder") -> Path:
    """A folder setting of the scene's look-dev (``scene.bo2.lookdev.<setting>``, by default
    the Compare Folder) as an absolute path."""
    settings = scene.bo2.lookdev
    label = settings.bl_rna.properties[setting].name
    text = getattr(settings, setting).strip()
    if not text:
        raise CompareError(f"no {label} is set")
    if text.startswith("//") and not bpy.data.filepath:
        raise CompareError(f"save the .blend file first, or choose an absolute {label}")
    return Path(bpy.path.abspath(text))


def prepare_folder(folder: Path) -> Path:
    """Create ``folder`` if needed; fail clearly when it cannot be written."""
    folder = Path(folder)
    try:
        folder.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise CompareError(f"{folder}: cannot create the output folder "
                           f"({exc.strerror or exc})") from None
    if not folder.is_dir() or not os.access(folder, os.W_OK | os.X_OK):
        raise CompareError(f"{folder}: the output folder is not writable")
    return folder


def save_result(scene, path: Path) -> None:
    """Write the Render Result as a multilayer 32-bit EXR at ``path`` (atomically)."""
    try:
        images.save_render_result(scene, path, "OPEN_EXR_MULTILAYER", "32", "RGBA",
                                  follow_scene=True)
    except images.ImageError as exc:
        raise CompareError(str(exc)) from None


def read_exr(path: Path, layer: str) -> dict:
    """Every pass of both engines in view layer ``layer`` of the EXR at ``path``:
    {pipeline pass name: (H, W, C) float32}."""
    return images.read_exr_passes(path, layer, READ)


# ---------------------------------------------------------------------------------------------
# Analysis


def analyse(scene, folder: Path, layer: str, info: dict) -> dict:
    """Compare ``bo2.exr`` with ``cycles.exr`` in ``folder``; write the pictures and
    ``metrics.json``; return the metrics (the JSON's content)."""
    exrs = {key: read_exr(folder / ENGINES[key][2], layer) for key in ENGINES}
    for key, layers in exrs.items():
        if "Combined" not in layers:
            raise CompareError(f"{folder / ENGINES[key][2]}: no Combined pass of view layer "
                               f"{layer!r}")
    bo2, cyc = exrs["bo2"], exrs["cycles"]
    (hb, wb), (hc, wc) = bo2["Combined"].shape[:2], cyc["Combined"].shape[:2]
    if (hb, wb) != (hc, wc):
        raise CompareError(f"resolution mismatch: BO2 Lighting rendered {wb}x{hb}, Cycles "
                           f"{wc}x{hc} (a render border or crop?); kept both EXR files")
    pairs = core.light_pairs(bo2, cyc)
    display = {name: images.to_display(scene, list(pair)) for name, pair in pairs.items()}
    view = scene.view_settings
    context = {
        "scene": scene.name,
        "blend_file": bpy.path.basename(bpy.data.filepath) or None,
        "frame": scene.frame_current,
        "view_layer": layer,
        "blender_version": bpy.app.version_string,
        "resolution": [wb, hb],
        "color_management": {
            "view_transform": view.view_transform,
            "look": view.look,
            "exposure": view.exposure,
            "gamma": view.gamma,
            "display_device": scene.display_settings.display_device,
        },
    }
    files = {name: str(folder / name) for name in
             (*(e[2] for e in ENGINES.values()), *PICTURES, "metrics.json")}
    result = core.report(pairs, display, bo2, cyc, info, context, files,
                         label=passes.readable_name)

    t_bo2, t_cyc = info["bo2"]["render_seconds"], info["cycles"]["render_seconds"]
    seconds = core.format_seconds
    labels = ((f"BO2 Lighting  {seconds(t_bo2)}", f"BO2 {seconds(t_bo2)}", "BO2"),
              (f"Cycles  {seconds(t_cyc)}", f"Cycles {seconds(t_cyc)}", "Cycles"))
    left, right = display["Combined"]
    imaging.write_png(folder / "side_by_side.png", imaging.side_by_side(left, right, labels))
    imaging.write_png(folder / "split.png", imaging.split_view(left, right, labels))
    diff, scale_max, _ = core.difference(pairs)
    imaging.write_png(folder / "difference.png", imaging.heat_map(
        diff, scale_max, "|Y BO2 - Y Cycles|, scene-linear", core.metrics_line(result["image"])))

    atomic.write_text(folder / "metrics.json", json.dumps(result, indent=2, allow_nan=False) + "\n")
    return result


# ---------------------------------------------------------------------------------------------
# Rendering


class RenderWatch:
    """Blender's ``render_complete`` and ``render_cancel`` handlers for one render."""

    def __init__(self):
        self.completed = self.cancelled = False
        self.end = 0.0
        bpy.app.handlers.render_complete.append(self._complete)
        bpy.app.handlers.render_cancel.append(self._cancel)

    def _complete(self, *_):
        self.completed, self.end = True, time.perf_counter()

    def _cancel(self, *_):
        self.cancelled, self.end = True, time.perf_counter()

    def remove(self) -> None:
        for handlers, fn in ((bpy.app.handlers.render_complete, self._complete),
                             (bpy.app.handlers.render_cancel, self._cancel)):
            if fn in handlers:
                handlers.remove(fn)


class Comparison:
    """One comparison, step by step (the modal operator and ``run`` share it): ``begin`` an
    engine, render it, ``finish`` it (its EXR), then ``analyse``; ``restore`` puts the scene's
    engine, passes and output settings back."""

    def __init__(self, scene, view_layer, folder: Path):
        if scene.camera is None:
            raise CompareError(f"scene {scene.name!r} has no active camera")
        self.scene, self.layer = scene, view_layer.name
        self.folder = prepare_folder(folder)
        self.info: dict[str, dict] = {}
        settings = scene.render.image_settings
        self._saved_engine = scene.render.engine
        self._saved_flags = {name: passes.enabled(view_layer, name) for name in READ}
        self._saved_image = [(a, getattr(settings, a)) for a in images.SETTINGS
                             if hasattr(settings, a)]
        self._view_layer = view_layer
        for name in READ:  # every pass of both engines, plus Cycles' colour passes
            passes.set_enabled(view_layer, name)

    def kept(self) -> list[Path]:
        """The EXR files written so far."""
        return [self.folder / ENGINES[k][2] for k in self.info]

    def kept_text(self) -> str:
        """"kept <files>" or "nothing written", for a message."""
        kept = self.kept()
        return "kept " + ", ".join(str(p) for p in kept) if kept else "nothing written"

    def begin(self, key: str) -> None:
        """Make ``key``'s engine the scene's, ready to render."""
        self.scene.render.engine = ENGINES[key][0]
        if key == "bo2":  # a world of any nodes: rendered by Cycles first
            worlds.ensure(self.scene)

    def finish(self, key: str, seconds: float) -> None:
        """Save the Render Result of ``key``'s render and note its time and settings."""
        path = self.folder / ENGINES[key][2]
        save_result(self.scene, path)
        scene = self.scene
        combined = read_exr(path, self.layer).get("Combined")
        if combined is None:
            raise CompareError(f"the {ENGINES[key][1]} render produced no image")
        info = {"engine": ENGINES[key][0], "render_seconds": seconds,
                "resolution": [combined.shape[1], combined.shape[0]], "file": str(path)}
        if key == "bo2":
            used = settings_of.render_settings(scene)
            info.update(samples=used.samples, specular_model=used.specular_model,
                        indirect=scene.bo2.indirect.use)
        else:
            c = scene.cycles
            info.update(samples=c.samples, adaptive_sampling=c.use_adaptive_sampling,
                        denoising=c.use_denoising, device=c.device)
        self.info[key] = info

    def analyse(self) -> dict:
        return analyse(self.scene, self.folder, self.layer, self.info)

    def restore(self) -> None:
        """Undo the changes to the scene (best effort: a value Blender refuses is skipped)."""
        settings = self.scene.render.image_settings
        for obj, values in ((self.scene.render, [("engine", self._saved_engine)]),
                            (settings, self._saved_image)):
            for attr, value in values:
                try:
                    setattr(obj, attr, value)
                except (TypeError, ValueError, AttributeError, ReferenceError):
                    pass
        for name, on in self._saved_flags.items():
            try:
                passes.set_enabled(self._view_layer, name, on)
            except (TypeError, ValueError, AttributeError, ReferenceError):
                pass


def render_sync(job: Comparison, key: str) -> float:
    """Render ``key``'s engine now (blocking); its render time in seconds."""
    job.begin(key)
    watch = RenderWatch()
    label = ENGINES[key][1]
    try:
        start = time.perf_counter()
        bpy.ops.render.render(layer=job.layer, scene=job.scene.name)
        seconds = time.perf_counter() - start
        interrupt.check()  # the bo2 command's Ctrl-C: nothing of this render is kept
    except RuntimeError as exc:
        text = str(exc).strip().splitlines()[-1].removeprefix("Error: ") if str(exc) else ""
        raise CompareError(f"the {label} render failed: {text}") from None
    finally:
        watch.remove()
    if watch.cancelled:
        raise CompareError(f"the {label} render was cancelled; {job.kept_text()}")
    return seconds


def run(scene, view_layer, folder: Path, on_stage=None) -> dict:
    """The whole comparison, synchronously: both renders, their EXRs, pictures and metrics.

    on_stage: called with "BO2 Lighting render", "Cycles render", "comparison" as each starts
    returns:  the metrics (metrics.json's content)
    """
    job = Comparison(scene, view_layer, folder)
    try:
        for key in ENGINES:
            if on_stage:
                on_stage(f"{ENGINES[key][1]} render")
            job.finish(key, render_sync(job, key))
        if on_stage:
            on_stage("comparison")
        return job.analyse()
    finally:
        job.restore()


def show_images(context, result: dict) -> None:
    """Load the pictures as images and show ``split.png`` in an Image Editor, if the UI has one
    (never in background mode)."""
    if bpy.app.background or context.window_manager is None:
        return
    images = {}
    for name in PICTURES:
        path = result["files"][name]
        image = bpy.data.images.load(path, check_existing=True)
        image.reload()
        images[name] = image
    windows = [context.window] + [w for w in context.window_manager.windows
                                  if w != context.window]
    for window in windows:
        if window is None:
            continue
        for area in window.screen.areas:
            if area.type == "IMAGE_EDITOR":
                area.spaces.active.image = images["split.png"]
                area.tag_redraw()
                return
