"""Shadow maps drawn on the GPU: the casters' depths of every face and cascade of the maps the
core left to a GPU (``core.render.shadows.ShadowMap.on_gpu``), and their reduction pyramids,
in the layouts the filter reads (``lights.ShadowSet``: ``glsl/shadow_filter.glsl``).

The same maps as ``core.render.shadows`` builds on the CPU: a perspective face stores its clip
w (``kernels.raster.perspective_depths``), a sun cascade the depth along the sun
(``ortho_depths``), +inf where nothing is drawn, each texel the nearest caster at its centre,
row 0 at the top; casters two-sided. Texels exactly on a triangle's edge follow the GPU's
rasterization rule (the CPU counts both triangles), so maps may differ there. The pyramid is
``shadows._pyramid``'s: per block of 2^l x 2^l texels (cut by the map's edge) the least
distance from the light (cascades: depth), the least and the greatest depth, for levels
``MIP_FIRST_LEVEL`` and up; the finest is reduced from the depths at once, each next one from
the level before.
"""

from __future__ import annotations

import numpy as np

from ..core.render.shadows import MIP_FIRST_LEVEL, mip_layout
from . import programs, textures
from .textures import ROW_WIDTH as MIPS_WIDTH

_DEPTH_STATE = ("LESS_EQUAL", True, "NONE")  # depth test, depth writes, blending


def _depth_program(ortho: bool) -> programs.Program:
    return programs.Program(
        "draw", (), (programs.source("shadow_depth_vert"), programs.source("shadow_depth_frag")),
        defines={"ORTHO": int(ortho)}, constants=(("MAT4", "view_proj"), ("VEC4", "along")),
        inputs=(("VEC3", "pos"),), varyings=(("FLOAT", "v_along", "smooth"),),
        outputs=(("FLOAT", "out_depth"),), depth_write=None if ortho else "ANY")


def _level_program(first: bool) -> programs.Program:
    return programs.Program(
        "draw", (), (programs.source("background_vert"), programs.source("shadow_pyramid_frag")),
        defines={"FROM_DEPTHS": int(first), "BLOCK": 1 << MIP_FIRST_LEVEL if first else 2},
        samplers=(("FLOAT_2D_ARRAY", "source"),),
        constants=(("IVEC4", "where"), ("FLOAT", "tan_half")), inputs=(("VEC2", "corner"),),
        outputs=(("VEC4", "out_level"),))


def _pack_program() -> programs.Program:
    return programs.Program(
        "draw", (), (programs.source("background_vert"), programs.source("shadow_pack_frag")),
        defines={"MIPS_WIDTH": MIPS_WIDTH},
        samplers=(("FLOAT_2D_ARRAY", "level"),), constants=(("IVEC4", "span"),),
        inputs=(("VEC2", "corner"),), outputs=(("VEC4", "out_row"),))


class Casters:
    """The frame's shadow casters on the GPU: (T, 3, 3) float32 world corners, metres."""

    def __init__(self, triangles: np.ndarray):
        import gpu

        tris = np.ascontiguousarray(np.asarray(triangles, np.float32).reshape(-1, 3))
        fmt = gpu.types.GPUVertFormat()
        fmt.attr_add(id="pos", comp_type="F32", len=3, fetch_mode="FLOAT")
        vbo = gpu.types.GPUVertBuf(fmt, len(tris))
        vbo.attr_fill("pos", tris)
        self.count = len(tris) // 3
        self.batch = gpu.types.GPUBatch(type="TRIS", buf=vbo)
        self.screen = textures.full_screen()


def _column_major(matrix: np.ndarray) -> list[float]:
    return [float(v) for v in np.asarray(matrix, np.float32).T.reshape(-1)]


def _far(view_proj: np.ndarray) -> float:
    """The far plane of a perspective face's world -> clip matrix (``shadows._perspective``
    times a rigid view): clip w = -z_view, clip z = A z_view + B, far = B / (A + 1)."""
    w_row = view_proj[3]
    a = -float(view_proj[2, :3] @ w_row[:3]) / float(w_row[:3] @ w_row[:3])
    b = float(view_proj[2, 3]) + a * float(w_row[3])
    return b / (a + 1.0)


