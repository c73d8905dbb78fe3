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

import dataclasses
import threading
from dataclasses import dataclass

import numpy as np

from ..core.formulas import occlusion as occlusion_formulas
from ..core.render import depth_of_field, motion_blur, pipeline
from ..core.render.buffers import Frame
from ..core.render.passes import EMPTY_DEPTH, group_pass
from ..core.render.shading import has_indirect
from ..core.render.transparency import BLEND_LAYERS, DITHER_LAYERS, PEELS, cut_warning
from . import dome, images, lightmaps, lights, materials, occlusion, probes, programs, textures
from .uniforms import Struct

BATCH_LIGHTS = 32  # lights shaded per draw (their blocks stay far below 16 KiB)
DOME_BATCH_LIGHTS = 8  # lights of the first draw when the world's dome shares its block
SHADOW_RECORDS = DOME_BATCH_LIGHTS + dome.MAX_DIRECTIONS  # a draw's ShadowData (15 KiB)
FRAME = Struct("FrameData", (
    ("view_proj", "mat4", 0),  # world -> clip of the camera
    ("clip_to_world", "mat4", 0),  # its inverse
    ("world_to_camera", "mat4", 0),
    ("ndc_scale", "vec2", 0),  # the frame's part of the target (1, 1; less with a margin)
    ("sample_offset", "vec2", 0),  # the sample's position in its pixel, top-left origin
    ("eye", "vec3", 0), ("ortho", "int", 0),  # the camera's position; 1: orthographic
    ("forward", "vec3", 0),  # the direction it looks along
    ("jitter", "vec2", 0),  # the sample's shift, NDC
    ("counts", "ivec4", 0),  # (lights in the batch, specular model, first batch, MODES)
    ("size", "ivec4", 0),  # (width, height, the sample's number, -)
    ("flags", "ivec4", 0),  # (specular occlusion, peeling: the depth pre-pass, layered
    #                          diffuse, a transparent film)
    ("world", "vec4", 0),  # the background's radiance and alpha
    ("shutter", "vec4", 0),  # (the sample's shutter time, 1 where it moves: the motion blur
    #                          of the geometry's steps m0..m2; 0: the frame's own time, -, -)
    ("options", "ivec4", 0),  # (the blended stacks' layer drawn plus 1, 0: the sample's own
    #                          surfaces (``glsl/stack.glsl``); the Shadow Catcher pass; the
    #                          share of the shutter shaded at plus 1, 0: the frame's own time
    #                          (``Frame.at_times``); the moving triangles' count)
))
WORLD = Struct("WorldData", (
    ("clip_to_world", "mat4", 0),  # the camera's inverse projection and view
    ("rotation", "vec4", 3),  # world -> texture rotation rows (the Mapping node's)
    ("params", "vec4", 0),  # (strength, background alpha, level of detail or -1, has a sun)
    ("sun", "vec4", 0),  # towards the sun, cos(half its angle)
    ("sun_color", "vec4", 0),  # its disc's radiance
))
# How a sample is shaded (``glsl/frame_frag.glsl``): the batch's first sample, a later one
# (reusing the first's shading where it sees the same triangle), or every sample on its own
MODES = {"MODE_FIRST": 0, "MODE_REST": 1, "MODE_EVERY": 2}
# What shading gives (the order of ``WRITE_TARGETS``'s arguments), the passes each holds
# (``core.render.passes.PASSES`` names), and the groups drawn at once (a framebuffer holds
# six targets: the key and five)
TARGETS = ("combined", "diffuse", "specular", "diff_ind", "gloss_ind", "emit", "surface",
           "normal", "position", "uv", "rf0", "ao", "lightmap", "texels", "reflections",
           "volumes", "catcher")
PASS_OF = {"Combined": ("combined", slice(0, 4)), "DiffDir": ("diffuse", slice(0, 3)),
           "GlossDir": ("specular", slice(0, 3)), "DiffInd": ("diff_ind", slice(0, 3)),
           "GlossInd": ("gloss_ind", slice(0, 3)), "Albedo": ("surface", slice(0, 3)),
           "Gloss": ("surface", slice(3, 4)), "Normal": ("normal", slice(0, 3)),
           "Emit": ("emit", slice(0, 3)), "Position": ("position", slice(0, 3)),
           "UV": ("uv", slice(0, 3)), "Specular Color": ("rf0", slice(0, 3)),
           "AO": ("ao", slice(0, 1)), "Lightmap": ("lightmap", slice(0, 3)),
           "Lightmap Texels": ("texels", slice(0, 3)),
           "Shadow Catcher": ("catcher", slice(0, 3))}
# a triangle's flags (``glsl/frame_vert.glsl``)
FLAG_CULL, FLAG_HOLDOUT, FLAG_FADES, FLAG_DARK, FLAG_CATCHER, FLAG_BLENDED = 1, 2, 4, 8, 16, 32
FLAG_MOVES = 64  # the triangle moves over the shutter: a sample never reuses its shading
# Depth and IndexMA come from one sample, the one nearest the pixel centre (``central``)
CENTRAL = ("Depth", "IndexMA")
GROUPS = (("combined", "diffuse", "specular", "diff_ind", "gloss_ind"),
          ("emit", "surface", "normal", "position", "uv"),
          ("rf0", "ao", "lightmap", "texels", "catcher"))
# the targets that need the lights or the indirect light (the others: the surface alone);
# the probes' influence views ("reflections", "volumes") are no pass: the viewport's alone
LIT = {"combined", "diffuse", "specular", "diff_ind", "gloss_ind", "ao", "lightmap", "texels",
       "reflections", "volumes", "catcher"}
DOME_TEXTURES = ("dome_grid", "dome_points", "dome_normals")  # dome_grid_frag's outputs


GPU_BUDGET = 4 << 30  # bytes of GPU memory a frame may take (the gpu module cannot tell)


def memory(width: int, height: int, names: tuple[str, ...], blended: bool = False) -> int:
    """Bytes of GPU memory the targets of one group ``names`` take at width x height: the
    first and later samples' (each with its key), the total, the pre-pass's triangle and the
    depth; the contact occlusion's buffers (the frame and its margin) beside them; with
    ``blended``, the blended stacks' (``GPUFrame._stack``)."""
    pixels = width * height
    margin = (width + 2 * 64) * (height + 2 * 64)
    stacks = pixels * (16 * STACK_TEXTURES + 4) if blended else 0
    return (pixels * (16 * (3 * len(names) + 3) + 4) + margin * (2 * 16 + 4) + pixels * 32
            + stacks)


STACK_TEXTURES = 15  # float32 RGBA per pixel of a sample's blended stacks (``GPUFrame._stack``)
STACK_SLOTS = BLEND_LAYERS // 2  # textures holding a stack's layers, two to a texel
STACK_SAMPLERS = (("FLOAT_2D", "stack_state"),) + tuple(
    ("FLOAT_2D", f"stack_slots{k}") for k in range(STACK_SLOTS)) + (("FLOAT_2D", "stack_order"),)
STACK_DEFINES = {"BLEND_LAYERS": BLEND_LAYERS, "DITHER_LAYERS": DITHER_LAYERS,
                 "ORDER_ROW": textures.ROW_WIDTH}
MOTION_STEPS = 3  # shutter steps the vertex shader reads (m0, m1, m2; ``frame_vert.glsl``)
GPU_LINK_SETS = 32  # light linking sets a triangle's ``links`` holds (set 0 included)


class Unsupported(Exception):
    """The frame needs what the GPU backend does not draw yet: the message says what."""


def unsupported(frame: Frame) -> str | None:
    """What of ``frame`` the GPU does not draw yet (one phrase), or None."""
    scene = frame.scene
    mats = scene.materials
    if has_indirect(frame):
        why = dome.unsupported(frame) or probes.unsupported(scene.probes,
                                                            scene.settings.volume_visibility)
        if why:
            return why
    if frame.catcher is not None:
        # a catcher's share is held over free irradiance of all lights: one batch of them
        first = (DOME_BATCH_LIGHTS if has_indirect(frame) and frame.sky is not None
                 else BATCH_LIGHTS)
        if len(scene.lights) > first:
            return f"shadow catchers with more than {first} lights"
        if scene.world.texture is not None and not scene.settings.film_transparent:
            return "shadow catchers over an image world"
        if scene.settings.light_groups:
            return "shadow catchers with light groups"
    if frame.blends is not None and len(frame.positions) >= 1 << 24:
        return "blended materials among more than 16.7 million triangles"
    if frame.motion_reach and scene.settings.rolling_shutter is not None:
        return "a rolling shutter (a time per band of pixel rows)"
    if frame.motion is not None and len(frame.motion) != MOTION_STEPS:
        return f"motion blur of other than {MOTION_STEPS} steps"
    if any(light.receivers >= GPU_LINK_SETS for light in scene.lights):
        return f"more than {GPU_LINK_SETS - 1} light linking collections"
    varying = [m.program for m, v in zip(mats, frame.tables["varying"], strict=False) if v]
    why = materials.unsupported(varying, frame.attributes)
    if why:
        return why
    return None


def _writes(names: tuple[str, ...]) -> dict:
    """The defines that store shading's values into the targets ``names``."""
    args = ", ".join(f"v_{name}" for name in TARGETS)
    stores = " ".join(f"out_{name} = stack_weight * (v_{name});" for name in names)
    compose = " ".join(f"out_{name} = texelFetch(rest_{name}, pixel, 0) + weight * "
                       f"texelFetch(first_{name}, pixel, 0);" for name in names)
    return {f"WRITE_TARGETS({args})": stores, "COMPOSE_TARGETS": compose,
            "WRITE_ZEROS": " ".join(f"out_{name} = vec4(0.0);" for name in names),
            "WRITE_COMBINED(c)": "out_combined = c;" if "combined" in names else "",
            "WRITE_CATCHER(c)": "out_catcher = c;" if "catcher" in names else ""}


@dataclass
class MaterialCode:
    """The frame's materials that vary over their surface, as GLSL (``materials``): the
    fragment shader's generated part, the corner attributes its vertices carry, its images
    and the key naming it among compiled shaders."""

    code: str
    streams: int
    images: int
    key: str
    constants: np.ndarray  # (K, 4) the rows of mat_const


