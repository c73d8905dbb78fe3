"""The viewport on the GPU: a prepared frame (``core.render.viewport.Session`` prepares it on
its worker) drawn through the viewport's camera, one more sample per redraw until the
viewport's sample count, and resolved into the look-dev view's image."""

from __future__ import annotations

import numpy as np

from ..core.render.viewport import same_camera
from ..core.render.visibility import sample_offsets
from . import programs
from .frame import GPUFrame, Targets

# look-dev views the GPU draws: (its target, how the resolve shows it: 0 the value, 1 a
# normal, 2 the alpha channel in grey, 3 the colour, opaque)
VIEWS = {"COMBINED": ("combined", 0), "ALBEDO": ("surface", 3), "GLOSS": ("surface", 2),
         "NORMAL": ("normal", 1), "DIFFUSE_DIRECT": ("diffuse", 3),
         "GLOSSY_DIRECT": ("specular", 3), "DIFFUSE_INDIRECT": ("diff_ind", 3),
         "GLOSSY_INDIRECT": ("gloss_ind", 3), "SPECULAR_COLOR": ("rf0", 3),
         "AMBIENT_OCCLUSION": ("ao", 3), "LIGHTMAP": ("lightmap", 3),
         "LIGHTMAP_TEXELS": ("texels", 3), "REFLECTION_PROBES": ("reflections", 3),
         "IRRADIANCE_VOLUMES": ("volumes", 3)}


def _resolve_program(mode: int) -> programs.Program:
    return programs.Program(
        "draw", (), (programs.source("background_vert"), programs.source("resolve_frag")),
        defines={"RESOLVE_VIEW": mode}, samplers=(("FLOAT_2D", "total"),),
        constants=(("FLOAT", "scale"),), inputs=(("VEC2", "corner"),),
        outputs=(("VEC4", "out_color"),))


class ViewportDrawing:
    """One viewport's GPU state: the uploaded frame, the sample targets and the image."""

    def __init__(self):
        self._frame = None  # the core Frame uploaded
        self._drawn: GPUFrame | None = None
        self._targets: Targets | None = None
        self._camera = None
        self._view = None
        self._image = None  # (texture, its framebuffer)

    def samples(self, frame) -> int:
        """The samples drawn of ``frame`` (0 until the first draw of a frame not yet drawn)."""
        return 0 if self._targets is None or frame is not self._frame else self._targets.samples

    def draw(self, frame, camera, view: str, samples: int):
        """Add one sample of ``frame`` through ``camera`` (a ``core.scene.Camera``) for look-dev
        ``view`` (a key of ``VIEWS``) unless ``samples`` are drawn already, and return the
        view's image (an RGBA32F GPU texture of the camera's size, scene-linear). Raises
        ``frame.Unsupported`` or ``programs.ShaderError`` for what the GPU cannot draw."""
        import gpu

        if frame is not self._frame:
            self._drawn, self._frame = None, frame
            self._drawn = GPUFrame(frame)
            self._targets = None
        target, mode = VIEWS[view]
        size = (camera.width, camera.height)
        t = self._targets
        if t is None or (t.width, t.height) != size or t.names != (target,):
            self._targets = t = Targets(*size, (target,))
            texture = gpu.types.GPUTexture(size, format="RGBA32F")
            self._image = (texture, gpu.types.GPUFrameBuffer(color_slots=(texture,)))
            self._camera = None
        if self._camera is None or view != self._view or not same_camera(self._camera, camera):
            t.clear()
            self._camera, self._view = camera, view
        if t.samples < samples:
            k = t.samples
            offsets = sample_offsets(max(1, samples), frame.scene.settings.filter_width)
            self._drawn.draw(camera, offsets[k:k + 1], t, first_sample=k)
            program = programs.compiled(_resolve_program(mode), ("resolve", mode))
            texture, framebuffer = self._image
            blend = gpu.state.blend_get()
            with framebuffer.bind():
                gpu.state.blend_set("NONE")
                program.bind()
                program.uniform_sampler("total", t.textures[f"total_{target}"])
                program.uniform_float("scale", float(np.float32(1.0 / t.samples)))
                self._drawn.background.draw(program)
            gpu.state.blend_set(blend)
        return self._image[0]
