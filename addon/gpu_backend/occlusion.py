"""The contact occlusion on the GPU (``core/render/contact_occlusion``): the pixel centres'
view depths and normals drawn over the frame and a margin, the ground-truth-based ambient
occlusion of each pixel and its filter (``glsl/gtao.glsl``), into one texture the
shading reads."""

from __future__ import annotations

import numpy as np

from ..core.formulas import occlusion
from . import programs
from .uniforms import Struct

AO = Struct("AOData", (
    ("rec", "vec4", 2),  # kernels.occlusion.gtao's rec: view x, y of a buffer pixel
    ("params", "vec4", 0),  # (radius m, pixels per metre, orthographic, reach = margin px)
    ("origin", "ivec4", 0),  # (the buffer's origin in the frame, the raw region's in it)
    ("size", "vec4", 0),  # (the filter's plane tolerance, raw height, -, frame height)
))


def _program(main: str, samplers) -> programs.Program:
    return programs.Program(
        "draw", ("gtao",), (programs.source("background_vert"), programs.source(main)),
        defines={"AO_BLUR": 1} if "raw_ao" in samplers else {},
        structs=(AO,), blocks=(("AOData", "ao"),),
        samplers=tuple(("FLOAT_2D", name) for name in samplers),
        inputs=(("VEC2", "corner"),), outputs=(("VEC4", "out_color"),))


def block(camera, radius: float) -> bytes:
    """The AOData of a frame through ``camera`` (``contact_occlusion.tile_ambient``'s
    numbers for one tile that is the whole frame)."""
    m, b = occlusion.REACH, occlusion.BLUR
    proj = np.asarray(camera.projection, np.float64)
    ux, vx = 2.0 / camera.width, 2.0 * (-m + 0.5) / camera.width - 1.0
    uy, vy = -2.0 / camera.height, 1.0 - 2.0 * (-m + 0.5) / camera.height
    p32, p33 = proj[3, 2], proj[3, 3]
    rec = [p32 * ux / proj[0, 0], (p32 * vx - proj[0, 2]) / proj[0, 0],
           p33 * ux / proj[0, 0], (p33 * vx - proj[0, 3]) / proj[0, 0],
           p32 * uy / proj[1, 1], (p32 * vy - proj[1, 2]) / proj[1, 1],
           p33 * uy / proj[1, 1], (p33 * vy - proj[1, 3]) / proj[1, 1]]
    scale = 0.5 * proj[1, 1] * camera.height
    return AO.pack([{"rec": rec, "params": [radius, scale, float(camera.orthographic), m],
                     "origin": [-m, -m, m - b, m - b],
                     "size": [2.0 / scale, camera.height + 2 * b, 0.0, camera.height]}])


def ambient(center_depth, center_normal, camera, radius: float, triangle):
    """(H, W) R32F-like RGBA32F texture of the frame's filtered ambient occlusion, from the
    centre buffers (``Targets``' ``center_*``, the frame grown by ``occlusion.REACH``)."""
    import gpu

    b = occlusion.BLUR
    w, h = camera.width, camera.height
    data = gpu.types.GPUUniformBuf(block(camera, radius))
    raw = gpu.types.GPUTexture((w + 2 * b, h + 2 * b), format="RGBA32F")
    out = gpu.types.GPUTexture((w, h), format="RGBA32F")
    gtao = programs.compiled(_program("gtao_frag", ("center_depth", "center_normal")), "gtao")
    blur = programs.compiled(_program("ao_blur_frag", ("center_depth", "center_normal",
                                                       "raw_ao")), "ao_blur")
    blend = gpu.state.blend_get()
    gpu.state.blend_set("NONE")
    for program, target, extra in ((gtao, raw, {}), (blur, out, {"raw_ao": raw})):
        fb = gpu.types.GPUFrameBuffer(color_slots=(target,))
        with fb.bind():
            program.bind()
            program.uniform_block("ao", data)
            program.uniform_sampler("center_depth", center_depth)
            program.uniform_sampler("center_normal", center_normal)
            for name, texture in extra.items():
                program.uniform_sampler(name, texture)
            triangle.draw(program)
    gpu.state.blend_set(blend)
    return out
