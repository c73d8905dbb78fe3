"""A frame drawn on the GPU: the core's prepared ``Frame`` (its triangles, material tables,
lights and shadow maps) rasterized through a camera and shaded with the talk's direct terms.

Per anti-aliasing sample (``core.render.visibility.sample_offsets``, the projection shifted by
the sample's offset): a depth pre-pass, then the visible points shaded (depth test EQUAL) by
the lights in batches of ``BATCH_LIGHTS``, then the world where nothing was drawn; the passes
add up in float32 targets and are divided by the sample count. Every sample is shaded on its
own (the CPU's ``shade_every_sample``; by default the CPU shades once per pixel and triangle,
which differs at edges only).

What the GPU does not draw yet is named by ``unsupported`` (the frame then renders on the CPU).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..core.kernels import shading as shading_kernel
from ..core.render.buffers import Frame
from ..core.render.shading import has_indirect
from . import lights, programs, textures
from .uniforms import Struct

BATCH_LIGHTS = 32  # lights shaded per draw (their blocks stay far below 16 KiB)
FRAME = Struct("FrameData", (
    ("view_proj", "mat4", 0),  # world -> clip of the camera
    ("eye", "vec3", 0), ("ortho", "int", 0),  # the camera's position; 1: orthographic
    ("forward", "vec3", 0),  # the direction it looks along
    ("jitter", "vec2", 0),  # the sample's shift, NDC
    ("counts", "ivec4", 0),  # (lights in the batch, specular model, first batch, -)
    ("world", "vec4", 0),  # the background's radiance and alpha
))
# The targets, in slot order, and the passes they hold (``core.render.passes.PASSES`` names)
TARGETS = ("combined", "diffuse", "specular", "surface", "normal", "emit")
PASS_OF = {"Combined": ("combined", slice(0, 4)), "DiffDir": ("diffuse", slice(0, 3)),
           "GlossDir": ("specular", slice(0, 3)), "Albedo": ("surface", slice(0, 3)),
           "Gloss": ("surface", slice(3, 4)), "Normal": ("normal", slice(0, 3)),
           "Emit": ("emit", slice(0, 3))}


class Unsupported(Exception):
    """The frame needs what the GPU backend does not draw yet: the message says what."""


def unsupported(frame: Frame) -> str | None:
    """What of ``frame`` the GPU does not draw yet (one phrase), or None."""
    scene = frame.scene
    mats = scene.materials
    if has_indirect(frame) or frame.sky is not None:
        return "indirect light (probes, lightmaps, the world's light)"
    varying = [m.name for m, v in zip(mats, frame.tables["varying"], strict=False) if v]
    if varying:
        return f"materials that vary over their surface ({', '.join(varying[:3])})"
    if frame.fades.any():
        return "transparent materials"
    if frame.holdout.any():
        return "holdout"
    if frame.cull is not None:
        return "backface culling"
    if scene.world.texture is not None:
        return "an image world"
    return None


def _program(kind: str) -> programs.Program:
    frame_block = (("FrameData", "frame"),)
    vertex_in = (("VEC3", "pos"), ("VEC3", "nor"), ("VEC3", "geo"), ("FLOAT", "mat"))
    varyings = (("VEC3", "v_position", "smooth"), ("VEC3", "v_normal", "smooth"),
                ("VEC3", "v_geo", "flat"), ("INT", "v_material", "flat"))
    outputs = tuple(("VEC4", f"out_{name}") for name in TARGETS)
    vert = programs.source("frame_vert")
    if kind == "depth":
        return programs.Program("draw", (), (vert, programs.source("depth_frag")),
                                structs=(FRAME,), blocks=frame_block, inputs=vertex_in,
                                varyings=varyings)
    if kind == "background":
        return programs.Program("draw", (), (programs.source("background_vert"),
                                             programs.source("background_frag")),
                                structs=(FRAME,), blocks=frame_block,
                                inputs=(("VEC2", "corner"),), outputs=outputs)
    return programs.Program(
        "draw", ("direct", "shadow_filter", "surface"), (vert, programs.source("frame_frag")),
        defines=lights.filter_defines(), structs=(FRAME, lights.LIGHT, lights.SHADOW),
        prelude=lights.filter_prelude(),
        blocks=frame_block + (("LightData", f"lights[{BATCH_LIGHTS}]"),
                              ("ShadowData", f"shadows[{BATCH_LIGHTS}]")),
        samplers=(("FLOAT_2D", "materials"), ("FLOAT_2D_ARRAY", "shadow_depth"),
                  ("FLOAT_2D", "shadow_mips"), ("FLOAT_2D", "shadow_rotations")),
        inputs=vertex_in, varyings=varyings, outputs=outputs)


def shader(kind: str):
    """The compiled ``kind`` program ("depth", "shade", "background")."""
    return programs.compiled(_program(kind), ("frame", kind))


@dataclass
class _Batch:
    count: int
    light_block: object  # GPUUniformBuf
    shadows: lights.ShadowSet
    shadow_block: object


class GPUFrame:
    """``frame`` on the GPU: its geometry, material table, lights and shadow maps uploaded
    once; ``draw`` renders it through any camera. Raises ``Unsupported`` for a frame the GPU
    does not draw yet (``unsupported``)."""

    def __init__(self, frame: Frame):
        import gpu

        reason = unsupported(frame)
        if reason:
            raise Unsupported(reason)
        self.frame = frame
        keep = np.ones(len(frame.positions), bool) if frame.seen is None else frame.seen
        pos = np.ascontiguousarray(frame.positions[keep], np.float32)
        t = len(pos)
        geo = np.stack(_triangle_normals(pos), -1)
        fmt = gpu.types.GPUVertFormat()
        for name, size in (("pos", 3), ("nor", 3), ("geo", 3), ("mat", 1)):
            fmt.attr_add(id=name, comp_type="F32", len=size, fetch_mode="FLOAT")
        vbo = gpu.types.GPUVertBuf(fmt, 3 * t)
        vbo.attr_fill("pos", pos.reshape(-1, 3))
        vbo.attr_fill("nor", np.ascontiguousarray(frame.normals[keep], np.float32).reshape(-1, 3))
        vbo.attr_fill("geo", np.repeat(geo, 3, axis=0).astype(np.float32))
        vbo.attr_fill("mat", np.repeat(frame.material[keep], 3).astype(np.float32))
        self.triangles = t
        self.batch = gpu.types.GPUBatch(type="TRIS", buf=vbo)
        corner_fmt = gpu.types.GPUVertFormat()
        corner_fmt.attr_add(id="corner", comp_type="F32", len=2, fetch_mode="FLOAT")
        corners = gpu.types.GPUVertBuf(corner_fmt, 3)
        corners.attr_fill("corner", np.float32([[-1, -1], [3, -1], [-1, 3]]))
        self.background = gpu.types.GPUBatch(type="TRIS", buf=corners)
        tab = frame.tables
        table = np.zeros((max(1, len(tab["albedo"])), 3, 4), np.float32)
        table[:len(tab["albedo"]), 0] = np.column_stack([tab["albedo"], tab["gloss"]])
        table[:len(tab["albedo"]), 1] = np.column_stack([tab["rf0"], tab["alpha"]])
        table[:len(tab["albedo"]), 2, :3] = tab["emission"]
        self.materials = textures.image(table.reshape(1, -1, 4))
        scene_lights = frame.scene.lights
        maps = frame.shadow_maps[:len(scene_lights)]
        self.batches = []
        for lo in range(0, max(1, len(scene_lights)), BATCH_LIGHTS):
            group = scene_lights[lo:lo + BATCH_LIGHTS]
            shadow_set = lights.shadow_set(maps[lo:lo + BATCH_LIGHTS])
            self.batches.append(_Batch(
                len(group), gpu.types.GPUUniformBuf(_light_bytes(group, shadow_set)),
                shadow_set, gpu.types.GPUUniformBuf(
                    _padded(shadow_set.block, lights.SHADOW, BATCH_LIGHTS))))

    def draw(self, camera, offsets, targets: Targets) -> None:
        """Add the samples at ``offsets`` ((S, 2) positions in the pixel, top-left origin)
        of the frame through ``camera`` (``core.scene.Camera`` of the targets' size) to
        ``targets``."""
        import gpu

        scene = self.frame.scene
        view_proj = np.asarray(camera.projection @ camera.world_to_camera, np.float64)
        c2w = np.linalg.inv(np.asarray(camera.world_to_camera, np.float64))
        base = {"view_proj": view_proj, "eye": c2w[:3, 3], "ortho": int(camera.orthographic),
                "forward": -c2w[:3, 2] / np.linalg.norm(c2w[:3, 2]),
                "world": np.append(np.asarray(scene.world.color, np.float32), 1.0)}
        model = shading_kernel.MODELS[scene.settings.specular_model]
        depth, shade, background = shader("depth"), shader("shade"), shader("background")
        w, h = camera.width, camera.height
        with targets.framebuffer.bind():
            gpu.state.viewport_set(0, 0, w, h)
            for ox, oy in np.asarray(offsets, np.float64).reshape(-1, 2):
                jitter = ((0.5 - ox) * 2.0 / w, -(0.5 - oy) * 2.0 / h)
                targets.framebuffer.clear(depth=1.0)
                gpu.state.color_mask_set(False, False, False, False)
                gpu.state.depth_mask_set(True)
                gpu.state.depth_test_set("LESS")
                gpu.state.blend_set("NONE")
                block = self._frame_block(base, jitter, 0, model, True)
                depth.bind()
                depth.uniform_block("frame", block)
                self.batch.draw(depth)
                gpu.state.color_mask_set(True, True, True, True)
                gpu.state.depth_mask_set(False)
                gpu.state.blend_set("ADDITIVE_PREMULT")
                gpu.state.depth_test_set("EQUAL")
                shade.bind()
                shade.uniform_sampler("materials", self.materials)
                blocks = []  # alive until drawn
                for k, batch in enumerate(self.batches):
                    blocks.append(self._frame_block(base, jitter, batch.count, model, k == 0))
                    shade.uniform_block("frame", blocks[-1])
                    shade.uniform_block("lights", batch.light_block)
                    shade.uniform_block("shadows", batch.shadow_block)
                    for _, name, texture in batch.shadows.samplers():
                        shade.uniform_sampler(name, texture)
                    self.batch.draw(shade)
                if not scene.settings.film_transparent:
                    gpu.state.depth_test_set("LESS_EQUAL")
                    background.bind()
                    background.uniform_block("frame", block)
                    self.background.draw(background)
            gpu.state.depth_test_set("NONE")
            gpu.state.depth_mask_set(False)
            gpu.state.blend_set("NONE")
        targets.samples += len(np.reshape(offsets, (-1, 2)))

    @staticmethod
    def _frame_block(base: dict, jitter, count: int, model: int, first: bool):
        import gpu

        return gpu.types.GPUUniformBuf(FRAME.pack([{
            **base, "jitter": jitter, "counts": [count, model, int(first), 0]}]))


class Targets:
    """The float32 targets samples add up in (``TARGETS``) and a depth buffer, of one size."""

    def __init__(self, width: int, height: int):
        import gpu

        self.width, self.height = width, height
        self.textures = {name: gpu.types.GPUTexture((width, height), format="RGBA32F")
                         for name in TARGETS}
        self.depth = gpu.types.GPUTexture((width, height), format="DEPTH_COMPONENT32F")
        self.framebuffer = gpu.types.GPUFrameBuffer(
            depth_slot=self.depth, color_slots=tuple(self.textures[n] for n in TARGETS))
        self.samples = 0
        self.clear()

    def clear(self) -> None:
        with self.framebuffer.bind():
            self.framebuffer.clear(color=(0.0, 0.0, 0.0, 0.0), depth=1.0)
        self.samples = 0

    def passes(self, names=None) -> dict[str, np.ndarray]:
        """{pass name: (H, W, C) float32} averaged over the samples, row 0 at the top."""
        out, read = {}, {}
        scale = np.float32(1.0 / max(1, self.samples))
        for name in names or PASS_OF:
            target, channels = PASS_OF[name]
            if target not in read:
                read[target] = textures.read(self.textures[target])[::-1] * scale
            out[name] = np.ascontiguousarray(read[target][..., channels])
        return out


def _triangle_normals(pos: np.ndarray):
    """(c1 - c0) x (c2 - c0) of triangles (T, 3, 3) (``kernels.shading.triangle_normal``)."""
    a, b = pos[:, 1] - pos[:, 0], pos[:, 2] - pos[:, 0]
    return (a[:, 1] * b[:, 2] - a[:, 2] * b[:, 1], a[:, 2] * b[:, 0] - a[:, 0] * b[:, 2],
            a[:, 0] * b[:, 1] - a[:, 1] * b[:, 0])


def _light_bytes(group, shadow_set) -> bytes:
    return _padded(lights.light_block(group, shadow_set.index) if group else b"",
                   lights.LIGHT, BATCH_LIGHTS)


def _padded(block: bytes, struct: Struct, count: int) -> bytes:
    """``block`` (whole structs) padded with zeros to ``count`` structs."""
    size = struct.layout()[1]
    return block[:count * size] + bytes(count * size - min(len(block), count * size))


def render(frame: Frame, offsets) -> dict[str, np.ndarray]:
    """The frame's passes (``PASS_OF``) through its own camera, drawn on the GPU:
    {name: (H, W, C) float32}, row 0 at the top (``pipeline.render_frame``'s layout)."""
    cam = frame.scene.camera
    targets = Targets(cam.width, cam.height)
    GPUFrame(frame).draw(cam, offsets, targets)
    return targets.passes()