def material_code(frame: Frame) -> tuple[MaterialCode | None, list, list]:
    """(the code of ``frame``'s varying materials or None, the corner attributes' keys it
    reads (vertex inputs a0, a1 ...), the images (``Texture``) it reads, in ``images[]``
    order)."""
    import hashlib

    mats = frame.scene.materials
    varying = [(k, m.program) for k, (m, v) in enumerate(zip(mats, frame.tables["varying"],
                                                            strict=False)) if v]
    wanted = frame.scene.settings.aovs
    names = {name for name, _ in wanted}
    writers = [(k, m.program) for k, m in enumerate(mats)
               if any(name in names for name, *_ in m.program.aovs)]
    if not varying and not writers:
        return None, [], []
    read = varying + [w for w in writers if w not in varying]
    keys = [k for k in materials.streams([p for _, p in read]) if k in frame.attributes]
    streams = {key: k for k, key in enumerate(keys)}
    texs, numbers = [], {}
    for _, program in read:
        for op in program.ops:
            if op.kind == "image" and op.param[0] is not None and id(op.param[0]) not in numbers:
                numbers[id(op.param[0])] = len(texs)
                texs.append(op.param[0])
    derivatives = "".join(f"  mp_a{k} = v_a{k};\n  mp_da{k}[0] = dFdx(v_a{k});\n"
                          f"  mp_da{k}[1] = dFdy(v_a{k});\n" for k in range(len(keys)))
    cases = "".join(f"    case {k}: m = material_{k}(p); break;\n" for k, _ in varying)
    constants = materials.Constants()
    code = "\n".join([
        materials.attribute_globals(len(keys)),
        "void material_derivatives()", "{",
        "  ivec2 px = ivec2(gl_FragCoord.xy);",
        "  mp_pixel = vec2(float(px.x), float(frame.size.y - 1 - px.y)) + frame.sample_offset;",
        "  mp_dpos[0] = dFdx(v_position);", "  mp_dpos[1] = dFdy(v_position);",
        "  mp_uv0 = v_uv;", "  mp_duv[0] = dFdx(v_uv);", "  mp_duv[1] = dFdy(v_uv);",
        derivatives + "}", "",
        *(materials.surface_function(program, f"material_{k}", numbers, streams, constants)
          for k, program in varying),
        "void material_apply(int material, inout Surface s)", "{",
        "  MatPoint p = mp_point(s.p, s.n, s.geo, s.v);", "  MatSurface m;",
        "  switch (material) {", cases + "    default: return;", "  }",
        "  s.albedo = m.albedo;", "  s.rf0 = m.rf0;", "  s.emission = m.emission;",
        "  s.gloss = m.gloss;", "  s.n = m.normal;", "  s.occlusion = m.occlusion;",
        "  s.alpha = m.alpha;", "  s.layer = m.layer;", "  s.layer_f0 = m.layer_f0;", "}", "",
        _aov_code(writers, wanted, numbers, streams, constants)])
    return (MaterialCode(code, len(keys), len(texs), hashlib.sha256(code.encode()).hexdigest(),
                         constants.array()), keys, texs)


def _aov_code(writers, wanted, numbers, streams, constants) -> str:
    """GLSL of ``vec4 material_aov(int material, int which, Surface s)``: the shader AOV
    ``wanted[which]`` of a material at a point (``core.scene.material.evaluate_aovs``: its
    colour and 1, or its value), 0 where the material writes none; each writer's registers
    through ``materials.value_function``."""
    parts, cases = [], []
    for k, program in writers:
        own = {name: (color, value) for name, color, value in program.aovs}
        regs, rows = [], []
        for j, (name, kind) in enumerate(wanted):
            if name in own:
                regs.append(own[name][0 if kind == "COLOR" else 1])
                x = f"aov_{k}(p, {len(regs) - 1})"
                rows.append(f"      case {j}: return " + (
                    f"vec4({x}.xyz, 1.0);" if kind == "COLOR" else f"vec4({x}.x, 0.0, 0.0, 1.0);"))
        parts.append(materials.value_function(program, regs, f"aov_{k}", numbers, streams,
                                              constants))
        cases.append(f"    case {k}:\n      switch (which) {{\n" + "\n".join(rows)
                     + "\n      }\n      break;")
    return "\n".join(parts + [
        "vec4 material_aov(int material, int which, Surface s)", "{",
        "  MatPoint p = mp_point(s.p, s.n, s.geo, s.v);",
        "  switch (material) {", *cases, "  }", "  return vec4(0.0);", "}", ""])


def _with_materials(program: programs.Program, mat: MaterialCode | None) -> programs.Program:
    """``program`` (a frame_frag one) with the materials' code, or as it is without."""
    if mat is None:
        return program
    at = program.sources.index("surface")
    vertex, fragment = program.main
    return dataclasses.replace(
        program, sources=program.sources[:at] + ("texture", "nodes", "material_frame")
        + program.sources[at:], main=(vertex, mat.code + "\n" + fragment),
        defines={**program.defines, "MATERIALS": 1, "MATERIAL_VERTEX": " ".join(
            ["v_object = inst;"] + [f"v_a{k} = a{k};" for k in range(mat.streams)])},
        structs=program.structs + ((images.IMAGE,) if images.IMAGE not in program.structs
                                   else ()),
        blocks=program.blocks + (("ImageData", f"images[{max(1, mat.images)}]"),),
        samplers=program.samplers + (("FLOAT_2D", "mat_texels"), ("FLOAT_2D", "mat_floats"),
                                     ("FLOAT_2D", "srgb_table"), ("FLOAT_2D", "objects"),
                                     ("FLOAT_2D", "mat_consts")),
        inputs=program.inputs + (("INT", "inst"),) + tuple(("VEC4", f"a{k}")
                                                          for k in range(mat.streams)),
        varyings=program.varyings + (("INT", "v_object", "flat"),) + tuple(
            ("VEC4", f"v_a{k}", "smooth") for k in range(mat.streams)))


def _with_motion(program: programs.Program) -> programs.Program:
    """``program`` (one drawing the frame's triangles) reading their corners at the shutter's
    ``MOTION_STEPS`` steps (``core.render.motion_blur``)."""
    return dataclasses.replace(
        program, defines={**program.defines, "MOTION": 1, "SHARE_ROW": textures.ROW_WIDTH},
        inputs=program.inputs + tuple(("VEC3", f"m{k}") for k in range(MOTION_STEPS)),
        samplers=program.samplers + (("FLOAT_2D", "share_rows"), ("FLOAT_2D", "share_corners")),
        varyings=program.varyings + (("VEC3", "v_moved", "smooth"),))


