"""The lights and their shadow maps as the GPU's shaders read them: the ``LightData`` and
``ShadowData`` uniform blocks (declared once here), the maps' depth, pyramid and rotation
textures, and the defines of ``glsl/shadow_filter.glsl``."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..core.render import shadow_filter
from ..core.render.shadows import MAX_CASCADES, MIP_FIRST_LEVEL
from . import textures
from .uniforms import Struct

LIGHT = Struct("LightData", (
    ("color", "vec3", 0), ("kind", "int", 0),  # colour times power; kernels.shading.KINDS
    ("position", "vec3", 0), ("cos_half", "float", 0),  # a spot's cos(size / 2)
    ("axis", "vec3", 0), ("blend", "float", 0),  # the direction it shines along
    ("shadow", "int", 0),  # its shadow map's index in the ShadowData block, -1 none
    ("receivers", "int", 0),  # its light linking set (core.scene.linking), 0 none
))
MAX_LEVELS = 16  # pyramid levels of a map (a 16384 texel map has 12)
FP_SLOTS = 24  # room for the filter's float constants (kernels.shadows.P_SIZE_ALL, 21)
SHADOW = Struct("ShadowData", (
    ("fp", "vec4", FP_SLOTS // 4),  # kernels.shadows.P_* in order
    ("kind", "int", 0),  # kernels.shadows.CUBE, PERSPECTIVE, ORTHO
    ("ints", "ivec4", 0),  # (faces whose pyramid tops give the least depth: maps drawn on
                           # the GPU, 0: fp's; resolution, first layer in shadow_depth, cascades)
    ("ints2", "ivec4", 0),  # (first row in shadow_mips, pyramid levels, jitter, -)
    ("basis", "vec4", 3),  # rows R, U, F (perspective and sun maps)
    ("rects", "vec4", MAX_CASCADES),  # sun cascades (cx, cy, half side, z_min)
    ("offsets", "ivec4", MAX_LEVELS // 4), ("sides", "ivec4", MAX_LEVELS // 4),
))
MIPS_WIDTH = textures.ROW_WIDTH


def _glsl_float(x: float) -> str:
    return f"{float(np.float32(x)):.9g}".replace("inf", "1.0 / 0.0")


def _disc(name: str, disc: np.ndarray) -> str:
    items = ", ".join(f"vec2({_glsl_float(a)}, {_glsl_float(b)})" for a, b in disc)
    return f"const vec2 {name}[{len(disc)}] = vec2[{len(disc)}]({items});\n"


def filter_defines() -> dict:
    """The defines ``glsl/shadow_filter.glsl`` reads: the kernel's slot numbers and the
    filter's constants (``shadow_filter.FILTER_TABLES``)."""
    from ..core.kernels import shadows as filter_kernel

    t = shadow_filter.FILTER_TABLES
    out = {name: getattr(filter_kernel, name) for name in dir(filter_kernel)
           if name.startswith("P_") and name != "P_SIZE_ALL"}
    out.update(MIP_FIRST_LEVEL=MIP_FIRST_LEVEL, SEARCH_REFINEMENTS=t["search_refinements"],
               MIPS_WIDTH=MIPS_WIDTH, BLOCKER_TAPS=len(t["blocker_disc"]),
               PCF_TAPS=len(t["pcf_disc"]), HARD_TAPS=len(t["hard_disc"]),
               PCF_REACH=_glsl_float(t["pcf_reach"]), HARD_REACH=_glsl_float(t["hard_reach"]))
    return out


def filter_prelude() -> str:
    """The tap discs as GLSL constant arrays."""
    t = shadow_filter.FILTER_TABLES
    return (_disc("BLOCKER_DISC", t["blocker_disc"]) + _disc("PCF_DISC", t["pcf_disc"])
            + _disc("HARD_DISC", t["hard_disc"]))


@dataclass
class ShadowSet:
    """Every shadow map of a frame on the GPU.

    index:     per map given, its number in the ShadowData block, -1 for None
    block:     the ShadowData block's bytes; count: its length (at least 1)
    depth:     R32F 2D array: each map's faces, in order, in the top-left res x res of a layer
    mips:      RGBA32F rows (``textures.rows``): every map's pyramid rows, in order
    rotations: RG32F (1024 x 1): the disc rotations' (cos, sin)
    """

    index: list[int]
    block: bytes
    count: int
    depth: object
    mips: object
    rotations: object

    def samplers(self) -> tuple:
        """The samplers ``glsl/shadow_filter.glsl`` reads, as ``pointwise.run`` takes them."""
        return (("FLOAT_2D_ARRAY", "shadow_depth", self.depth),
                ("FLOAT_2D", "shadow_mips", self.mips),
                ("FLOAT_2D", "shadow_rotations", self.rotations))


