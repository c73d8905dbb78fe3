"""Compare with Cycles: render one frame with BO2 Lighting and with Cycles, same camera and
resolution, and write both renders and their comparison into a folder (docs/compare.md).

The folder receives ``bo2.exr`` and ``cycles.exr`` (multilayer, 32-bit float, scene-linear,
every pass), ``side_by_side.png``, ``split.png`` and ``difference.png`` (display pictures) and
``metrics.json``. Pictures and display-referred metrics go through the scene's colour management:
the linear pixels are put in a float image and saved with ``Image.save_render`` as a 16-bit PNG,
which applies the scene's view transform, look, exposure, gamma and curves exactly as Blender's
render output does, then read back as display values (``to_display``); composition, labels and
metrics are NumPy (``core.compare``). The compositor is not applied: the comparison is of the
view layer's passes.

Cycles' Diffuse and Glossy light passes exclude the surface colour (Blender composites
DiffDir x DiffCol); BO2 Lighting's include it. BO2's light passes are therefore compared with
Cycles' pass times its colour pass (``"cycles_times_color": true`` in metrics.json).

``BO2_OT_compare_cycles`` runs it: from a script (EXEC) synchronously; invoked from the UI as a
modal operator that starts each engine's render as Blender's own render job (its progress in
the render window, Esc cancels it) and moves on when the job ends. ``bo2 compare`` runs it
headless (``addon/cli.py``).
"""

from __future__ import annotations

import json
import os
import tempfile
import time
from pathlib import Path

import bpy
import numpy as np

from ..core import compare as core
from . import engine as bo2_engine

# key -> (engine identifier, label, EXR file name)
ENGINES = {"bo2": ("BO2_LIGHTING", "BO2 Lighting", "bo2.exr"),
           "cycles": ("CYCLES", "Cycles", "cycles.exr")}
PICTURES = ("side_by_side.png", "split.png", "difference.png")
# Light passes (pipeline names) compared, with the Cycles colour pass they are multiplied by.
LIGHT_PASSES = {"DiffDir": "DiffCol", "GlossDir": "GlossCol", "DiffInd": "DiffCol",
                "GlossInd": "GlossCol", "Emit": None}
DATA_PASSES = ("Depth", "Normal", "Position", "UV", "IndexMA")
_PASS_FLAGS = ("use_pass_combined", "use_pass_z", "use_pass_normal", "use_pass_position",
               "use_pass_uv", "use_pass_material_index", "use_pass_diffuse_direct",
               "use_pass_glossy_direct", "use_pass_diffuse_indirect", "use_pass_glossy_indirect",
               "use_pass_emit", "use_pass_diffuse_color", "use_pass_glossy_color")
_BO2_PASS_FLAGS = ("use_pass_albedo", "use_pass_specular_color", "use_pass_gloss")
_IMAGE_SETTINGS = ("media_type", "file_format", "color_mode", "color_depth", "exr_codec",
                   "color_management")
# Channel order of each pass (pipeline names) as the EXR stores its components.
_CHANNELS = {name: ids for name, (_, ids, _, _) in bo2_engine.PASS_LAYOUT.items()}
_CHANNELS.update({"Combined": "RGBA", "DiffCol": "RGB", "GlossCol": "RGB"})
_COLOR_RENAMED_IN_5 = {"DiffCol": "Diffuse Color", "GlossCol": "Glossy Color"}
_GEOMETRY_DEPTH = 1e9  # both engines write 1e10 where the camera sees no geometry


class CompareError(Exception):
    """A comparison that cannot go on: one line for the user."""


def readable_name(name: str) -> str:
    """The Blender 5.0 name of a pass (``Diffuse Direct``), whatever Blender runs."""
    return {**bo2_engine.RENAMED_IN_5, **_COLOR_RENAMED_IN_5}.get(name, name)


def blender_name(name: str) -> str:
    """The running Blender's name of the pass ``name`` (pipeline / Blender 4 name)."""
    if bpy.app.version >= (5, 0, 0):
        return readable_name(name)
    return name


# ---------------------------------------------------------------------------------------------
# Files


def output_folder(scene) -> Path:
    """The scene's Compare Folder (``scene.bo2.compare_folder``) as an absolute path."""
    text = scene.bo2.compare_folder.strip()
    if not text:
        raise CompareError("no Compare Folder is set")
    if text.startswith("//") and not bpy.data.filepath:
        raise CompareError("save the .blend file first, or choose an absolute Compare Folder")
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