def _program(kind: str, names: tuple[str, ...], indirect: bool = False,
             ambient: bool = False, sky: bool = False) -> programs.Program:
    frame_block = (("FrameData", "frame"),)
    vertex_in = (("VEC3", "pos"), ("VEC3", "nor"), ("VEC3", "geo"), ("FLOAT", "mat"),
                 ("INT", "tri"), ("INT", "lm"), ("VEC2", "lm_uv"), ("VEC3", "uv"),
                 ("INT", "flags"), ("INT", "links"))
    varyings = (("VEC3", "v_position", "smooth"), ("VEC3", "v_normal", "smooth"),
                ("VEC3", "v_geo", "flat"), ("INT", "v_material", "flat"),
                ("INT", "v_tri", "flat"), ("INT", "v_lightmap", "flat"),
                ("VEC2", "v_lightmap_uv", "smooth"), ("VEC3", "v_uv", "smooth"),
                ("INT", "v_flags", "flat"), ("INT", "v_links", "flat"))
    outputs = (("VEC4", "out_key"),) + tuple(("VEC4", f"out_{name}") for name in names)
    vert = programs.source("frame_vert")
    corner = (("VEC2", "corner"),)
    if kind == "depth":
        return programs.Program("draw", ("key",), (vert, programs.source("depth_frag")),
                                structs=(FRAME,), blocks=frame_block,
                                samplers=(("FLOAT_2D", "peel_floor"),), inputs=vertex_in,
                                varyings=varyings, outputs=(("VEC4", "out_visible"),))
    if kind == "peel":
        return programs.Program("draw", ("key", "dither", "surface"),
                                (vert, programs.source("peel_frag")), structs=(FRAME,),
                                blocks=frame_block, samplers=(("FLOAT_2D", "materials"),
                                                              ("FLOAT_2D", "visible"),
                                                              ("FLOAT_2D", "peel_prev")),
                                inputs=vertex_in, varyings=varyings,
                                outputs=(("VEC4", "out_floor"),))
    if kind == "stack":
        return programs.Program("draw", ("key", "dither", "surface", "stack"),
                                (vert, programs.source("stack_frag")), defines=STACK_DEFINES,
                                structs=(FRAME,), blocks=frame_block,
                                samplers=(("FLOAT_2D", "materials"), ("FLOAT_2D", "visible"))
                                + STACK_SAMPLERS, inputs=vertex_in, varyings=varyings,
                                outputs=(("VEC4", "out_floor"), ("VEC4", "out_record")))
    if kind == "stack_merge":
        return programs.Program(
            "draw", ("key",), (programs.source("background_vert"),
                               programs.source("stack_merge_frag")),
            structs=(FRAME,), blocks=frame_block,
            samplers=(("FLOAT_2D", "visible"),) + STACK_SAMPLERS[:-1] + (
                ("FLOAT_2D", "stack_record"), ("FLOAT_2D", "peel_floor"),
                ("FLOAT_2D", "next_visible")), inputs=corner,
            outputs=(("VEC4", "out_visible"), ("VEC4", "out_state")) + tuple(
                ("VEC4", f"out_slots{k}") for k in range(STACK_SLOTS)))
    if kind == "merge":
        return programs.Program("draw", (), (programs.source("background_vert"),
                                             programs.source("merge_frag")),
                                samplers=(("FLOAT_2D", "peel_floor"),
                                          ("FLOAT_2D", "next_visible")),
                                inputs=corner, outputs=(("VEC4", "out_visible"),))
    if kind == "aov":
        return programs.Program("draw", ("key", "surface"), (vert, programs.source("aov_frag")),
                                structs=(FRAME,), blocks=frame_block,
                                samplers=(("FLOAT_2D", "materials"), ("FLOAT_2D", "visible")),
                                inputs=vertex_in, varyings=varyings,
                                outputs=(("VEC4", "out_aov"),))
    if kind == "central":
        return programs.Program("draw", ("key", "surface"), (vert, programs.source("central_frag")),
                                structs=(FRAME,), blocks=frame_block,
                                samplers=(("FLOAT_2D", "materials"), ("FLOAT_2D", "visible")),
                                inputs=vertex_in, varyings=varyings,
                                outputs=(("VEC4", "out_central"),))
    if kind == "center":
        return programs.Program("draw", (), (vert, programs.source("center_frag")),
                                structs=(FRAME,), blocks=frame_block, inputs=vertex_in,
                                varyings=varyings, outputs=outputs[:2])
    if kind == "background":
        world = {"sources": ("texture",), "defines": {"WORLD_IMAGE": 1},
                 "structs": (WORLD, images.IMAGE),
                 "blocks": (("WorldData", "world"), ("ImageData", "images[1]")),
                 "samplers": (("FLOAT_2D", "world_texels"), ("FLOAT_2D", "srgb_table"))
                 } if indirect else {}
        return programs.Program(
            "draw", world.get("sources", ()), (programs.source("background_vert"),
                                               programs.source("background_frag")),
            defines={**_writes(names), **world.get("defines", {})},
            structs=(FRAME,) + world.get("structs", ()),
            blocks=frame_block + world.get("blocks", ()),
            samplers=(("FLOAT_2D", "visible"),) + world.get("samplers", ()),
            inputs=corner, outputs=outputs)
    if kind == "compose":
        return programs.Program(
            "draw", (), (programs.source("background_vert"), programs.source("compose_frag")),
            defines=_writes(names), inputs=corner,
            samplers=(("FLOAT_2D", "first_key"), ("FLOAT_2D", "rest_key")) + tuple(
                ("FLOAT_2D", f"{part}_{name}") for part in ("first", "rest") for name in names),
            outputs=outputs[1:])
    samplers = (("FLOAT_2D", "materials"), ("FLOAT_2D", "first_key"), ("FLOAT_2D", "visible"))
    shadow_samplers = (("FLOAT_2D_ARRAY", "shadow_depth"), ("FLOAT_2D", "shadow_mips"),
                       ("FLOAT_2D", "shadow_rotations"))
    if kind == "dome_grid":
        return programs.Program(
            "draw", ("shadow_filter", "surface", "dome"),
            (vert, programs.source("dome_grid_frag")), defines=lights.filter_defines(),
            structs=(FRAME, lights.SHADOW, dome.DOME), prelude=lights.filter_prelude(),
            blocks=frame_block + (("ShadowData", f"shadows[{SHADOW_RECORDS}]"),
                                  ("DomeData", "dome")),
            samplers=samplers[:1] + shadow_samplers, inputs=vertex_in, varyings=varyings,
            outputs=(("VEC4", "out_vis"), ("VEC4", "out_point"), ("VEC4", "out_normal")))
    if not set(names) & LIT:
        return programs.Program(
            "draw", ("key", "surface"), (vert, programs.source("frame_frag")),
            defines={**MODES, **_writes(names), "SURFACE_ONLY": 1}, structs=(FRAME,),
            blocks=frame_block, samplers=samplers, inputs=vertex_in, varyings=varyings,
            outputs=outputs)
    sources = ("key", "direct", "shadow_filter", "surface")
    defines = {**lights.filter_defines(), **MODES, **_writes(names)}
    structs = (FRAME, lights.LIGHT, lights.SHADOW)
    blocks = frame_block + (("LightData", f"lights[{BATCH_LIGHTS}]"),
                            ("ShadowData", f"shadows[{SHADOW_RECORDS}]"))
    samplers += shadow_samplers
    prelude = lights.filter_prelude()
    if indirect:
        sources += ("indirect",)
        defines.update(probes.defines(), INDIRECT=1)
        structs += (probes.INDIRECT, probes.REFLECTION, probes.VOLUME)
        blocks += tuple((struct, member) for struct, member, _ in probes.BLOCKS)
        samplers += tuple((kind_, name) for kind_, name in probes.SAMPLERS)
        prelude += probes.prelude()
        sources += ("occlusion", "lightmap")
        defines.update(lightmaps.defines())
        prelude += lightmaps.prelude()
        structs += (lightmaps.LIGHTMAPS,)
        blocks += (("LightmapData", "lightmaps"),)
        samplers += (("FLOAT_2D", "lightmap_texels"),)
        if sky:
            sources += ("dome",)
            defines.update(DOME=1, DOME_SHADING=1)
            structs += (dome.DOME,)
            blocks += (("DomeData", "dome"),)
            samplers += tuple(("FLOAT_2D", name) for name in DOME_TEXTURES)
    if ambient:
        defines["AMBIENT"] = 1
        structs += (occlusion.AO,)
        blocks += (("AOData", "ao"),)
        samplers += (("FLOAT_2D", "ambient"),)
    return programs.Program(
        "draw", sources, (vert, programs.source("frame_frag")), defines=defines,
        structs=structs, prelude=prelude, blocks=blocks, samplers=samplers, inputs=vertex_in,
        varyings=varyings, outputs=outputs)


def _with_stacks(program: programs.Program) -> programs.Program:
    """``program`` (a "shade", "background" or "aov" one) drawing the blended stacks' layers
    too (``glsl/stack.glsl``)."""
    return dataclasses.replace(
        program, sources=program.sources + ("stack",),
        defines={**program.defines, **STACK_DEFINES, "BLENDED": 1},
        samplers=program.samplers + STACK_SAMPLERS)


def shader(kind: str, names: tuple[str, ...] = GROUPS[0], indirect: bool = False,
           ambient: bool = False, sky: bool = False, mat: MaterialCode | None = None,
           motion: bool = False, blended: bool = False):
    """The compiled ``kind`` program ("depth", "center", "central", "dome_grid", "shade",
    "peel", "merge", "background", "compose", "aov", "stack", "stack_merge") writing the
    targets ``names``; ``indirect``: with the probes' light (``glsl/indirect.glsl``),
    ``ambient``: its contact occlusion, ``sky``: the world's occlusion through the dome
    (``glsl/dome.glsl``); ``mat``: "shade", "peel", "aov" and "stack" with the frame's
    material programs; ``motion``: the triangles' motion over
    the shutter (the programs that draw them); ``blended``: "shade", "background" and "aov"
    drawing the blended stacks' layers too."""
    blended = blended and kind in ("shade", "background", "aov")
    if kind == "background":  # ``indirect``: the world is an image
        program = _program(kind, names, indirect)
        return programs.compiled(_with_stacks(program) if blended else program,
                                 ("frame", kind, names, indirect, blended))
    indirect = indirect and kind == "shade" and bool(set(names) & LIT)
    ambient = ambient and kind == "shade" and bool(set(names) & LIT)
    sky = sky and indirect
    mat = mat if kind in ("shade", "peel", "aov", "stack") else None
    motion = motion and kind in ("depth", "center", "central", "dome_grid", "shade", "peel",
                                 "aov", "stack")
    key = ("frame", kind, names, indirect, ambient, sky, mat and mat.key, motion, blended)
    program = _with_materials(_program(kind, names, indirect, ambient, sky), mat)
    program = _with_stacks(program) if blended else program
    return programs.compiled(_with_motion(program) if motion else program, key)


@dataclass
class _Batch:
    count: int
    light_block: object  # GPUUniformBuf
    shadows: lights.ShadowSet
    shadow_block: object


# [(key, shadow sets, what the key's ids name)] of the last GPUFrame: the drawn or uploaded
# shadow maps of a frame whose geometry and maps are the same objects (``with_materials``);
# ``release`` empties it
_kept_shadows: list = []
_kept_lock = threading.Lock()


def release() -> None:
    """Let go of the GPU memory kept for the next frame (the last frame's shadow maps, the
    material images' uploads): when the viewport closes and after a final frame."""
    with _kept_lock:
        _kept_shadows.clear()
    images.release()