def shadow_set(maps: list, *, jitter=True, casters=None) -> ShadowSet:
    """Upload ``maps`` (``core.render.shadows.ShadowMap`` or None each) for the filter, or
    draw them here when the core left them to a GPU (``ShadowMap.on_gpu``: every map of a set
    alike) from ``casters`` (``shadow_depths.Casters``: one for every map, or one per map);
    ``jitter``: whether each map's taps turn per point (one bool, or one per map)."""
    import gpu

    from ..core.kernels import shadows as filter_kernel

    if filter_kernel.P_SIZE_ALL > FP_SLOTS:
        raise ValueError(f"the filter has {filter_kernel.P_SIZE_ALL} constants: raise FP_SLOTS")
    turns = [jitter] * len(maps) if isinstance(jitter, bool) else list(jitter)
    kept = [m for m in maps if m is not None and len(m.depth)]
    drawn = {m.on_gpu for m in kept}
    if len(drawn) > 1:
        raise ValueError("a set of shadow maps mixes maps drawn here and on the CPU")
    on_gpu = drawn == {True}
    per_map = list(casters) if isinstance(casters, (list, tuple)) else [casters] * len(maps)
    if on_gpu and any(c is None for m, c in zip(maps, per_map, strict=True)
                      if m is not None and len(m.depth)):
        raise ValueError("shadow maps left to the GPU need the frame's casters")
    records, index, depths, mip_rows, layers, rows = [], [], [], [], [], []
    layer = row = 0
    side = max([m.resolution for m in kept], default=1)
    for m, turn in zip(maps, turns, strict=True):
        if m is None or not len(m.depth):
            index.append(-1)
            continue
        offsets, sides, basis, rects, _, fp, ip = shadow_filter.constants(m)
        res, faces = m.resolution, len(m.depth)
        if len(sides) > MAX_LEVELS:
            raise ValueError(f"a shadow map of {res} texels has more than {MAX_LEVELS} levels")
        if on_gpu:
            count = int(offsets[-1]) + faces if len(offsets) else 0
        else:
            depth, mips = shadow_filter.packed(m)[:2]
            padded = np.full((faces, side, side), np.inf, np.float32)
            padded[:, :res, :res] = depth.reshape(faces, res, res)
            depths.append(padded)
            mip_rows.append(mips.reshape(-1, 3))
            count = len(mip_rows[-1])
        index.append(len(records))
        layers.append(layer)
        rows.append(row)
        records.append({
            "fp": fp, "kind": ip[filter_kernel.I_KIND],
            "ints": [faces if on_gpu else 0, res, layer, len(rects)],
            "ints2": [row, len(sides), int(turn), 0],
            "basis": np.pad(basis, ((0, 0), (0, 1))),
            "rects": rects, "offsets": offsets, "sides": sides})
        layer += faces
        row += count
    rot = np.stack([shadow_filter.FILTER_TABLES["rot_cos"],
                    shadow_filter.FILTER_TABLES["rot_sin"]], -1)[None]
    if on_gpu:
        from . import shadow_depths

        depth = gpu.types.GPUTexture((side, side), layers=layer, format="R32F")
        width = min(max(1, row), MIPS_WIDTH)
        mips = gpu.types.GPUTexture((width, -(-max(1, row) // width)), format="RGBA32F")
        drawn_by = [c for m, c in zip(maps, per_map, strict=True)
                    if m is not None and len(m.depth)]
        shadow_depths.draw_depths(kept, drawn_by, depth, layers)
        shadow_depths.draw_pyramids(kept, drawn_by[0], depth, layers, rows, mips)
    else:
        depth = textures.layers(np.concatenate(depths) if depths
                                else np.full((1, 1, 1), np.inf, np.float32))
        mips = textures.rows(np.concatenate(mip_rows) if mip_rows
                             else np.zeros((1, 3), np.float32), MIPS_WIDTH)
    return ShadowSet(index, SHADOW.pack(records), max(1, len(records)), depth, mips,
                     textures.image(rot))


def light_block(lights: list, shadow_index: list[int]) -> bytes:
    """The LightData block of ``lights`` (``core.scene.Light``), each with its shadow map's
    number (``ShadowSet.index``)."""
    from ..core.kernels import shading as shading_kernel

    return LIGHT.pack([{
        "color": np.asarray(light.color, np.float32).ravel()[:3],
        "kind": shading_kernel.KINDS[light.kind],
        "position": np.asarray(light.position, np.float32).ravel()[:3],
        "cos_half": np.cos(0.5 * light.spot_size), "blend": light.spot_blend,
        "axis": np.asarray(light.direction, np.float32).ravel()[:3],
        "shadow": shadow, "receivers": light.receivers}
        for light, shadow in zip(lights, shadow_index, strict=True)])
