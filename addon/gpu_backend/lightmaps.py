"""Baked lightmaps on the GPU (``core/lighting/lightmap``): every lightmap of a frame in one
row texture, its place in a ``LightmapData`` record (declared once here), read by
``glsl/lightmap.glsl``."""

from __future__ import annotations

import numpy as np

from ..core.lighting import lightmap as core_lightmap
from ..core.render.shading import LIGHTMAP_HUES
from . import textures
from .uniforms import Struct

MAX_LIGHTMAPS = 256
LIGHTMAPS = Struct("LightmapData", (
    ("maps", "ivec4", MAX_LIGHTMAPS),  # (first texel, width, height, channels: 3 or 12)
))


def defines() -> dict:
    return {"LIGHTMAP_SH_SCALE": f"{float(np.pi * core_lightmap.SH_SCALE_C0):.9g}",
            "ROW_WIDTH": textures.ROW_WIDTH}


def prelude() -> str:
    """The Lightmap Texels pass's hues (``shading.LIGHTMAP_HUES``) as a GLSL constant."""
    hues = ", ".join(f"vec3({r}, {g}, {b})" for r, g, b in LIGHTMAP_HUES)
    return f"const vec3 LIGHTMAP_HUES[{len(LIGHTMAP_HUES)}] = vec3[{len(LIGHTMAP_HUES)}]({hues});\n"


def upload(maps) -> tuple[bytes, object]:
    """(the LightmapData block, the row texture) of a frame's lightmaps (``Frame.lightmaps``:
    ``lightmap.Lightmap`` each, its ``image`` (H, W, 3 or 12))."""
    if len(maps) > MAX_LIGHTMAPS:
        raise ValueError(f"more than {MAX_LIGHTMAPS} lightmaps")
    records, parts, at = [], [], 0
    for m in maps:
        image = np.asarray(m.image, np.float32)
        h, w, c = image.shape
        rows = image.reshape(-1, c // 3, 3).reshape(-1, 3)  # a pixel's channels, 3 per texel
        parts.append(rows)
        records.append([at, w, h, c])
        at += len(rows)
    return (LIGHTMAPS.pack([{"maps": records}]),
            textures.rows(np.concatenate(parts) if parts else np.zeros((1, 3), np.float32)))