class GPUFrame:
    """``frame`` on the GPU: its geometry, material table, lights and shadow maps uploaded
    once; ``draw`` renders it through any camera. Raises ``Unsupported`` for a frame the GPU
    does not draw yet (``unsupported``)."""

    def __init__(self, frame: Frame, dark: np.ndarray | None = None):
        import gpu

        reason = unsupported(frame)
        if reason:
            raise Unsupported(reason)
        self.frame = frame
        # the samples' times when anything moves (``_lens``), else None
        self.shutter = frame.scene.settings.shutter_curve if frame.motion_reach else None
        keep = np.ones(len(frame.positions), bool) if frame.seen is None else frame.seen
        pos = np.ascontiguousarray(frame.positions[keep], np.float32)
        t = len(pos)
        geo = np.stack(_triangle_normals(pos), -1)
        fmt = gpu.types.GPUVertFormat()
        for name, size in (("pos", 3), ("nor", 3), ("geo", 3), ("mat", 1)):
            fmt.attr_add(id=name, comp_type="F32", len=size, fetch_mode="FLOAT")
        fmt.attr_add(id="tri", comp_type="I32", len=1, fetch_mode="INT")
        fmt.attr_add(id="lm", comp_type="I32", len=1, fetch_mode="INT")
        fmt.attr_add(id="lm_uv", comp_type="F32", len=2, fetch_mode="FLOAT")
        fmt.attr_add(id="uv", comp_type="F32", len=3, fetch_mode="FLOAT")
        fmt.attr_add(id="flags", comp_type="I32", len=1, fetch_mode="INT")
        fmt.attr_add(id="links", comp_type="I32", len=1, fetch_mode="INT")
        self.motion = frame.motion is not None  # the triangles move over the shutter
        if self.motion:
            for k in range(MOTION_STEPS):
                fmt.attr_add(id=f"m{k}", comp_type="F32", len=3, fetch_mode="FLOAT")
        self.mat, keys, texs = material_code(frame)
        if self.mat is not None:
            fmt.attr_add(id="inst", comp_type="I32", len=1, fetch_mode="INT")
            for k in range(len(keys)):
                fmt.attr_add(id=f"a{k}", comp_type="F32", len=4, fetch_mode="FLOAT")
        vbo = gpu.types.GPUVertBuf(fmt, 3 * t)
        vbo.attr_fill("pos", pos.reshape(-1, 3))
        vbo.attr_fill("nor", np.ascontiguousarray(frame.normals[keep], np.float32).reshape(-1, 3))
        vbo.attr_fill("geo", np.repeat(geo, 3, axis=0).astype(np.float32))
        vbo.attr_fill("mat", np.repeat(frame.material[keep], 3).astype(np.float32))
        vbo.attr_fill("tri", np.repeat(np.flatnonzero(keep).astype(np.int32), 3))
        lit = frame.lightmap is not None and frame.scene.probes is not None
        vbo.attr_fill("lm", np.repeat(frame.lightmap[keep].astype(np.int32), 3) if lit
                      else np.full(3 * t, -1, np.int32))
        vbo.attr_fill("lm_uv", np.ascontiguousarray(frame.lightmap_uvs[keep], np.float32)
                      .reshape(-1, 2) if lit else np.zeros((3 * t, 2), np.float32))
        uv = np.zeros((t, 3, 3), np.float32)  # (u, v, 1) where the triangle has UVs
        if len(frame.uvs):
            has = frame.has_uv[keep]
            uv[has, :, :2] = frame.uvs[keep][has]
            uv[has, :, 2] = 1.0
        vbo.attr_fill("uv", uv.reshape(-1, 3))
        flags = np.zeros(t, np.int32)  # glsl/flags.glsl: culled from behind, holdout
        if frame.cull is not None:
            flags |= frame.cull[keep].astype(np.int32) * FLAG_CULL
        flags |= frame.holdout[keep].astype(np.int32) * FLAG_HOLDOUT
        flags |= frame.dithers[keep].astype(np.int32) * FLAG_FADES
        if frame.blends is not None:
            flags |= frame.blends[keep].astype(np.int32) * FLAG_BLENDED
        if frame.catcher is not None:
            flags |= frame.catcher[keep].astype(np.int32) * FLAG_CATCHER
        if frame.motion_row is not None:
            flags |= (frame.motion_row[keep] >= 0).astype(np.int32) * FLAG_MOVES
        if dark is not None:  # (a light group's frame: the emission of other groups' meshes)
            flags |= dark[keep].astype(np.int32) * FLAG_DARK
        vbo.attr_fill("flags", np.repeat(flags, 3))
        # light linking: the receiver sets of the triangle's mesh, the low 32 (``unsupported``)
        links = (np.full(t, -1, np.int32) if frame.receives is None else
                 (frame.receives[keep] & np.uint64(0xFFFFFFFF)).astype(np.uint32)
                 .view(np.int32))
        vbo.attr_fill("links", np.repeat(links, 3))
        if self.motion:
            rows = frame.motion_row[keep]
            for k in range(MOTION_STEPS):
                step = pos.copy()
                step[rows >= 0] = frame.motion[k][rows[rows >= 0]]
                vbo.attr_fill(f"m{k}", step.reshape(-1, 3))
        self.mat_resources = None  # (ImageData buffer, samplers) of the material programs
        if self.mat is not None:
            vbo.attr_fill("inst", np.repeat(frame.obj[keep].astype(np.int32), 3))
            for k, key in enumerate(keys):
                corners = np.zeros((t, 3, 4), np.float32)
                a = frame.attributes[key][keep]
                corners[..., :a.shape[2]] = a[..., :4]
                vbo.attr_fill(f"a{k}", corners.reshape(-1, 4))
            rows = np.zeros((len(frame.world_to_object), 5, 4), np.float32)
            rows[:, :3] = np.asarray(frame.world_to_object, np.float64)[:, :3]
            rows[:, 3:, :3] = frame.texspace
            records, (floats, codes) = images.pack(texs)
            self.mat_resources = (
                gpu.types.GPUUniformBuf(images.IMAGE.pack(records)),
                (("mat_texels", codes), ("mat_floats", floats),
                 ("srgb_table", images.srgb_table()),
                 ("objects", textures.rows(rows.reshape(-1, 4))),
                 ("mat_consts", textures.rows(self.mat.constants))))
        self.triangles = t
        self.batch = gpu.types.GPUBatch(type="TRIS", buf=vbo)
        self.blended = frame.blends is not None  # blended stacks (``_stack``)
        self.stack_order = None  # per triangle (its rank, its object shown once or -1)
        self.cut = 0  # pixel samples whose blended stack was cut (``transparency.blend``)
        if self.blended:
            n = len(frame.positions)
            rank = np.zeros(n) if frame.blend_rank is None else frame.blend_rank
            solo = np.full(n, -1.0) if frame.blend_solo is None else frame.blend_solo
            self.stack_order = textures.rows(np.column_stack([rank, solo]))
        self._stacks = None  # (size, textures and framebuffers) of the blended stacks
        self._after = None  # (size, texture, framebuffer, depth) of ``_behind``
        self._stack_state = None  # the last sample's stacks: (state, layers) textures
        self.background = textures.full_screen()
        tab = frame.tables
        table = np.zeros((max(1, len(tab["albedo"])), 4, 4), np.float32)
        table[:len(tab["albedo"]), 0] = np.column_stack([tab["albedo"], tab["gloss"]])
        table[:len(tab["albedo"]), 1] = np.column_stack([tab["rf0"], tab["alpha"]])
        table[:len(tab["albedo"]), 2] = np.column_stack([tab["emission"], tab["occlusion"]])
        table[:len(tab["albedo"]), 3, :3] = np.column_stack([tab["pass_index"], tab["layer"],
                                                             tab["layer_f0"]])
        self.materials = textures.image(table.reshape(1, -1, 4))
        self.world = None  # (ImageData record's buffer, texels, sRGB table) of an image world
        world = frame.scene.world
        if world.texture is not None:
            record, texels = images.upload(world.texture)
            self.world = (gpu.types.GPUUniformBuf(images.IMAGE.pack([record])), texels,
                          images.srgb_table())
        self.indirect = None
        s = frame.scene.settings
        self.ambient = (frame.scene.probes is not None and s.ambient_occlusion
                        and s.ao_distance > 0.0 and (s.ao_pass or has_indirect(frame)))
        if has_indirect(frame):
            s = frame.scene.settings
            drawn = probes.indirect_set(frame.scene.probes, s.normalization, s.prefilter,
                                        s.env_brdf, s.volume_extrapolation,
                                        s.volume_visibility, s.nearest_reflections)
            block, texels = lightmaps.upload(frame.lightmaps or [])
            self.indirect = ([(member.partition("[")[0], gpu.types.GPUUniformBuf(raw))
                              for _, member, raw in drawn.blocks()]
                             + [("lightmaps", gpu.types.GPUUniformBuf(block))],
                             [(name, texture) for _, name, texture in drawn.samplers()]
                             + [("lightmap_texels", texels)])
        sky = frame.sky if self.indirect is not None else None
        self._peeling = None  # (size, textures and framebuffers) of the layers peeled
        self.dummy = gpu.types.GPUTexture((1, 1), format="RGBA32F")
        # the shadow maps of the frame before, when this one has the same (a material tweak)
        key = (id(frame.positions), id(frame.casts), sky is not None,
               tuple(id(m) for m in frame.shadow_maps))
        with _kept_lock:
            last = _kept_shadows[0] if _kept_shadows else None
        kept = last[1] if last is not None and last[0] == key else None
        # the lights' draws; the dome's map numbers in the first draw's ShadowData
        self.batches, sets, self.dome = _light_batches(frame, sky, kept)
        # kept with what the key names, so that no id is another object's while kept
        with _kept_lock:
            _kept_shadows[:] = [(key, sets, (frame.positions, frame.casts,
                                             list(frame.shadow_maps)))]
        self.shares = None  # per share of the shutter: (its light batches, eye, forward)
        self.moving = 0  # triangles that move over the shutter
        self.share_textures = None  # (each triangle's motion row, the shares' corners)
        if frame.at_times is not None:
            self._upload_shares(frame)

    def _upload_shares(self, frame: Frame) -> None:
        """The frame at each share of the shutter (``Frame.at_times``): the moving triangles'
        corners and normals there (read by ``frame_vert.glsl`` when FrameData.options.z names
        the share), the camera there and the light batches of its shadow maps (the frame's
        own where its maps are the same)."""
        moving = (np.flatnonzero(frame.motion_row >= 0) if frame.motion_row is not None
                  else np.zeros(0, np.int64))
        self.moving = len(moving)
        corners = np.zeros((len(frame.at_times), len(moving), 3, 2, 4), np.float32)
        self.shares = []
        for g, moved in enumerate(frame.at_times):
            corners[g, :, :, 0, :3] = moved.positions[moving]
            corners[g, :, :, 1, :3] = moved.normals[moving]
            batches = self.batches
            if moved.shadow_maps is not frame.shadow_maps:
                sky = moved.sky if self.indirect is not None else None
                batches = _light_batches(moved, sky, like=(frame, self.batches))[0]
            cam = moved.scene.camera
            self.shares.append((batches, cam.position, cam.forward))
        rows = (np.full(len(frame.positions), -1.0) if frame.motion_row is None
                else frame.motion_row)
        self.share_textures = (textures.rows(np.asarray(rows, np.float32)[:, None]),
                               textures.rows(corners.reshape(-1, 4)))

    def _sample_groups(self, count: int, first_sample: int):
        """How ``count`` samples from number ``first_sample`` are shaded, as
        ``pipeline.render_tile`` does: (the batches of sample indices whose shading is reused
        within each, (count,) each sample's share of the shutter or -1, whether each is
        shaded on its own). Where shadows move, a batch per share; under a moving camera every
        sample on its own."""
        every = self.frame.scene.settings.shade_every_sample
        if self.shares is None or not self.frame.motion_reach:
            return [list(range(count))], np.full(count, -1), every
        times = motion_blur.shutter_times(first_sample + np.arange(count),
                                          self.frame.scene.settings.shutter_curve)
        share_of = motion_blur.shares(times, len(self.shares))
        every = every or self.frame.scene.camera.motion is not None
        if not self.frame.shadows_move:
            return [list(range(count))], share_of, every
        return ([list(np.flatnonzero(share_of == g)) for g in range(len(self.shares))
                 if (share_of == g).any()], share_of, every)

    def _bind_shares(self, program) -> None:
        """The shares' textures (``_upload_shares``) for a program reading the triangles'
        motion."""
        rows, corners = self.share_textures or (self.dummy, self.dummy)
        program.uniform_sampler("share_rows", rows)
        program.uniform_sampler("share_corners", corners)

    def draw(self, camera, offsets, targets: Targets, first_sample: int = 0) -> None:
        """Add the samples at ``offsets`` ((S, 2) positions in the pixel, top-left origin;
        the first being sample ``first_sample`` of the whole) of the frame through ``camera``
        (``core.scene.Camera`` of the targets' size) to ``targets``, shaded once per pixel and
        triangle within these samples (``pipeline.render_tile``; every sample on its own with
        the setting ``shade_every_sample``). With motion blur, each sample is shaded at its
        share of the shutter (``_sample_groups``: a batch per share where shadows move)."""
        import gpu

        scene = self.frame.scene
        settings = scene.settings
        view_proj = np.asarray(camera.projection @ camera.world_to_camera, np.float64)
        c2w = np.linalg.inv(np.asarray(camera.world_to_camera, np.float64))
        w, h = camera.width, camera.height
        base = {"view_proj": view_proj, "clip_to_world": np.linalg.inv(view_proj),
                "eye": c2w[:3, 3], "ortho": int(camera.orthographic),
                "world_to_camera": camera.world_to_camera, "ndc_scale": (1.0, 1.0),
                "forward": -c2w[:3, 2] / np.linalg.norm(c2w[:3, 2]),
                "world": np.append(np.asarray(scene.world.color, np.float32), 1.0),
                "flags": [int(settings.specular_occlusion), 0, int(settings.layered_diffuse),
                          int(settings.film_transparent)],
                "options": [0, int(settings.shadow_catcher_pass), 0, 0]}
        from ..core.kernels import shading as shading_kernel

        model = shading_kernel.MODELS[settings.specular_model]
        lit = bool(set(targets.names) & LIT)
        ambient = self.ambient and lit and self._ambient(camera, targets, base)
        shade = shader("shade", targets.names, self.indirect is not None, self.ambient,
                       self.dome is not None, self.mat, self.motion, self.blended)
        background = shader("background", targets.names, self.world is not None,
                            blended=self.blended)
        catcher_pass = int(settings.shadow_catcher_pass)
        world_block = self.world and gpu.types.GPUUniformBuf(self._world_block(camera))
        blocks = []  # uniform buffers stay alive until drawn
        saved = gpu.state.depth_test_get(), gpu.state.depth_mask_get(), gpu.state.blend_get()
        offsets = np.asarray(offsets, np.float64).reshape(-1, 2)
        groups, share_of, every = self._sample_groups(len(offsets), first_sample)
        for group in groups:  # a batch of samples each: their shading reused within it
            targets.clear_batch()
            for j, k in enumerate(group):
                ox, oy = offsets[k]
                mode = ("MODE_EVERY" if every else "MODE_FIRST" if j == 0 else "MODE_REST")
                g = int(share_of[k])  # its share of the shutter, -1: the frame's own time
                moves = [0, 0] if g < 0 else [g + 1, self.moving]  # FrameData.options.zw
                share = {} if g < 0 else {"eye": self.shares[g][1],
                                          "forward": self.shares[g][2],
                                          "options": [0, catcher_pass, *moves]}
                batches = self.batches if g < 0 else self.shares[g][0]
                sky = self.dome is not None and lit and self._dome(camera, targets, base, g)
                jitter = ((0.5 - ox) * 2.0 / w, -(0.5 - oy) * 2.0 / h)
                lens = _lens(camera, first_sample + k, self.shutter)  # its lens point and time

                def block(count, first_batch, mode=mode, jitter=jitter, k=k, offset=(ox, oy),
                          lens=lens, share=share, **extra):
                    blocks.append(gpu.types.GPUUniformBuf(FRAME.pack([{
                        **base, **share, **lens, "jitter": jitter, "sample_offset": offset,
                        "counts": [count, model, int(first_batch), MODES[mode]],
                        "size": [w, h, first_sample + k, 0], **extra}])))
                    return blocks[-1]

                if "clip_to_world" in lens and self.world is not None:  # through the lens point
                    world_block = gpu.types.GPUUniformBuf(self._world_block(camera, lens))
                    blocks.append(world_block)

                def shade_into(fb, visible, stack=None, mode=mode, block=block,
                               batches=batches, sky=sky):
                    """The visible points (or ``stack``'s layer: options) shaded into ``fb``."""
                    with fb.bind():  # only that triangle shades (not another at the same depth)
                        gpu.state.depth_mask_set(False)
                        gpu.state.blend_set("ADDITIVE_PREMULT")
                        gpu.state.depth_test_set("ALWAYS" if self.frame.dithers.any() or stack
                                                 else "EQUAL")
                        shade.bind()
                        self._bind_materials(shade)
                        shade.uniform_sampler("first_key", targets.dummy if mode == "MODE_FIRST"
                                              else targets.textures["first_key"])
                        shade.uniform_sampler("visible", visible)
                        self._bind_stacks(shade)
                        if ambient:
                            shade.uniform_block("ao", ambient[0])
                            shade.uniform_sampler("ambient", ambient[1])
                        if sky:
                            shade.uniform_block("dome", sky[0])
                            for name, texture in zip(DOME_TEXTURES, sky[1], strict=True):
                                shade.uniform_sampler(name, texture)
                        if lit and self.indirect is not None:
                            for name, buffer in self.indirect[0]:
                                shade.uniform_block(name, buffer)
                            for name, texture in self.indirect[1]:
                                shade.uniform_sampler(name, texture)
                        if self.motion:
                            self._bind_shares(shade)
                        for b, batch in enumerate(batches if lit else batches[:1]):
                            shade.uniform_block("frame", block(batch.count, b == 0, mode=mode,
                                                               **(stack or {})))
                            if lit:
                                shade.uniform_block("lights", batch.light_block)
                                shade.uniform_block("shadows", batch.shadow_block)
                                for _, name, texture in batch.shadows.samplers():
                                    shade.uniform_sampler(name, texture)
                            self.batch.draw(shade)

                def world_into(visible, stack=None, block=block, world_block=world_block):
                    """The world where no surface is seen (or behind ``stack``'s layers)."""
                    with targets.rest.bind():  # a miss adds the world in every sample
                        gpu.state.depth_test_set("ALWAYS")  # where no surface is (visible)
                        gpu.state.blend_set("ADDITIVE_PREMULT")
                        background.bind()
                        background.uniform_block("frame", block(0, True, **(stack or {})))
                        background.uniform_sampler("visible", visible)
                        self._bind_stacks(background)
                        if self.world is not None:
                            background.uniform_block("world", world_block)
                            background.uniform_block("images", self.world[0])
                            background.uniform_sampler("world_texels", self.world[1])
                            background.uniform_sampler("srgb_table", self.world[2])
                        self.background.draw(background)

                visible = targets.textures["visible"]
                def unshared(**extra):  # (the raster is the sample's own time's)
                    return block(0, True, share={}, **extra)

                self._visible(targets.prepass, visible, unshared, first_sample + k)
                shade_into(targets.first if mode == "MODE_FIRST" else targets.rest, visible)
                world = not settings.film_transparent or "catcher" in targets.names
                if world:
                    world_into(visible)
                if self.blended:  # each layer of the stacks on its own, weighted by its share
                    behind, layers = self._stack(visible, unshared, first_sample + k)
                    for slot in [*range(layers), BLEND_LAYERS] if layers else []:
                        stack = {"options": [slot + 1, catcher_pass, *moves]}
                        shade_into(targets.rest, behind, stack, "MODE_EVERY")
                    if world and layers:
                        world_into(behind, {"options": [BLEND_LAYERS + 1, catcher_pass,
                                                        *moves]})
            targets.compose(self.background, len(group))
        gpu.state.depth_test_set(saved[0])
        gpu.state.depth_mask_set(saved[1])
        gpu.state.blend_set(saved[2])


    def central(self, camera, offsets) -> dict[str, np.ndarray]:
        """Depth and IndexMA through ``camera`` at the sample of ``offsets`` nearest the
        pixel centre (its surfaces dithered as that sample's): {name: (H, W, 1) float32},
        row 0 at the top; 1e10 and 0 where no surface is seen (``passes.EMPTY_DEPTH``)."""
        import gpu

        offsets = np.asarray(offsets, np.float64).reshape(-1, 2)
        k = int(np.argmin(np.abs(offsets - 0.5).sum(-1)))
        w, h = camera.width, camera.height
        record = _view_record(camera, offsets[k], k, self.shutter)
        blocks = []

        def block(**extra):
            blocks.append(gpu.types.GPUUniformBuf(FRAME.pack([{**record, **extra}])))
            return blocks[-1]

        target, visible = (gpu.types.GPUTexture((w, h), format="RGBA32F") for _ in range(2))
        z = gpu.types.GPUTexture((w, h), format="DEPTH_COMPONENT32F")
        prepass = gpu.types.GPUFrameBuffer(depth_slot=z, color_slots=(visible,))
        fb = gpu.types.GPUFrameBuffer(depth_slot=z, color_slots=(target,))
        program = shader("central", motion=self.motion)
        saved = gpu.state.depth_test_get(), gpu.state.depth_mask_get(), gpu.state.blend_get()
        self._visible(prepass, visible, block, k)
        with fb.bind():
            fb.clear(color=(float(EMPTY_DEPTH), 0.0, 0.0, 0.0))
            gpu.state.depth_test_set("ALWAYS")
            gpu.state.depth_mask_set(False)
            gpu.state.blend_set("NONE")
            program.bind()
            # Depth: the view-axis distance in the camera of the sample's time
            program.uniform_block("frame", block() if "shutter" not in record else block(
                world_to_camera=motion_blur.view_at(camera, record["shutter"][0])))
            program.uniform_sampler("materials", self.materials)
            program.uniform_sampler("visible", visible)
            self.batch.draw(program)
        gpu.state.depth_test_set(saved[0])
        gpu.state.depth_mask_set(saved[1])
        gpu.state.blend_set(saved[2])
        image = textures.read(target)[::-1]
        return {"Depth": np.ascontiguousarray(image[..., :1]),
                "IndexMA": np.ascontiguousarray(image[..., 1:2])}

    def aovs(self, camera, offsets, first_sample: int = 0) -> dict[str, np.ndarray]:
        """The shader AOVs of the settings through ``camera``, averaged over the samples of
        ``offsets`` (their surfaces dithered as theirs): {name: (H, W, 4) colour, or (H, W, 1)
        value, float32}, row 0 at the top (``pipeline.render_tile``'s AOV columns)."""
        import gpu

        wanted = self.frame.scene.settings.aovs
        offsets = np.asarray(offsets, np.float64).reshape(-1, 2)
        w, h = camera.width, camera.height
        out = {name: np.zeros((h, w, 4 if kind == "COLOR" else 1), np.float32)
               for name, kind in wanted}
        if self.mat is None:  # no material writes any
            return out
        sums = [gpu.types.GPUTexture((w, h), format="RGBA32F") for _ in wanted]
        fbs = [gpu.types.GPUFrameBuffer(color_slots=(t,)) for t in sums]
        for fb in fbs:
            with fb.bind():
                fb.clear(color=(0.0, 0.0, 0.0, 0.0))
        program = shader("aov", mat=self.mat, motion=self.motion, blended=self.blended)
        saved = gpu.state.depth_test_get(), gpu.state.depth_mask_get(), gpu.state.blend_get()
        share_of = self._sample_groups(len(offsets), first_sample)[1]
        for block, visible, sample in self._each_visible(camera, offsets, first_sample):
            g = int(share_of[sample - first_sample])  # shaded at its share of the shutter
            moves, share = [0, 0], {}
            if g >= 0:
                moves = [g + 1, self.moving]
                share = {"forward": self.shares[g][2]}
                if camera.aperture is None or camera.orthographic:  # (else the lens point)
                    share["eye"] = self.shares[g][1]
            draws = [(visible, 0)]  # (the surfaces, the blended stacks' layer drawn + 1)
            if self.blended:
                behind, layers = self._stack(visible, block, sample)
                draws += [(behind, slot + 1) for slot in [*range(layers), BLEND_LAYERS] if layers]
            for j, fb in enumerate(fbs):
                for seen, layer in draws:
                    with fb.bind():
                        gpu.state.depth_test_set("ALWAYS")
                        gpu.state.depth_mask_set(False)
                        gpu.state.blend_set("ADDITIVE_PREMULT")
                        program.bind()
                        program.uniform_block("frame", block(counts=[j, 0, 0, 0],
                                                             options=[layer, 0, *moves],
                                                             **share))
                        self._bind_materials(program)
                        if self.motion:
                            self._bind_shares(program)
                        self._bind_stacks(program)
                        program.uniform_sampler("visible", seen)
                        self.batch.draw(program)
        gpu.state.depth_test_set(saved[0])
        gpu.state.depth_mask_set(saved[1])
        gpu.state.blend_set(saved[2])
        for (name, _), texture in zip(wanted, sums, strict=True):
            image = textures.read(texture)[::-1] / np.float32(len(offsets))
            out[name] = np.ascontiguousarray(image[..., :out[name].shape[-1]], np.float32)
        return out

    def _each_visible(self, camera, offsets, first_sample: int):
        """Per sample of ``offsets`` through ``camera``: (its FrameData maker ``block(**extra)``,
        the texture of its visible surfaces, drawn by ``_visible``, one texture for all; its
        number)."""
        import gpu

        w, h = camera.width, camera.height
        visible = gpu.types.GPUTexture((w, h), format="RGBA32F")
        z = gpu.types.GPUTexture((w, h), format="DEPTH_COMPONENT32F")
        prepass = gpu.types.GPUFrameBuffer(depth_slot=z, color_slots=(visible,))
        for k, offset in enumerate(np.asarray(offsets, np.float64).reshape(-1, 2)):
            record = _view_record(camera, offset, first_sample + k, self.shutter)
            blocks = []  # the uniform buffers live until the sample is drawn

            def block(record=record, blocks=blocks, **extra):
                blocks.append(gpu.types.GPUUniformBuf(FRAME.pack([{**record, **extra}])))
                return blocks[-1]

            self._visible(prepass, visible, block, first_sample + k)
            yield block, visible, first_sample + k

    def seen(self, camera, offsets, first_sample: int = 0) -> list[np.ndarray]:
        """The triangle each sample of ``offsets`` sees through ``camera`` (its surfaces
        dithered as that sample's; holdouts count as none): S arrays (H W,) int32 in row-major
        order from the top row, -1 where none (``pipeline.render_tile``'s ``seen_by``)."""
        import gpu

        saved = gpu.state.depth_test_get(), gpu.state.depth_mask_get(), gpu.state.blend_get()
        out = []
        for _, visible, _ in self._each_visible(camera, offsets, first_sample):
            key = textures.read(visible)[::-1].reshape(-1, 4)
            tri = key[:, 0].astype(np.int32) * 4096 + key[:, 1].astype(np.int32) - 1
            tri[(tri >= 0) & self.frame.holdout[np.maximum(tri, 0)]] = -1
            out.append(tri)
        gpu.state.depth_test_set(saved[0])
        gpu.state.depth_mask_set(saved[1])
        gpu.state.blend_set(saved[2])
        return out

    def _bind_materials(self, program) -> None:
        """The material table and the material programs' images and object rows."""
        program.uniform_sampler("materials", self.materials)
        if self.mat_resources is not None:
            program.uniform_block("images", self.mat_resources[0])
            for name, texture in self.mat_resources[1]:
                program.uniform_sampler(name, texture)

    def _visible(self, fb, visible, block, sample: int) -> None:
        """Each pixel's surface at one sample into ``visible`` (``fb``: it and a depth
        buffer): the depth pre-pass; with surfaces that may be transparent, then the layers
        peeled where their alpha does not exceed the sample's threshold
        (``core.render.transparency.dither``). block(**fields): the sample's FrameData."""
        import gpu

        depth = shader("depth", motion=self.motion)
        gpu.state.blend_set("NONE")
        with fb.bind():  # the nearest triangle of each pixel, and its depth
            fb.clear(color=(0.0, 0.0, 0.0, 0.0), depth=1.0)
            gpu.state.depth_mask_set(True)
            gpu.state.depth_test_set("LESS")
            depth.bind()
            depth.uniform_block("frame", block())
            depth.uniform_sampler("peel_floor", self.dummy)  # (not read)
            self.batch.draw(depth)
        if not self.frame.dithers.any():
            return
        w, h = visible.width, visible.height
        if self._peeling is None or self._peeling[0] != (w, h):
            floors = [gpu.types.GPUTexture((w, h), format="RGBA32F") for _ in range(2)]
            self._peeling = ((w, h), [(f, gpu.types.GPUFrameBuffer(color_slots=(f,)))
                                      for f in floors])
        _, floors = self._peeling
        peel, merge = shader("peel", mat=self.mat, motion=self.motion), shader("merge")
        for layer in range(DITHER_LAYERS):
            floor, floor_fb = floors[layer % 2]
            with floor_fb.bind():  # the pixels whose surface lets the sample through
                floor_fb.clear(color=(0.0, 0.0, 0.0, 0.0))
                gpu.state.depth_test_set("NONE")
                gpu.state.depth_mask_set(False)
                peel.bind()
                peel.uniform_block("frame", block(counts=[layer, 0, 0, 0]))
                self._bind_materials(peel)
                peel.uniform_sampler("visible", visible)
                peel.uniform_sampler("peel_prev", floors[(layer + 1) % 2][0] if layer
                                     else self.dummy)
                self.batch.draw(peel)
            after = self._behind(floor, block)
            with fb.bind():
                gpu.state.depth_test_set("NONE")
                gpu.state.depth_mask_set(False)
                merge.bind()
                merge.uniform_sampler("peel_floor", floor)
                merge.uniform_sampler("next_visible", after)
                self.background.draw(merge)

    def _behind(self, floor, block):
        """The nearest surface behind the peeled pixels of ``floor`` (``glsl/depth_frag.glsl``
        peeling; ``peel_frag.glsl``'s floor) into a texture of its size, returned (the same
        texture every call). block(**fields): the sample's FrameData."""
        import gpu

        w, h = floor.width, floor.height
        if self._after is None or self._after[0] != (w, h):
            after = gpu.types.GPUTexture((w, h), format="RGBA32F")
            z = gpu.types.GPUTexture((w, h), format="DEPTH_COMPONENT32F")
            # (the depth texture is kept: a texture freed leaves the framebuffers it was in)
            self._after = ((w, h), after, gpu.types.GPUFrameBuffer(depth_slot=z,
                                                                   color_slots=(after,)), z)
        _, after, fb, _ = self._after
        depth = shader("depth", motion=self.motion)
        with fb.bind():
            gpu.state.depth_test_set("LESS")
            gpu.state.depth_mask_set(True)
            fb.clear(color=(0.0, 0.0, 0.0, 0.0), depth=1.0)
            depth.bind()
            depth.uniform_block("frame", block(flags=[
                int(self.frame.scene.settings.specular_occlusion), 1, 0, 0]))
            depth.uniform_sampler("peel_floor", floor)
            self.batch.draw(depth)
        return after

    def _stack(self, visible, block, sample: int):
        """The blended stacks of one sample (``core.render.transparency.blend``) behind the
        pixels of ``visible`` whose surface is blended: a step per layer, front to back
        (``glsl/stack_frag.glsl``, a depth peel, ``glsl/stack_merge_frag.glsl``), until no
        stack goes on or after ``PEELS`` steps; their layers kept for ``_bind_stacks``, the
        pixels cut or out of peels added to ``cut``. block(**fields): the sample's
        FrameData. Returns (the texture of the surface behind each stack, the most layers
        a stack holds)."""
        import gpu

        w, h = visible.width, visible.height
        if self._stacks is None or self._stacks[0] != (w, h):
            def texture():
                return gpu.types.GPUTexture((w, h), format="RGBA32F")

            sets = []  # (visible, state, layers, their framebuffer), one written per step
            for _ in range(2):
                made = (texture(), texture(), tuple(texture() for _ in range(STACK_SLOTS)))
                sets.append((*made, gpu.types.GPUFrameBuffer(color_slots=(
                    made[0], made[1], *made[2]))))
            floor, record = texture(), texture()
            self._stacks = ((w, h), sets, floor, record, gpu.types.GPUFrameBuffer(
                color_slots=(floor, record)))
        _, sets, floor, record, step_fb = self._stacks
        with sets[0][3].bind():
            sets[0][3].clear(color=(0.0, 0.0, 0.0, 0.0))
        step_program = shader("stack", mat=self.mat, motion=self.motion)
        merge = shader("stack_merge")
        gpu.state.blend_set("NONE")
        prev = (visible, *sets[0][1:3])
        # a step takes, peels or ends at one triangle: the fading ones and one more suffice
        steps = min(PEELS, int(self.frame.fades.sum()) + 1)
        for step in range(steps):
            with step_fb.bind():  # what each stack's surface is: a layer, peeled or its end
                step_fb.clear(color=(0.0, 0.0, 0.0, 0.0))
                gpu.state.depth_test_set("NONE")
                gpu.state.depth_mask_set(False)
                step_program.bind()
                step_program.uniform_block("frame", block(counts=[step, 0, 0, 0]))
                self._bind_materials(step_program)
                step_program.uniform_sampler("visible", prev[0])
                self._bind_stacks(step_program, prev[1:])
                self.batch.draw(step_program)
            after = self._behind(floor, block)  # where the stack goes on
            out = sets[(step + 1) % 2]
            with out[3].bind():
                gpu.state.depth_test_set("NONE")
                gpu.state.depth_mask_set(False)
                merge.bind()
                merge.uniform_block("frame", block(counts=[step, 0, 0, 0]))
                merge.uniform_sampler("visible", prev[0])
                merge.uniform_sampler("stack_state", prev[1])
                for k, texture in enumerate(prev[2]):
                    merge.uniform_sampler(f"stack_slots{k}", texture)
                merge.uniform_sampler("stack_record", record)
                merge.uniform_sampler("peel_floor", floor)
                merge.uniform_sampler("next_visible", after)
                self.background.draw(merge)
            prev = out[:3]
            if step + 1 < steps and (step + 1) & step == 0:  # after steps 1, 2, 4 ...: any left?
                if not (textures.read(prev[1])[..., 1] > 0.0).any():
                    break
        state = textures.read(prev[1])
        self.cut += int((state[..., 1] + state[..., 2]).sum())
        self._stack_state = prev[1:]
        return prev[0], int(state[..., 0].max())

    def _bind_stacks(self, program, state=None) -> None:
        """The blended stacks' textures (``glsl/stack.glsl``): ``state`` (the state's
        texture, the layers'), else the last sample's (``_stack``)."""
        if not self.blended:
            return
        state = state or self._stack_state or (self.dummy, (self.dummy,) * STACK_SLOTS)
        program.uniform_sampler("stack_state", state[0])
        for k, texture in enumerate(state[1]):
            program.uniform_sampler(f"stack_slots{k}", texture)
        program.uniform_sampler("stack_order", self.stack_order)

    def _world_block(self, camera, lens: dict | None = None) -> bytes:
        """The WorldData of the frame's image world seen through ``camera`` (from a lens
        point: ``_lens``)."""
        import math

        world = self.frame.scene.world
        view_proj = np.asarray(camera.projection, np.float64) @ np.asarray(
            camera.world_to_camera, np.float64)
        record = {"clip_to_world": lens["clip_to_world"] if lens else np.linalg.inv(view_proj),
                  "rotation": np.asarray(world.rotation, np.float64),
                  "params": [world.strength, world.background_alpha,
                             world.background_lod or -1.0, float(world.sun is not None)]}
        sun = world.sun
        if sun is not None:
            half = max(float(sun.radius), 1e-4) / 2.0
            solid = 2.0 * math.pi * (1.0 - math.cos(half))
            record["sun"] = [*(-np.asarray(sun.direction, np.float64)), math.cos(half)]
            record["sun_color"] = np.asarray(sun.color, np.float32) / np.float32(solid)
        return WORLD.pack([record])

    def _dome(self, camera, targets: Targets, base: dict, share: int = -1):
        """(the DomeData block, its grid's textures) through ``camera``: the dome's visibility
        at the anchor pixels of ``sky.upsampled``, made once per camera, targets and share of
        the shutter (-1: the frame's own time; else its geometry and dome there)."""
        import gpu

        kept = targets.kept.get(("dome", share))
        if kept is not None and kept[0] is camera:
            return kept[1]
        if share >= 0:
            base = {**base, "options": [0, 0, share + 1, self.moving]}
        _, _, gw, gh = dome.grid(camera)
        scale, shift = dome.grid_projection(camera)
        grid_textures = [gpu.types.GPUTexture((gw, gh), format="RGBA32F") for _ in range(3)]
        z = gpu.types.GPUTexture((gw, gh), format="DEPTH_COMPONENT32F")
        fb = gpu.types.GPUFrameBuffer(depth_slot=z, color_slots=tuple(grid_textures))
        seen = self.frame if share < 0 else self.frame.at_times[share]
        data = gpu.types.GPUUniformBuf(dome.block(seen, self.dome, camera))
        frame_data = gpu.types.GPUUniformBuf(FRAME.pack([{
            **base, "jitter": shift, "ndc_scale": scale}]))
        batch = (self.batches if share < 0 else self.shares[share][0])[0]
        depth = shader("depth", motion=self.motion)
        program = shader("dome_grid", motion=self.motion)
        saved = (gpu.state.depth_test_get(), gpu.state.depth_mask_get(),
                 gpu.state.blend_get())
        with fb.bind():
            fb.clear(color=(0.0, 0.0, 0.0, 0.0), depth=1.0)
            gpu.state.blend_set("NONE")
            gpu.state.depth_test_set("LESS")
            gpu.state.depth_mask_set(True)
            gpu.state.color_mask_set(False, False, False, False)
            depth.bind()
            depth.uniform_block("frame", frame_data)
            depth.uniform_sampler("peel_floor", self.dummy)  # (not read)
            if self.motion:
                self._bind_shares(depth)
            self.batch.draw(depth)
            gpu.state.color_mask_set(True, True, True, True)
            gpu.state.depth_mask_set(False)
            gpu.state.depth_test_set("EQUAL")
            program.bind()
            program.uniform_block("frame", frame_data)
            program.uniform_block("shadows", batch.shadow_block)
            program.uniform_block("dome", data)
            program.uniform_sampler("materials", self.materials)
            for _, name, texture in batch.shadows.samplers():
                program.uniform_sampler(name, texture)
            if self.motion:
                self._bind_shares(program)
            self.batch.draw(program)
        gpu.state.depth_test_set(saved[0])
        gpu.state.depth_mask_set(saved[1])
        gpu.state.blend_set(saved[2])
        result = (data, grid_textures)
        targets.kept[("dome", share)] = (camera, result)
        return result

    def _ambient(self, camera, targets: Targets, base: dict):
        """(the AOData block, the frame's ambient occlusion texture) through ``camera``, made
        once per camera and targets (``occlusion.ambient``)."""
        import gpu

        kept = targets.kept.get("ambient")
        if kept is not None and kept[0] is camera:
            return kept[1]
        m = occlusion_formulas.REACH
        w, h = camera.width, camera.height
        size = (w + 2 * m, h + 2 * m)
        depth_tex, normal_tex, z = (gpu.types.GPUTexture(size, format=f) for f in
                                    ("RGBA32F", "RGBA32F", "DEPTH_COMPONENT32F"))
        fb = gpu.types.GPUFrameBuffer(depth_slot=z, color_slots=(depth_tex, normal_tex))
        program = shader("center", motion=self.motion)
        data = gpu.types.GPUUniformBuf(FRAME.pack([{
            **base, "jitter": (0.0, 0.0), "ndc_scale": (w / size[0], h / size[1])}]))
        saved = gpu.state.depth_test_get(), gpu.state.depth_mask_get(), gpu.state.blend_get()
        with fb.bind():
            fb.clear(color=(0.0, 0.0, 0.0, 0.0), depth=1.0)
            gpu.state.depth_test_set("LESS")
            gpu.state.depth_mask_set(True)
            gpu.state.blend_set("NONE")
            program.bind()
            program.uniform_block("frame", data)
            self.batch.draw(program)
        gpu.state.depth_test_set(saved[0])
        gpu.state.depth_mask_set(saved[1])
        gpu.state.blend_set(saved[2])
        texture = occlusion.ambient(depth_tex, normal_tex, camera,
                                    self.frame.scene.settings.ao_distance, self.background)
        result = (gpu.types.GPUUniformBuf(occlusion.block(camera, 0.0)), texture)
        targets.kept["ambient"] = (camera, result)
        return result