def draw_depths(maps: list, casters: list[Casters], depth, first_layers: list[int]) -> None:
    """Draw every face of ``maps`` (``ShadowMap`` with ``on_gpu``), each of its ``casters``,
    into the layers of ``depth`` (an R32F 2D-array texture cleared to +inf, side at least
    each map's resolution) from ``first_layers`` on, each face in the top-left res x res of
    its layer."""
    import gpu

    side = depth.width
    zbuffer = gpu.types.GPUTexture((side, side), format="DEPTH_COMPONENT32F")
    saved = gpu.state.depth_test_get(), gpu.state.depth_mask_get(), gpu.state.blend_get()
    gpu.state.depth_test_set(_DEPTH_STATE[0])
    gpu.state.depth_mask_set(_DEPTH_STATE[1])
    gpu.state.blend_set(_DEPTH_STATE[2])
    gpu.state.face_culling_set("NONE")  # casters are two-sided (Blender's default state)
    try:
        for m, first, mine in zip(maps, first_layers, casters, strict=True):
            ortho = m.kind == "ORTHO"
            shader = programs.compiled(_depth_program(ortho), ("shadow_depth", ortho))
            res = m.resolution
            for f in range(len(m.depth)):
                framebuffer = gpu.types.GPUFrameBuffer(
                    depth_slot=zbuffer, color_slots={"texture": depth, "layer": first + f})
                with framebuffer.bind():
                    framebuffer.clear(color=(np.inf, np.inf, np.inf, np.inf), depth=1.0)
                    if not mine.count:
                        continue
                    framebuffer.viewport_set(0, 0, res, res)
                    shader.bind()
                    view_proj = np.asarray(m.view_proj[f], np.float64)
                    if ortho:  # the depth along the sun: z_min + (z_ndc + 1) / 2 (z_hi - z_lo)
                        along = (*m.basis[f][2], 0.0)
                    else:  # gl_FragDepth = w / far: linear, so the nearest wins by w
                        along = (0.0, 0.0, 0.0, 1.0 / _far(view_proj))
                    shader.uniform_float("view_proj", _column_major(view_proj))
                    shader.uniform_float("along", [float(v) for v in along])
                    mine.batch.draw(shader)
    finally:
        gpu.state.depth_test_set(saved[0])
        gpu.state.depth_mask_set(saved[1])
        gpu.state.blend_set(saved[2])


def draw_pyramids(maps: list, casters: Casters, depth, first_layers: list[int],
                  first_rows: list[int], rows) -> None:
    """The reduction pyramid of every map of ``maps`` (drawn by ``draw_depths`` into
    ``depth``) into ``rows`` (RGBA32F, ``MIPS_WIDTH`` texels per row: ``lights.ShadowSet``'s
    ``mips``) from item ``first_rows[k]`` of map k on, in ``shadows.mip_layout``'s order."""
    import gpu

    width = rows.width
    packer = programs.compiled(_pack_program(), "shadow_pack")
    saved = gpu.state.depth_test_get(), gpu.state.blend_get()
    gpu.state.depth_test_set("NONE")
    gpu.state.blend_set("NONE")
    out = gpu.types.GPUFrameBuffer(color_slots=(rows,))
    try:
        for m, layer, row in zip(maps, first_layers, first_rows, strict=True):
            res, faces = m.resolution, len(m.depth)
            offsets, sides = mip_layout(res, faces)
            source, source_side = depth, res
            for level, (offset, side) in enumerate(zip(offsets, sides, strict=True)):
                first = level == 0
                target = gpu.types.GPUTexture((side, side), layers=faces, format="RGBA32F")
                shader = programs.compiled(_level_program(first), ("shadow_level", first))
                for f in range(faces):
                    framebuffer = gpu.types.GPUFrameBuffer(
                        color_slots={"texture": target, "layer": f})
                    with framebuffer.bind():
                        shader.bind()
                        shader.uniform_sampler("source", source)
                        shader.uniform_int("where", [(layer if first else 0) + f, source_side,
                                                     int(m.kind != "ORTHO"), res])
                        if first:
                            shader.uniform_float("tan_half", float(m.tan_half))
                        casters.screen.draw(shader)
                start, count = row + offset, faces * side * side
                with out.bind():
                    lo, hi = start // width, (start + count - 1) // width
                    out.viewport_set(0, lo, width, hi - lo + 1)
                    packer.bind()
                    packer.uniform_sampler("level", target)
                    packer.uniform_int("span", [start, count, side, 0])
                    casters.screen.draw(packer)
                source, source_side = target, side
    finally:
        gpu.state.depth_test_set(saved[0])
        gpu.state.blend_set(saved[1])