def read_exr(path: Path, layer: str) -> dict[str, np.ndarray]:
    """The passes of one view layer of a multilayer EXR written by Blender 4.5 or 5.0.

    path:    the EXR
    layer:   view layer name
    returns: {pipeline pass name ("Combined", "DiffDir", "DiffCol", "Depth", ...):
              (H, W, C) float32, row 0 at the top}
    """
    import OpenEXR

    names = {blender_name(n): n for n in _CHANNELS}
    components: dict[str, dict[str, np.ndarray]] = {}
    grouped: dict[str, np.ndarray] = {}
    for part in OpenEXR.File(str(path)).parts:  # 5.0: one part per pass; 4.5: one part
        for key, channel in part.channels.items():
            if not key.startswith(f"{layer}."):
                continue
            rest = key[len(layer) + 1:]
            if rest in names:  # RGB(A) channels come grouped in one array
                grouped[names[rest]] = np.asarray(channel.pixels, np.float32)
            else:
                name, _, comp = rest.rpartition(".")
                if name in names:
                    components.setdefault(names[name], {})[comp] = channel.pixels
    out = {n: (a if a.ndim == 3 else a[..., None]) for n, a in grouped.items()}
    for name, comps in components.items():
        order = [c for c in _CHANNELS[name] if c in comps]
        out[name] = np.stack([np.asarray(comps[c], np.float32) for c in order], -1)
    return out


def _set_image_settings(settings, fmt: str, depth: str, mode: str = "RGB") -> None:
    if hasattr(settings, "color_management"):
        settings.color_management = "FOLLOW_SCENE"
    if hasattr(settings, "media_type"):  # Blender 5.0 chooses multilayer by media type
        settings.media_type = "MULTI_LAYER_IMAGE" if fmt == "OPEN_EXR_MULTILAYER" else "IMAGE"
    settings.file_format = fmt
    settings.color_mode = mode
    settings.color_depth = depth


def save_result(scene, path: Path) -> None:
    """Write the Render Result as a multilayer 32-bit EXR at ``path`` (atomically)."""
    result = bpy.data.images.get("Render Result")
    if result is None:
        raise CompareError("the render produced no image")
    _set_image_settings(scene.render.image_settings, "OPEN_EXR_MULTILAYER", "32", "RGBA")
    tmp = path.with_name(f".{path.stem}.partial{path.suffix}")
    try:
        result.save_render(filepath=str(tmp), scene=scene)
    except RuntimeError as exc:
        raise CompareError(f"cannot write {path}: {str(exc).strip().splitlines()[-1]}") from None
    if not tmp.is_file():
        raise CompareError(f"cannot write {path}")
    os.replace(tmp, path)


def to_display(scene, images: list[np.ndarray]) -> list[np.ndarray]:
    """Scene-linear images through the scene's colour management, as Blender saves a render.

    scene:   its view transform, look, exposure, gamma, curves and display device are applied
    images:  (H, W, >=3) scene-linear RGB, each of the same width, row 0 at the top
    returns: the same shapes with 3 channels, display-encoded float32 in [0, 1] (16-bit)
    """
    if not images:
        return []
    stack = np.concatenate([np.asarray(i[..., :3], np.float32) for i in images], 0)
    h, w = stack.shape[:2]
    rgba = np.concatenate([stack, np.ones((h, w, 1), np.float32)], -1)[::-1]  # bottom row first
    settings = scene.render.image_settings
    image = bpy.data.images.new("BO2 Compare", w, h, alpha=False, float_buffer=True)
    loaded = None
    try:
        image.pixels.foreach_set(np.ascontiguousarray(rgba).ravel())
        _set_image_settings(settings, "PNG", "16")
        with tempfile.TemporaryDirectory() as tmp:
            path = str(Path(tmp) / "display.png")
            image.save_render(filepath=path, scene=scene)
            loaded = bpy.data.images.load(path, check_existing=False)
            loaded.colorspace_settings.name = "Non-Color"  # keep the encoded values as they are
            px = np.empty(w * h * loaded.channels, np.float32)
            loaded.pixels.foreach_get(px)
        px = px.reshape(h, w, -1)[::-1, :, :3]
    finally:
        bpy.data.images.remove(image)
        if loaded is not None:
            bpy.data.images.remove(loaded)
    out, row = [], 0
    for i in images:
        out.append(np.ascontiguousarray(px[row:row + i.shape[0]]))
        row += i.shape[0]
    return out


# ---------------------------------------------------------------------------------------------
# Analysis