class Targets:
    """Float32 targets of one size: a batch's first sample (its key: the triangle of each
    pixel) and later samples (their key: how many reuse the first's shading), and the running
    total every batch is composed into; ``names``: the ``TARGETS`` drawn (a group of
    ``GROUPS`` or fewer: the viewport draws Combined alone)."""

    def __init__(self, width: int, height: int, names: tuple[str, ...] = GROUPS[0]):
        import gpu

        self.width, self.height, self.names = width, height, tuple(names)

        def texture():
            return gpu.types.GPUTexture((width, height), format="RGBA32F")

        self.textures = {f"{part}_{name}": texture() for part in ("first", "rest", "total")
                         for name in ("key", *self.names) if f"{part}_{name}" != "total_key"}
        self.textures["visible"] = texture()
        self.depth = gpu.types.GPUTexture((width, height), format="DEPTH_COMPONENT32F")
        self.dummy = gpu.types.GPUTexture((1, 1), format="RGBA32F")
        self.first, self.rest = (gpu.types.GPUFrameBuffer(depth_slot=self.depth, color_slots=tuple(
            self.textures[f"{part}_{name}"] for name in ("key", *self.names)))
            for part in ("first", "rest"))
        self.prepass = gpu.types.GPUFrameBuffer(depth_slot=self.depth,
                                                color_slots=(self.textures["visible"],))
        self.total = gpu.types.GPUFrameBuffer(color_slots=tuple(
            self.textures[f"total_{name}"] for name in self.names))
        self.samples = 0
        self.kept = {}  # what depends on the camera alone (the ambient occlusion)
        self.clear()

    def clear(self) -> None:
        """Forget every sample."""
        with self.total.bind():
            self.total.clear(color=(0.0, 0.0, 0.0, 0.0))
        self.samples = 0

    def clear_batch(self) -> None:
        for fb in (self.first, self.rest):
            with fb.bind():
                fb.clear(color=(0.0, 0.0, 0.0, 0.0), depth=1.0)

    def compose(self, triangle, count: int) -> None:
        """Add the batch of ``count`` samples to the total (``glsl/compose_frag.glsl``)."""
        import gpu

        program = shader("compose", self.names)
        with self.total.bind():
            gpu.state.depth_test_set("NONE")
            gpu.state.blend_set("ADDITIVE_PREMULT")
            program.bind()
            for name, texture in self.textures.items():
                if name.startswith(("first", "rest")):
                    program.uniform_sampler(name, texture)
            triangle.draw(program)
        self.samples += count

    def combined(self):
        """The running total of Combined (divide by ``samples``): a GPU texture."""
        return self.textures["total_combined"]

    def passes(self, names=None) -> dict[str, np.ndarray]:
        """{pass name: (H, W, C) float32} averaged over the samples, row 0 at the top."""
        out, read = {}, {}
        scale = np.float32(1.0 / max(1, self.samples))
        for name in names or [p for p, (t, _) in PASS_OF.items() if t in self.names]:
            target, channels = PASS_OF[name]
            if target not in read:
                read[target] = textures.read(self.textures[f"total_{target}"])[::-1] * scale
            out[name] = np.ascontiguousarray(read[target][..., channels])
        return out


