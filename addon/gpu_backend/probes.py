"""The indirect light as the GPU's shaders read it (``glsl/indirect.glsl``): the probes' and the
world's uniform blocks (declared once here), the cube-map chains and the volumes' SH as row
textures, the environment BRDF's table."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..core.formulas import affine, cubemap, sh
from ..core.formulas import env_brdf as formulas_env_brdf
from ..core.lighting import probes as core_probes
from . import textures
from .uniforms import Struct

MAX_LEVELS = 16  # mip levels of a chain (a 32768 texel face has 16)
MAX_REFLECTIONS = 32  # reflection probes a frame's block holds (and the world's chain)
MAX_VOLUMES = 32  # irradiance volumes (and the bounce volume)
MAX_DEPTH_TEXELS = textures.ROW_WIDTH * 16384  # the volumes' depth moments (16384 rows, the
#                                                height every GL 4.3 context holds)
INDIRECT = Struct("IndirectData", (
    ("world_sh", "vec4", 9),  # the world's radiance SH, RGB
    ("band", "vec4", 3),  # sh.BAND_FACTORS (9)
    ("world_color", "vec4", 0),  # a world of one colour: RGB, 1; else 0
    ("counts", "ivec4", 0),  # (reflection probes, volumes, normalization, environment BRDF)
    ("flags", "ivec4", 0),  # (the bounce volume's index or -1, 1: visibility test,
    #                         1: the nearest probes where the world is hidden, -)
    ("limits", "vec4", 0),  # (eps, largest normalization ratio, smallest n.v of the BRDF,
    #                          1: volumes extrapolated to their boxes' faces)
    ("fit", "vec4", 3),  # env_brdf.FIT_A0 + FIT_A1 (10)
))
REFLECTION = Struct("ReflectionData", (
    ("position", "vec3", 0), ("radius", "float", 0),  # the capture's position; influence
    ("fade", "float", 0),  # falloff times radius
    ("counts", "ivec4", 0),  # (levels of its chain, parallax proxy kind, -, -)
    ("proxy", "vec4", 3),  # world -> proxy, 3 x 4 rows
    ("scalar", "vec4", 3), ("tint", "vec4", 0),  # the tinted scalar SH of its radiance
    ("dc_eps", "vec4", 0),  # its SH's constant term plus eps, RGB
    ("offsets", "ivec4", MAX_LEVELS // 4), ("sides", "ivec4", MAX_LEVELS // 4),
))
VOLUME = Struct("VolumeData", (
    ("to_local", "vec4", 3), ("to_world", "vec4", 3),  # 3 x 4 rows each
    ("res", "ivec4", 0),  # samples along x, y, z; its first row in volume_sh
    ("params", "vec4", 0),  # (influence, falloff, normal bias, view bias; metres)
    ("facing", "vec4", 0),  # (facing bias, facing on, validity on, -)
    ("visibility", "vec4", 0),  # (its first texel in volume_depth or -1, variance floor m^2,
    #                              the moments' face size, their clamp distance m)
))


# The blocks and samplers ``glsl/indirect.glsl`` reads, as a program declares them
BLOCKS = (("IndirectData", "indirect", None),
          ("ReflectionData", f"reflections[{MAX_REFLECTIONS + 1}]", None),
          ("VolumeData", f"volumes[{MAX_VOLUMES + 1}]", None))
SAMPLERS = (("FLOAT_2D", "chains"), ("FLOAT_2D", "volume_sh"), ("FLOAT_2D", "volume_depth"),
            ("FLOAT_2D", "env_table"), ("FLOAT_2D", "env_axes"))


def defines() -> dict:
    """The defines ``glsl/indirect.glsl`` reads."""
    from ..core.kernels import indirect as indirect_kernel

    low, high = core_probes.EXTRAPOLATION
    return {"ROW_WIDTH": textures.ROW_WIDTH, "EXTRAPOLATION_LOW": repr(float(low)),
            "EXTRAPOLATION_HIGH": repr(float(high)), "NEAREST": indirect_kernel.NEAREST,
            "CHOSEN": MAX_REFLECTIONS + 1 + indirect_kernel.NEAREST}


def prelude() -> str:
    """The cube faces' axes (``cubemap.FACES``) and the influence views' colours
    (``core.render.viewport.PALETTE``, ``WORLD_GREY``) as GLSL constants."""
    from ..core.render.viewport import PALETTE, WORLD_GREY

    faces = np.asarray(cubemap.FACES, np.float64)

    def table(name, rows, digits=1):
        items = ", ".join(f"vec3({a:.{digits}f}, {b:.{digits}f}, {c:.{digits}f})"
                          for a, b, c in rows)
        return f"const vec3 {name}[{len(rows)}] = vec3[{len(rows)}]({items});\n"

    return (table("CUBE_U", faces[:, 1]) + table("CUBE_V", faces[:, 2])
            + table("PALETTE", np.asarray(PALETTE, np.float64), 9)
            + f"const float WORLD_GREY = {float(WORLD_GREY):.9f};\n")


@dataclass
class IndirectSet:
    """A frame's indirect light on the GPU: the blocks' bytes and the textures."""

    indirect: bytes
    reflections: bytes
    volumes: bytes
    chains: object
    volume_sh: object
    volume_depth: object
    env_table: object
    env_axes: object

    def blocks(self) -> tuple:
        """(struct, member, bytes) as ``pointwise.run`` takes them."""
        data = (self.indirect, self.reflections, self.volumes)
        return tuple((struct, member, raw) for (struct, member, _), raw in
                     zip(BLOCKS, data, strict=True))

    def samplers(self) -> tuple:
        textures_ = (self.chains, self.volume_sh, self.volume_depth, self.env_table,
                     self.env_axes)
        return tuple((kind, name, t) for (kind, name), t in
                     zip(SAMPLERS, textures_, strict=True))


def unsupported(probes, visibility: bool = True) -> str | None:
    """What of ``probes`` the GPU's blocks and textures cannot hold (with the ``visibility``
    test, the volumes' depth moments too), or None."""
    if len(probes.reflection) > MAX_REFLECTIONS:
        return f"more than {MAX_REFLECTIONS} reflection probes"
    if len(probes.volumes) > MAX_VOLUMES:
        return f"more than {MAX_VOLUMES} irradiance volumes"
    texels = sum(int(np.prod(np.shape(v.moments)[:4])) * (np.shape(v.moments)[-2] + 2) ** 2
                 for v in probes.volumes if visibility and v.moments is not None)
    if texels > MAX_DEPTH_TEXELS:
        return (f"irradiance volumes of more than {MAX_DEPTH_TEXELS // 600:,} samples in all "
                "for the Visibility Test")
    return None