def _data_metrics(name: str, bo2: np.ndarray, cycles: np.ndarray, geometry: np.ndarray) -> dict:
    """G-buffer passes, compared where both engines see geometry."""
    a, b = bo2[geometry], cycles[geometry]
    if name == "IndexMA":
        equal = float(np.mean(a == b)) if a.size else 1.0
        return {"fraction_equal": equal, "pixels": int(geometry.sum())}
    if not a.size:
        return {"rmse": 0.0, "mean_abs_error": 0.0, "pixels": 0}
    return {"rmse": core.rmse(a, b),
            "mean_abs_error": float(np.mean(np.abs(a.astype(np.float64) - b))),
            "pixels": int(geometry.sum())}


DEFINITIONS = {
    "rmse": "root mean square of BO2 - Cycles over pixels and RGB channels, scene-linear "
            "(EXR values)",
    "mean_relative_error": "mean of |BO2 - Cycles| / (|Cycles| + 0.01) over pixels and RGB "
                           "channels, scene-linear",
    "psnr_db": "10 log10(1 / MSE) of the display-referred RGB in [0, 1] (through the scene's "
               "view transform); null when the images are identical",
    "ssim": "mean SSIM (Wang et al. 2004; 11x11 Gaussian window, sigma 1.5, K1 0.01, K2 0.03, "
            "L 1) of the display-referred Rec.709 luma",
    "cycles_times_color": "Cycles' Diffuse/Glossy Direct/Indirect passes exclude the surface "
                          "colour; they are multiplied by Cycles' Diffuse/Glossy Color pass "
                          "before the comparison with BO2 Lighting's, which include it",
    "data_passes": "Depth, Normal, Position, UV: rmse and mean_abs_error over the pixels where "
                   "both engines see geometry; Material Index: fraction of those pixels equal",
    "heat_map": "difference.png: |Y(BO2) - Y(Cycles)|, Y the Rec.709 luminance of the "
                "scene-linear Combined pass, in the colour map from 0 to scale_max",
}


def analyse(scene, folder: Path, layer: str, info: dict) -> dict:
    """Compare ``bo2.exr`` with ``cycles.exr`` in ``folder``; write the pictures and
    ``metrics.json``; return the metrics (the JSON's content)."""
    exrs = {key: read_exr(folder / ENGINES[key][2], layer) for key in ENGINES}
    for key, passes in exrs.items():
        if "Combined" not in passes:
            raise CompareError(f"{folder / ENGINES[key][2]}: no Combined pass of view layer "
                               f"{layer!r}")
    bo2, cyc = exrs["bo2"], exrs["cycles"]
    (hb, wb), (hc, wc) = bo2["Combined"].shape[:2], cyc["Combined"].shape[:2]
    if (hb, wb) != (hc, wc):
        raise CompareError(f"resolution mismatch: BO2 Lighting rendered {wb}x{hb}, Cycles "
                           f"{wc}x{hc} (a render border or crop?); kept both EXR files")
    pairs = {"Combined": (bo2["Combined"][..., :3], cyc["Combined"][..., :3])}
    for name, color in LIGHT_PASSES.items():
        if name in bo2 and name in cyc and (color is None or color in cyc):
            pairs[name] = (bo2[name], cyc[name] * cyc[color] if color else cyc[name])
    display = {name: to_display(scene, list(pair)) for name, pair in pairs.items()}
    metrics = {name: core.image_metrics(*pairs[name], *display[name]) for name in pairs}
    passes = {readable_name(n): metrics[n] for n in pairs if n != "Combined"}
    if "Depth" in bo2 and "Depth" in cyc:
        geometry = (bo2["Depth"][..., 0] < _GEOMETRY_DEPTH) & (cyc["Depth"][..., 0]
                                                                 < _GEOMETRY_DEPTH)
        for name in DATA_PASSES:
            if name in bo2 and name in cyc and bo2[name].shape == cyc[name].shape:
                passes[readable_name(name)] = _data_metrics(name, bo2[name], cyc[name],
                                                            geometry)

    # pictures
    image = metrics["Combined"]
    t_bo2, t_cyc = info["bo2"]["render_seconds"], info["cycles"]["render_seconds"]
    labels = (
        (f"BO2 Lighting  {core.format_seconds(t_bo2)}", f"BO2 {core.format_seconds(t_bo2)}",
         "BO2"),
        (f"Cycles  {core.format_seconds(t_cyc)}", f"Cycles {core.format_seconds(t_cyc)}",
         "Cycles"),
    )
    left, right = display["Combined"]
    core.write_png(folder / "side_by_side.png", core.side_by_side(left, right, labels))
    core.write_png(folder / "split.png", core.split_view(left, right, labels))
    diff = np.abs(core.luminance(pairs["Combined"][0]) - core.luminance(pairs["Combined"][1]))
    high = float(np.percentile(diff, 99)) if diff.size else 0.0
    high = high if high > 0 else float(diff.max(initial=0.0))
    scale_max = core.nice_ceil(high) if high > 0 else 1.0
    core.write_png(folder / "difference.png", core.heat_map(
        diff, scale_max, "|Y BO2 - Y Cycles|, scene-linear", _metrics_line(image)))

    result = {
        "scene": scene.name,
        "blend_file": bpy.path.basename(bpy.data.filepath) or None,
        "frame": scene.frame_current,
        "view_layer": layer,
        "blender_version": bpy.app.version_string,
        "resolution": [wb, hb],
        "color_management": {
            "view_transform": scene.view_settings.view_transform,
            "look": scene.view_settings.look,
            "exposure": scene.view_settings.exposure,
            "gamma": scene.view_settings.gamma,
            "display_device": scene.display_settings.display_device,
        },
        "engines": info,
        "speedup": t_cyc / t_bo2 if t_bo2 > 0 else None,
        "cycles_times_color": True,
        "image": image,
        "passes": passes,
        "heat_map": {"quantity": "abs_linear_luminance_difference", "scale_max": scale_max,
                     "percentile_99": high},
        "definitions": DEFINITIONS,
        "files": {name: str(folder / name) for name in
                  (*(e[2] for e in ENGINES.values()), *PICTURES, "metrics.json")},
    }
    tmp = folder / ".metrics.json.partial"
    tmp.write_text(json.dumps(result, indent=2, allow_nan=False) + "\n")
    os.replace(tmp, folder / "metrics.json")
    return result


