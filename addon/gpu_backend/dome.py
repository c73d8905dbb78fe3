"""The world's occlusion on the GPU (``core/render/world_occlusion``, ``core/render/sky``):
the dome's directions and weights (``DomeData``), its visibility drawn at the grid of pixels
the CPU looks it up at, and what the shading pass reads to blend it (``glsl/dome.glsl``)."""

from __future__ import annotations

import numpy as np

from ..core.render import sky as sky_light
from .uniforms import Struct

MAX_DIRECTIONS = 32  # dome maps a frame's shading block holds beside a batch of lights
DOME = Struct("DomeData", (
    ("dirs", "vec4", MAX_DIRECTIONS),  # unit direction towards the sky, its radiance weight
    ("maps", "ivec4", MAX_DIRECTIONS // 4),  # its map's number in the ShadowData block, -1 none
    ("counts", "ivec4", 0),  # (directions, -, the grid's stride, its first pixel)
    ("grid", "ivec4", 0),  # (grid width, grid height, -, -)
))


def unsupported(frame) -> str | None:
    """What of the frame's dome the GPU does not draw, or None."""
    sky = frame.sky
    if sky is not None and len(sky.maps) > MAX_DIRECTIONS:
        return f"a world occlusion of more than {MAX_DIRECTIONS} directions"
    return None


def grid(camera) -> tuple[int, int, int, int]:
    """(stride, first pixel, grid width, grid height): the anchor pixels of ``sky.upsampled``
    (every ``stride``-th from ``first``) over the whole frame."""
    stride = sky_light.stride(camera.height)
    half = stride // 2
    gw = max(1, -(-(camera.width - half) // stride))
    gh = max(1, -(-(camera.height - half) // stride))
    return stride, half, gw, gh


def grid_projection(camera) -> tuple[tuple, tuple]:
    """(NDC scale, NDC shift) that draw the anchor pixels' centres at the grid's texel
    centres: x_grid = scale x_frame + shift (``frame_vert.glsl``'s ndc_scale and jitter)."""
    stride, half, gw, gh = grid(camera)
    scale, shift = [], []
    for size, cells, sign in ((camera.width, gw, 1.0), (camera.height, gh, -1.0)):
        a = size / (stride * cells)
        x0 = sign * ((half + 0.5) * 2.0 / size - 1.0)  # the first anchor's centre, NDC
        g0 = sign * (0.5 * 2.0 / cells - 1.0)
        scale.append(a)
        shift.append(g0 - a * x0)
    return tuple(scale), tuple(shift)


def block(frame, map_index: list[int], camera) -> bytes:
    """The DomeData of ``frame``'s dome, its maps at ``map_index`` (-1 none) in the ShadowData
    block, for ``camera``'s grid."""
    sky = frame.sky
    count = len(sky.maps)
    dirs = sky.directions.astype(np.float32)
    weights = sky_light.radiance_weights(frame.scene.probes.world_sh, count)
    stride, half, gw, gh = grid(camera)
    return DOME.pack([{"dirs": np.column_stack([dirs, weights]), "maps": map_index,
                       "counts": [count, 0, stride, half], "grid": [gw, gh, 0, 0]}])