def _group_frame(frame: Frame, group: str) -> tuple[Frame, np.ndarray]:
    """``frame`` lit by light group ``group`` alone (``core.render.passes.group_pass``): its
    lights, and the world's light, the probes' and the background when the world is in it;
    and (T,) bool the triangles whose emission is another group's (or none's)."""
    scene = frame.scene
    mine = [k for k, light in enumerate(scene.lights) if light.group == group]
    world = scene.world.group == group
    sub = dataclasses.replace(
        scene, lights=[scene.lights[k] for k in mine], probes=scene.probes if world else None,
        world=scene.world if world else dataclasses.replace(
            scene.world, color=np.zeros(3, np.float32), texture=None, sun=None),
        settings=dataclasses.replace(scene.settings, light_groups=(), cryptomatte=(),
                                     aovs=()))
    maps = [frame.shadow_maps[k] for k in mine] + (
        list(frame.shadow_maps[len(scene.lights):]) if world else [])
    index = scene.settings.light_groups.index(group)
    dark = np.ones(len(frame.positions), bool) if frame.group is None else frame.group != index
    return dataclasses.replace(frame, scene=sub, shadow_maps=maps, crypto=None,
                               group=None), dark


def _view_record(camera, offset, sample: int, shutter=None) -> dict:
    """The FrameData of sample number ``sample`` at ``offset`` (x, y in the pixel) through
    ``camera`` (from its lens point and at its time, ``_lens``), for the passes that draw no
    light."""
    w, h = camera.width, camera.height
    ox, oy = offset
    c2w = np.linalg.inv(np.asarray(camera.world_to_camera, np.float64))
    view_proj = np.asarray(camera.projection @ camera.world_to_camera, np.float64)
    record = {"view_proj": view_proj, "clip_to_world": np.linalg.inv(view_proj),
            "world_to_camera": camera.world_to_camera, "ndc_scale": (1.0, 1.0),
            "eye": c2w[:3, 3], "ortho": int(camera.orthographic),
            "forward": -c2w[:3, 2] / np.linalg.norm(c2w[:3, 2]),
            "jitter": ((0.5 - ox) * 2.0 / w, -(0.5 - oy) * 2.0 / h),
            "sample_offset": (ox, oy), "size": [w, h, sample, 0],
            **_lens(camera, sample, shutter)}
    return record