def _metrics_line(m: dict) -> str:
    psnr = "inf" if m["psnr_db"] is None else f"{m['psnr_db']:.1f}"
    return f"RMSE {m['rmse']:.4g}  PSNR {psnr} dB  SSIM {m['ssim']:.3f}"


def headline(result: dict) -> str:
    """One line: BO2 1.2 s, Cycles 30 s (25x); RMSE 0.031, PSNR 31.2 dB, SSIM 0.950."""
    t_bo2 = result["engines"]["bo2"]["render_seconds"]
    t_cyc = result["engines"]["cycles"]["render_seconds"]
    m = result["image"]
    speed = f" ({result['speedup']:.1f}x)" if result["speedup"] else ""
    psnr = "inf" if m["psnr_db"] is None else f"{m['psnr_db']:.1f}"
    return (f"BO2 {core.format_seconds(t_bo2)}, Cycles {core.format_seconds(t_cyc)}{speed}; "
            f"RMSE {m['rmse']:.3g}, PSNR {psnr} dB, SSIM {m['ssim']:.3f}")


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
        self._saved_flags = {f: getattr(view_layer, f) for f in _PASS_FLAGS}
        self._saved_bo2 = {f: getattr(view_layer.bo2, f) for f in _BO2_PASS_FLAGS}
        self._saved_image = [(a, getattr(settings, a)) for a in _IMAGE_SETTINGS
                             if hasattr(settings, a)]
        self._view_layer = view_layer
        for flag in _PASS_FLAGS:  # every pass of both engines, plus Cycles' colour passes
            setattr(view_layer, flag, True)
        for flag in _BO2_PASS_FLAGS:
            setattr(view_layer.bo2, flag, True)

    def kept(self) -> list[Path]:
        """The EXR files written so far."""
        return [self.folder / ENGINES[k][2] for k in self.info]

    def begin(self, key: str) -> None:
        """Make ``key``'s engine the scene's, ready to render."""
        self.scene.render.engine = ENGINES[key][0]

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
            info.update(samples=scene.bo2.samples, specular_model=scene.bo2.specular_model,
                        indirect=scene.bo2.use_indirect)
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
                            (self._view_layer, self._saved_flags.items()),
                            (self._view_layer.bo2, self._saved_bo2.items()),
                            (settings, self._saved_image)):
            for attr, value in values:
                try:
                    setattr(obj, attr, value)
                except (TypeError, ValueError, AttributeError, ReferenceError):
                    pass


