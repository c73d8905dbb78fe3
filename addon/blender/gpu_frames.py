"""F12 and ``bo2 render`` on the GPU: whether this session can draw a frame there (the scene's
Device setting, and in background mode a GPU context probed once in a child process), and the
frame drawn and read back as the render's passes."""

from __future__ import annotations

from pathlib import Path

import bpy

from ..core import kernels
from ..core.render import pipeline
from ..core.render.passes import PASSES, group_pass
from ..core.render.visibility import sample_offsets
from ..gpu_backend import device
from ..gpu_backend import frame as gpu_frame
from . import passes


def refusal(scene) -> str | None:
    """Why a final render of ``scene`` is not drawn on the GPU in this session, or None."""
    choice = scene.bo2.device
    if choice == "CPU":
        return "the CPU was chosen"
    if bpy.app.background:
        found = device.probe(device.probe_command(bpy.app.binary_path), probe_cache())
        if not found.ok:
            return f"no GPU context: {found.reason}"
        name = found.renderer
    else:
        name = renderer()  # the render thread has Blender's GPU context (bl_use_gpu_context)
    if choice == "AUTO" and device.auto_refusal(name):
        return device.auto_refusal(name)
    if bpy.app.background:
        device.open_context(bpy.app.binary_path, probe_cache())
    return None


def probe_cache() -> Path:
    """Where the GPU probe's answer is kept: beside the compiled kernels' folder (the
    extension's user folder, else the per-user cache)."""
    return kernels.user_cache("gpu_device.json")


def renderer() -> str:
    """The GPU's name, as its driver gives it."""
    import gpu

    try:
        return gpu.platform.renderer_get()
    except Exception:  # noqa: BLE001 - a name only
        return "GPU"


def unsupported_passes(view_layer) -> str | None:
    """The enabled passes the GPU does not draw yet (one phrase), or None."""
    missing = [name for name in PASSES if name not in gpu_frame.PASS_OF
               and name not in gpu_frame.CENTRAL and passes.enabled(view_layer, name)]
    if not missing:
        return None
    return f"the {', '.join(missing[:3])} pass{'es' if len(missing) > 1 else ''}"


def render(job, view_layer) -> tuple[object, dict | str]:
    """The job's frame prepared (``pipeline.prepare``) and its passes drawn on the GPU:
    (frame, {pass name: (H, W, C) float32, row 0 at the top}), or (frame or None, why the
    GPU does not draw it)."""
    why = unsupported_passes(view_layer)
    if why:
        return None, why
    cam = job.scene.camera
    need = max(gpu_frame.memory(cam.width, cam.height, names) for names in gpu_frame.GROUPS)
    if need > gpu_frame.GPU_BUDGET:
        return None, (f"a frame of {cam.width} x {cam.height} (it needs "
                      f"{need / (1 << 30):.1f} GiB of GPU memory, more than "
                      f"{gpu_frame.GPU_BUDGET >> 30} GiB)")
    frame = pipeline.prepare(job, on_gpu=True)
    why = gpu_frame.unsupported(frame)
    if not why and frame.blends is not None:
        need = max(gpu_frame.memory(cam.width, cam.height, names, blended=True)
                   for names in gpu_frame.GROUPS)
        if need > gpu_frame.GPU_BUDGET:
            why = (f"blended materials in a frame of {cam.width} x {cam.height} (they need "
                   f"{need / (1 << 30):.1f} GiB of GPU memory, more than "
                   f"{gpu_frame.GPU_BUDGET >> 30} GiB)")
    if why:
        return pipeline.cpu_maps(job, frame), why
    s = job.scene.settings
    wanted = [name for name in PASSES if name == "Combined" or passes.enabled(view_layer, name)]
    wanted += passes.cryptomatte_passes(view_layer)
    wanted += [group_pass(group.name) for group in view_layer.lightgroups]
    wanted += [name for name, _ in s.aovs]
    return frame, gpu_frame.render(frame, sample_offsets(max(1, int(s.samples)),
                                                         s.filter_width), wanted, job.warn)