def _lens(camera, sample: int, shutter: tuple | None = None) -> dict:
    """The FrameData fields of sample number ``sample`` seen from its point of ``camera``'s
    aperture (``core.render.depth_of_field``): its view_proj, clip_to_world and eye; and at
    its time of the shutter (``core.render.motion_blur``; ``shutter``: the frame's shutter
    curve when anything moves, else None): its view_proj through the camera then, and the
    time (the shading keeps the frame's own view, as the CPU's); {} for a still pinhole."""
    lens = camera.aperture is not None and not camera.orthographic
    if not lens and shutter is None:
        return {}
    fields = {}
    proj = np.asarray(camera.projection, np.float64)
    view = np.asarray(camera.world_to_camera, np.float64)
    through = np.eye(4)
    if lens:
        point = depth_of_field.lens_points(camera.aperture, np.array([sample]))[0]
        through = depth_of_field.clip_transform(camera, point)
        fields["clip_to_world"] = np.linalg.inv(through @ proj @ view)
        fields["eye"] = depth_of_field.eye(camera, point)
    if shutter is not None:
        t = float(motion_blur.shutter_times(np.array([sample]), shutter)[0])
        view = motion_blur.view_at(camera, t)
        fields["shutter"] = (t, 1.0, 0.0, 0.0)
    fields["view_proj"] = through @ proj @ view
    return fields