def render_sync(job: Comparison, key: str) -> float:
    """Render ``key``'s engine now (blocking); its render time in seconds."""
    job.begin(key)
    watch = RenderWatch()
    label = ENGINES[key][1]
    try:
        start = time.perf_counter()
        bpy.ops.render.render(layer=job.layer)
        seconds = time.perf_counter() - start
    except RuntimeError as exc:
        text = str(exc).strip().splitlines()[-1].removeprefix("Error: ") if str(exc) else ""
        raise CompareError(f"the {label} render failed: {text}") from None
    finally:
        watch.remove()
    if watch.cancelled:
        raise CompareError(f"the {label} render was cancelled; {_kept_text(job)}")
    return seconds


def _kept_text(job: Comparison) -> str:
    kept = job.kept()
    return "kept " + ", ".join(str(p) for p in kept) if kept else "nothing written"


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


# ---------------------------------------------------------------------------------------------
# Operator


class BO2_OT_compare_cycles(bpy.types.Operator):
    """Compare with Cycles (the tooltip is ``bl_description``)."""

    bl_idname = "bo2.compare_cycles"
    bl_label = "Compare with Cycles"
    bl_description = ("Render the frame with BO2 Lighting and with Cycles and compare them: both "
                      "renders as EXR, side-by-side, split and difference pictures and metrics "
                      "in the Compare Folder")
    bl_options = {"REGISTER"}

    _job = None
    _watch = None
    _timer = None
    _queue: list = []
    _key = ""
    _start = 0.0

    @classmethod
    def poll(cls, context):
        return context.scene is not None and context.view_layer is not None and not (
            bpy.app.is_job_running("RENDER"))

    def _report_done(self, context, result: dict) -> None:
        self.report({"INFO"}, headline(result))
        show_images(context, result)

    def execute(self, context):
        scene = context.scene
        try:
            result = run(scene, context.view_layer, output_folder(scene))
        except CompareError as exc:
            self.report({"ERROR"}, str(exc))
            return {"CANCELLED"}
        self._report_done(context, result)
        return {"FINISHED"}

    def invoke(self, context, event):
        if bpy.app.background or context.window is None:
            return self.execute(context)
        try:
            self._job = Comparison(context.scene, context.view_layer,
                                   output_folder(context.scene))
        except CompareError as exc:
            self.report({"ERROR"}, str(exc))
            return {"CANCELLED"}
        self._queue = list(ENGINES)
        if not self._start_next(context):
            return {"CANCELLED"}
        wm = context.window_manager
        self._timer = wm.event_timer_add(0.25, window=context.window)
        wm.modal_handler_add(self)
        return {"RUNNING_MODAL"}

    def _status(self, context, text: str | None) -> None:
        if context.workspace is not None:
            context.workspace.status_text_set(text)

    def _start_next(self, context) -> bool:
        """Start the next engine's render as Blender's render job."""
        self._key = self._queue.pop(0)
        self._job.begin(self._key)
        self._watch = RenderWatch()
        label = ENGINES[self._key][1]
        self._status(context, f"Compare with Cycles: rendering with {label} "
                     "(Esc in the render window cancels)")
        self._start = time.perf_counter()
        result = bpy.ops.render.render("INVOKE_DEFAULT", layer=self._job.layer)
        if not result & {"RUNNING_MODAL", "FINISHED"}:
            self._end(context)
            self.report({"ERROR"}, f"Compare with Cycles: the {label} render did not start")
            return False
        return True

    def _end(self, context) -> None:
        if self._timer is not None:
            context.window_manager.event_timer_remove(self._timer)
            self._timer = None
        if self._watch is not None:
            self._watch.remove()
        self._status(context, None)
        self._job.restore()

    def modal(self, context, event):
        if event.type != "TIMER" or bpy.app.is_job_running("RENDER"):
            return {"PASS_THROUGH"}
        watch, label = self._watch, ENGINES[self._key][1]
        watch.remove()
        if watch.cancelled:
            self._end(context)
            self.report({"WARNING"}, f"Compare with Cycles: the {label} render was cancelled; "
                        f"{_kept_text(self._job)}")
            return {"CANCELLED"}
        seconds = (watch.end if watch.completed else time.perf_counter()) - self._start
        try:
            self._job.finish(self._key, seconds)
            if self._queue:
                return {"RUNNING_MODAL"} if self._start_next(context) else {"CANCELLED"}
            self._status(context, "Compare with Cycles: comparing")
            result = self._job.analyse()
        except CompareError as exc:
            self._end(context)
            self.report({"ERROR"}, f"Compare with Cycles: {exc}")
            return {"CANCELLED"}
        self._end(context)
        self._report_done(context, result)
        return {"FINISHED"}


CLASSES = [BO2_OT_compare_cycles]
