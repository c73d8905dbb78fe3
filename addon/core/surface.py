"""Material inputs per visible point: texture lookups, the Principled conversion, normal maps.

The talk's material parameters are albedo, specular colour rf0 and gloss (slide "Black Ops:
shading model"; alpha = 8192^gloss on slide "Black Ops: normal distribution function").
Principled BSDF inputs are converted per pixel, after texture lookups:

    albedo = base_color (1 - metallic) (1 - transmission)
    rf0    = lerp(F0(ior) 2 specular_level specular_tint, base_color, metallic),
             F0(ior) = ((ior - 1) / (ior + 1))^2, clamped to [0, 1]
    gloss  = brdf.roughness_to_gloss(roughness)        (documented in docs/model.md)

A colour texture feeding a scalar input gives its luminance (Rec. 709 weights of the
scene-linear space), as Blender converts a colour socket to a float.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from . import affine, brdf, texture
from .scene import Material, NormalMap, TextureInput

LUMINANCE = np.array([0.2126, 0.7152, 0.0722], np.float32)


@dataclass
class Lookup:
    """Where textures are read for N points: uv (N, 2) and lod-ready UV derivatives (N, 2)."""

    uv: np.ndarray | None
    duv_dx: np.ndarray | None
    duv_dy: np.ndarray | None


@dataclass
class SurfaceParams:
    """The talk's parameters at N points: albedo, rf0, emission (N, 3); gloss (N,)."""

    albedo: np.ndarray
    rf0: np.ndarray
    gloss: np.ndarray
    emission: np.ndarray
    normal_map: np.ndarray | None  # (N, 3) tangent-space map values in [0, 1], or None
    normal_strength: float = 1.0


def _value(value, n: int, lookup: Lookup, channels: int) -> np.ndarray:
    """A constant or texture input evaluated at n points: (n, 3) or (n,) float32."""
    if isinstance(value, TextureInput):
        tex = value.texture
        if lookup.uv is None:  # no UV map: the texture's first texel, as Cycles reads (0, 0)
            uv = np.zeros((n, 2), np.float32)
            lod = None
        else:
            uv = lookup.uv
            lod = texture.lod_from_uv_derivatives(tex, lookup.duv_dx, lookup.duv_dy)
        px = texture.sample(tex, uv, lod)
        if value.channel == "alpha":
            out = px[:, 3] if px.shape[1] == 4 else np.ones(n, np.float32)
            return np.repeat(out[:, None], 3, 1) if channels == 3 else out
        rgb = px[:, :3] if px.shape[1] >= 3 else np.repeat(px[:, :1], 3, 1)
        return rgb if channels == 3 else affine.linear(rgb, LUMINANCE[None])[:, 0]
    arr = np.asarray(value, np.float32)
    if channels == 3:
        return np.broadcast_to(arr.reshape(-1)[:3] if arr.size >= 3 else arr, (n, 3))
    return np.broadcast_to(arr.reshape(-1)[0] if arr.ndim else arr, (n,))


def principled_to_talk(base, metallic, roughness, ior, level, tint, transmission):
    """Principled BSDF inputs at N points -> (albedo (N,3), rf0 (N,3), gloss (N,)).

    base (N,3); metallic, roughness, level (N,); ior, transmission floats; tint (3,).
    """
    metallic = np.clip(metallic, 0.0, 1.0)[:, None]
    f0 = ((max(ior, 1.0) - 1.0) / (max(ior, 1.0) + 1.0)) ** 2
    dielectric = np.clip(f0 * 2.0 * level[:, None] * np.asarray(tint, np.float32), 0.0, 1.0)
    albedo = base * (1.0 - metallic) * (1.0 - float(np.clip(transmission, 0.0, 1.0)))
    rf0 = dielectric + (base - dielectric) * metallic
    gloss = brdf.roughness_to_gloss(np.clip(roughness, 0.0, 1.0).astype(np.float32))
    return albedo.astype(np.float32), rf0.astype(np.float32), gloss.astype(np.float32)


def evaluate(material: Material, n: int, lookup: Lookup) -> SurfaceParams:
    """The talk's parameters of ``material`` at n points (textures read through ``lookup``)."""
    if material.principled is not None:
        p = material.principled
        albedo, rf0, gloss = principled_to_talk(
            _value(p.base_color, n, lookup, 3), _value(p.metallic, n, lookup, 1),
            _value(p.roughness, n, lookup, 1), p.ior, _value(p.specular_level, n, lookup, 1),
            p.specular_tint, p.transmission)
    else:
        albedo = _value(material.albedo, n, lookup, 3)
        rf0 = _value(material.rf0, n, lookup, 3)
        gloss = np.clip(_value(material.gloss, n, lookup, 1), 0.0, 1.0)
    emission = _value(material.emission, n, lookup, 3) * np.float32(material.emission_strength)
    nmap: NormalMap | None = material.normal_map
    normal_values = None
    if nmap is not None and lookup.uv is not None:
        normal_values = _value(nmap.texture, n, lookup, 3)
    return SurfaceParams(
        albedo=np.asarray(albedo, np.float32),
        rf0=np.asarray(rf0, np.float32),
        gloss=np.asarray(gloss, np.float32),
        emission=np.asarray(emission, np.float32),
        normal_map=normal_values,
        normal_strength=nmap.strength if nmap is not None else 1.0,
    )
