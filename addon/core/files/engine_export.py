"""What a game engine loads: prefiltered cube map chains and SH, in its files and axes.

A chain (``write_chain``) is written in the GPU face layout (``gpu_textures``, Y up) as

- ``.ktx2``: KTX2 RGBA16F with the metadata under the key ``bo2.meta``;
- ``.dds``:  DDS RGBA16F, the metadata beside it as ``<name>.json``;
- ``.exr``:  one OpenEXR file, float32 RGB, a part per mip (``mip0``, ``mip1``, ...) holding its
  six faces top to bottom, the metadata in the attribute ``bo2.meta`` (``bake_file``).

The metadata (``chain_metadata``) says how to read it as the talk does: each mip's gloss and
Phong power, the shader's lod = nMips - gloss nMips (slide "Black Ops: environment map
pre-filtering"), and the environment map normalization's data (slide "Environment map
normalization: new idea": the map's irradiance as tinted scalar 3rd-order SH, ``sh.to_tinted``),
with the RGB SH too. SH are in the engine's axes (``gpu_textures.Y_UP``), radiance coefficients
of ``sh.basis`` (Ramamoorthi & Hanrahan 2001), irradiance E(n) = sum A_l L_lm Y_lm(n).
"""

from __future__ import annotations

import json
import os
from pathlib import Path

import numpy as np

from ..formulas import cubemap, sh
from ..system.atomic import write_atomically, write_text
from . import bake_file, gpu_textures

__all__ = ["AXES", "FORMATS", "chain_metadata", "cube_sh", "sh_header", "sh_record", "write_chain"]

FORMATS = ("ktx2", "dds", "exr")


def cube_sh(cube: np.ndarray) -> np.ndarray:
    """(9, 3) float64 radiance SH of a ``cubemap.FACES`` cube, in the engine's axes (Y up)."""
    size = cube.shape[1]
    d = cubemap.texel_directions(size).reshape(-1, 3).astype(np.float64) @ gpu_textures.Y_UP.T
    omega = np.broadcast_to(cubemap.texel_solid_angles(size), (6, size, size)).reshape(-1)
    return sh.project(d, np.asarray(cube, np.float64).reshape(-1, cube.shape[-1])[:, :3], omega)


AXES = {"y-up": "Y up: Blender's (x, y, z) as (x, z, -y), as glTF",
        "blender": "Blender's: Z up"}


def sh_record(coefficients: np.ndarray, axes: str = "y-up") -> dict:
    """The JSON form of RGB radiance SH in ``axes`` (a key of ``AXES``): the coefficients,
    their order and basis, and the tinted scalar SH (``sh.to_tinted``)."""
    coefficients = np.asarray(coefficients, np.float64).reshape(sh.COEFFICIENTS, 3)
    scalar, tint = sh.to_tinted(coefficients)
    return {
        "axes": AXES[axes],
        "basis": "real SH, Ramamoorthi & Hanrahan 2001 eq. 3, no Condon-Shortley sign",
        "order": [list(lm) for lm in sh.ORDER],
        "radiance_rgb": [[float(x) for x in row] for row in coefficients],
        "irradiance_band_factors": [float(x) for x in sh.BAND_FACTORS],
        "tinted_scalar": {"scalar": [float(x) for x in np.ravel(scalar)],
                          "tint": [float(x) for x in np.ravel(tint)],
                          "weights": [float(x) for x in sh.LUMINANCE_REC709]},
    }


def chain_metadata(filter_name: str, powers, size: int, coefficients, **extra) -> dict:
    """The metadata of a chain of len(powers) mips of face size ``size`` (see the module
    docstring); ``extra`` is added as it is."""
    count = len(powers)
    gloss = [1.0 - m / (count - 1) if count > 1 else 1.0 for m in range(count)]
    return {
        "filter": filter_name,
        "face_size": int(size),
        "mips": count,
        "faces": ["+X", "-X", "+Y", "-Y", "+Z", "-Z"],
        "face_orientation": "OpenGL/Direct3D/Vulkan cube map table, engine axes Y up",
        "mip_gloss": gloss,
        "mip_phong_power": [float(p) for p in powers],
        "gloss_to_lod": f"lod = {count - 1} - gloss * {count - 1}",
        "normalization": "divide the map by its irradiance (sh) at the surface's normal, "
                         "multiply by the surface's irradiance (Lazarov 2013)",
        "sh": sh_record(coefficients),
        **extra,
    }


def write_chain(path: str | os.PathLike, mips: list[np.ndarray], meta: dict) -> list[Path]:
    """Write a ``cubemap.FACES`` mip chain ((6, S >> m, S >> m, C) each) in the format of
    ``path``'s suffix; returns the files written (a DDS has its JSON beside it). Files are
    replaced atomically."""
    path = Path(path)
    kind = path.suffix.lower().lstrip(".")
    if kind not in FORMATS:
        raise ValueError(f"{path}: unknown format; use .{', .'.join(FORMATS)}")
    gpu = [gpu_textures.to_gpu_faces(np.asarray(level, np.float32)[..., :3]) for level in mips]
    if kind == "ktx2":
        gpu_textures.write_ktx2(path, gpu, meta)
        return [path]
    if kind == "dds":
        gpu_textures.write_dds(path, gpu)
        side = path.with_suffix(".json")
        write_text(side, json.dumps(meta, indent=2) + "\n")
        return [path, side]
    images = [(f"mip{m}", level.reshape(-1, level.shape[2], 3)) for m, level in enumerate(gpu)]
    write_atomically(path, lambda tmp: bake_file.write_parts(tmp, meta, images))
    return [path]


def sh_header(name: str, coefficients, source: str = "", axes: str = "y-up") -> str:
    """A C header declaring the RGB radiance SH and the tinted scalar SH of ``coefficients``
    ((9, 3) in ``axes``) as ``static const float`` arrays named after ``name``."""
    ident = "".join(c if c.isascii() and c.isalnum() else "_" for c in name).strip("_") or "env"
    if ident[0].isdigit():
        ident = "env_" + ident
    record = sh_record(coefficients, axes)
    rows = ",\n".join("    {" + ", ".join(f"{x:.9g}f" for x in row) + "}"
                      for row in record["radiance_rgb"])
    scalar = ", ".join(f"{x:.9g}f" for x in record["tinted_scalar"]["scalar"])
    tint = ", ".join(f"{x:.9g}f" for x in record["tinted_scalar"]["tint"])
    guard = f"BO2_SH_{ident.upper()}_H"
    return (
        f"/* Spherical harmonics of {source or name}, written by BO2 Lighting.\n"
        " * Radiance SH, order 3 (9 coefficients: (l, m) = (0,0) (1,-1) (1,0) (1,1) (2,-2)\n"
        " * (2,-1) (2,0) (2,1) (2,2)), real basis of Ramamoorthi & Hanrahan 2001 eq. 3,\n"
        f" * axes {record['axes']}.\n"
        " * Irradiance: E(n) = sum A_l L_lm Y_lm(n), A = pi, 2pi/3, pi/4.\n"
        " * Tinted scalar SH (Lazarov 2013): rgb = tint * scalar reconstruction. */\n"
        f"#ifndef {guard}\n#define {guard}\n\n"
        f"static const float {ident}_sh_rgb[9][3] = {{\n{rows}\n}};\n\n"
        f"static const float {ident}_sh_scalar[9] = {{{scalar}}};\n"
        f"static const float {ident}_sh_tint[3] = {{{tint}}};\n\n"
        f"#endif /* {guard} */\n")