def _volume_record(vol, row: int, depth: int) -> dict:
    m = np.asarray(vol.local_to_world, np.float64)
    res = np.asarray(vol.resolution, np.int64)
    step = float(core_probes.grid_spacing(m, vol.resolution))
    facing = vol.facing_bias is not None
    return {"to_local": affine.inverse(m)[:3], "to_world": m[:3],
            "res": [*res, row],
            "params": [vol.influence, vol.falloff, vol.normal_bias * step,
                       vol.view_bias * step],
            "facing": [vol.facing_bias if facing else 0.0, float(facing),
                       float(vol.validity is not None), 0.0],
            "visibility": [float(depth), vol.variance_floor(),
                           0.0 if vol.moments is None else float(vol.moments.shape[-2]),
                           vol.moment_clamp()]}


def indirect_set(probes, normalization: str, prefilter: str, env_model: str,
                 extrapolate: bool = False, visibility: bool = True,
                 nearest: bool = False) -> IndirectSet:
    """Upload ``probes`` (``core.lighting.probes.Probes``) for ``glsl/indirect.glsl`` with the
    frame's normalization, prefilter, environment BRDF, volume extrapolation, visibility
    test and nearest reflections (``RenderSettings``' names)."""
    from ..core.kernels import indirect as indirect_kernel

    why = unsupported(probes)
    if why:
        raise ValueError(why)
    flat, offsets, sides, levels = core_probes.packed_chains(probes, prefilter)
    shs = [p.sh for p in probes.reflection] + [probes.world_sh]
    records = []
    for k, probe_sh in enumerate(shs):
        scalar, tint = sh.to_tinted(np.asarray(probe_sh, np.float64))
        record = {"scalar": scalar, "tint": tint,
                  "dc_eps": np.asarray(probe_sh, np.float64)[0] + core_probes.EPS,
                  "counts": [levels[k], 0, 0, 0],
                  "offsets": offsets[k] // 3, "sides": sides[k]}
        if k < len(probes.reflection):
            p = probes.reflection[k]
            record.update(position=p.position, radius=p.radius,
                          fade=max(max(p.falloff, 1e-4) * p.radius, 1e-6))
            if p.proxy != "none" and p.proxy_to_world is not None:
                m = np.asarray(p.proxy_to_world, np.float64)
                if abs(np.linalg.det(m[:3, :3])) > 1e-12:
                    record["proxy"] = affine.inverse(m)[:3]
                    record["counts"][1] = indirect_kernel.PROXIES[p.proxy]
        if len(offsets[k]) > MAX_LEVELS:
            raise ValueError(f"a chain of more than {MAX_LEVELS} levels")
        records.append(record)
    volumes = list(probes.volumes) + ([probes.bounce] if probes.bounce is not None else [])
    rows, vol_records, at = [], [], 0
    depth_rows, depth_at = [], 0
    for vol in volumes:
        coeffs = np.asarray(vol.sh, np.float32).reshape(-1, 9, 3)
        part = np.zeros((len(coeffs), 9, 4), np.float32)
        part[..., :3] = coeffs
        if vol.validity is not None:
            part[:, 0, 3] = np.asarray(vol.validity, np.float32).reshape(-1)
        rows.append(part.reshape(-1, 4))
        depth = -1
        if visibility and vol.moments is not None:
            padded = vol.padded_moments().reshape(-1, 2)
            depth_rows.append(padded)
            depth, depth_at = depth_at, depth_at + len(padded)
        vol_records.append(_volume_record(vol, at, depth))
        at += len(part) * 9
    table, gloss_axis, nv_axis = core_probes.env_table()
    axes = np.zeros((2, max(len(gloss_axis), len(nv_axis)), 1), np.float32)
    axes[0, :len(gloss_axis), 0] = gloss_axis
    axes[1, :len(nv_axis), 0] = nv_axis
    indirect = INDIRECT.pack([{
        "world_sh": np.asarray(probes.world_sh, np.float32),
        "band": sh.BAND_FACTORS.astype(np.float32),
        "world_color": ([*np.asarray(probes.world_color, np.float32)[:3], 1.0]
                        if probes.world_color is not None else [0.0] * 4),
        "counts": [len(probes.reflection), len(probes.volumes),
                   indirect_kernel.NORMALIZATIONS[normalization],
                   indirect_kernel.ENV_MODELS[env_model]],
        "flags": [len(probes.volumes) if probes.bounce is not None else -1, int(visibility),
                  int(nearest), 0],
        "limits": [core_probes.EPS, core_probes.MAX_NORMALIZATION,
                   formulas_env_brdf.N_DOT_V_MIN, float(extrapolate)],
        "fit": np.array(formulas_env_brdf.FIT_A0 + formulas_env_brdf.FIT_A1)}])
    return IndirectSet(
        indirect, REFLECTION.pack(records, MAX_REFLECTIONS + 1),
        VOLUME.pack(vol_records, MAX_VOLUMES + 1),
        textures.rows(flat.reshape(-1, 3) if flat.size % 3 == 0 else np.zeros((1, 3))),
        textures.rows(np.concatenate(rows) if rows else np.zeros((1, 4), np.float32)),
        textures.rows(np.concatenate(depth_rows) if depth_rows else np.zeros((1, 2), np.float32)),
        textures.image(np.ascontiguousarray(np.moveaxis(table, 0, -1), np.float32)),
        textures.image(axes))