def _triangle_normals(pos: np.ndarray):
    """(c1 - c0) x (c2 - c0) of triangles (T, 3, 3) (``kernels.shading.triangle_normal``)."""
    a, b = pos[:, 1] - pos[:, 0], pos[:, 2] - pos[:, 0]
    return (a[:, 1] * b[:, 2] - a[:, 2] * b[:, 1], a[:, 2] * b[:, 0] - a[:, 0] * b[:, 2],
            a[:, 0] * b[:, 1] - a[:, 1] * b[:, 0])


def _light_batches(frame: Frame, sky, kept=None, like=None):
    """The frame's lights in draws of ``BATCH_LIGHTS`` (``DOME_BATCH_LIGHTS`` in the first
    when the world's dome ``sky`` shares its block): ([_Batch], their shadow sets, the dome's
    map numbers in the first's ShadowData or None). ``kept``: the shadow sets of a frame with
    the same maps, used as they are; ``like``: (a frame, its batches) whose batch is taken
    where it holds the same maps (a share of the shutter whose casters there do not move)."""
    import gpu

    scene_lights = frame.scene.lights
    maps = frame.shadow_maps[:len(scene_lights)]
    sets = [] if kept is None else kept
    casters = {}  # the shadow casters by blocker set, for maps the GPU draws
    if kept is None and any(m is not None and m.on_gpu for m in frame.shadow_maps):
        from ..core.render.shadow_maps import casters as caster_set
        from .shadow_depths import Casters

        for k in {0} | {light.blockers for light in scene_lights}:
            casters[k] = Casters(caster_set(frame, k)[0])
    batches, dome_index, lo = [], None, 0
    while lo < max(1, len(scene_lights)):
        size = DOME_BATCH_LIGHTS if sky is not None and lo == 0 else BATCH_LIGHTS
        group = scene_lights[lo:lo + size]
        extra = list(sky.maps) if sky is not None and lo == 0 else []
        mine = list(maps[lo:lo + size]) + extra
        if like is not None:
            theirs = like[0].shadow_maps[:len(scene_lights)][lo:lo + size] + (
                list(like[0].sky.maps) if extra else [])
            if len(theirs) == len(mine) and all(a is b for a, b in zip(mine, theirs, strict=True)):
                batches.append(like[1][len(batches)])
                if extra:
                    dome_index = batches[-1].shadows.index[len(group):]
                lo += size
                continue
        if kept is None:
            shadow_set = lights.shadow_set(
                mine, jitter=[True] * len(group) + [False] * len(extra),
                casters=[casters.get(light.blockers) for light in group]
                + [casters.get(0)] * len(extra))
            sets.append(shadow_set)
        else:
            shadow_set = kept[len(batches)]
        if extra:
            dome_index = shadow_set.index[len(group):]
        batches.append(_Batch(
            len(group), gpu.types.GPUUniformBuf(_light_bytes(group, shadow_set)),
            shadow_set, gpu.types.GPUUniformBuf(
                _padded(shadow_set.block, lights.SHADOW, SHADOW_RECORDS))))
        lo += size
    return batches, sets, dome_index


def _light_bytes(group, shadow_set) -> bytes:
    return _padded(lights.light_block(group, shadow_set.index[:len(group)]) if group else b"",
                   lights.LIGHT, BATCH_LIGHTS)


def _padded(block: bytes, struct: Struct, count: int) -> bytes:
    """``block`` (whole structs) padded with zeros to ``count`` structs."""
    size = struct.layout()[1]
    return block[:count * size] + bytes(count * size - min(len(block), count * size))


def render(frame: Frame, offsets, passes=None, warn=None) -> dict[str, np.ndarray]:
    """The frame's passes through its own camera, drawn on the GPU: {name: (H, W, C)
    float32}, row 0 at the top (``pipeline.render_frame``'s layout); ``passes``: the names
    wanted (``PASS_OF``, ``CENTRAL``, the settings' Cryptomatte and light group passes;
    default all), Combined always. warn(text): told of cut blended stacks, as the CPU's
    render tells."""
    cam = frame.scene.camera
    wanted = set(PASS_OF) | set(CENTRAL) if passes is None else set(passes) | {"Combined"}
    try:
        drawn = GPUFrame(frame)
        out = {}
        drawn_targets = {PASS_OF[p][0] for p in wanted if p in PASS_OF}
        for group in GROUPS:
            names = tuple(name for name in group if name in drawn_targets)
            if not names:
                continue
            targets = Targets(cam.width, cam.height, names)
            drawn.draw(cam, offsets, targets)
            if drawn.cut and warn is not None:
                warn(cut_warning(drawn.cut))
                warn = None  # (once: every group draws the same stacks)
            out.update({p: image for p, image in targets.passes().items() if p in wanted})
        if wanted & set(CENTRAL):
            out.update(drawn.central(cam, offsets))
        # a light group's frame makes its own peeling buffers: these are let go
        drawn._stacks = drawn._stack_state = drawn._peeling = drawn._after = None
        for group in frame.scene.settings.light_groups:
            name = group_pass(group)
            if passes is None or name in passes:
                sub, dark = _group_frame(frame, group)
                targets = Targets(cam.width, cam.height, ("combined",))
                GPUFrame(sub, dark).draw(cam, offsets, targets)
                out[name] = np.ascontiguousarray(targets.passes()["Combined"][..., :3])
        if frame.scene.settings.aovs and (passes is None or any(
                name in passes for name, _ in frame.scene.settings.aovs)):
            out.update(drawn.aovs(cam, offsets))
        if frame.crypto and (passes is None or any(p.startswith("Crypto") for p in passes)):
            crypto = pipeline.crypto_passes(frame, drawn.seen(cam, offsets))
            out.update({name: ranks.reshape(cam.height, cam.width, 4)
                        for name, ranks in crypto.items()})
        return out
    finally:
        release()  # a final frame's maps and images are not drawn again
