"""Deferred shading of visible surface points: direct light from Blender's light types.

Light units follow Blender so that a Lambert surface lit by one light matches Cycles: the
irradiance on a surface facing the light (perpendicular irradiance E, W/m^2) is

- point and spot, power P (W) at distance d:  E = P / (4 pi d^2)
- spot cone:  times smoothstep((cos theta - cos(size/2)) / ((1 - cos(size/2)) blend)), the
  cone falloff of Cycles' spot light
- sun, strength S (W/m^2):                   E = S
- area, power P (W), representative point at its centre (an approximation, exact for a small
  light far away):                           E = P max(0, cos theta_light) / (pi d^2)

and the reflected radiance is (f_diffuse + f_specular) (n.l) E with the BRDF of ``brdf.py``
(slide "Black Ops: shading model": Lambert diffuse plus the microfacet specular). These
factors were measured against Cycles renders of a white Lambert plane (tests/blender).

Indirect specular is the split approximation of slide "Environment lighting: split
approximation": the prefiltered environment radiance along the reflection vector times the
environment BRDF of ``env_brdf.py``.
"""

from __future__ import annotations

import numpy as np

from . import brdf, env_brdf
from .scene import Light


def _normalize(v: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Unit vectors and lengths of (N, 3) vectors; zero-length vectors stay zero."""
    length = np.linalg.norm(v, axis=-1)
    unit = v / np.maximum(length, 1e-20)[..., None]
    return unit.astype(np.float32), length.astype(np.float32)


def _smoothstep(x: np.ndarray) -> np.ndarray:
    x = np.clip(x, 0.0, 1.0)
    return x * x * (3.0 - 2.0 * x)


def light_incidence(light: Light, position: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Direction to the light and perpendicular irradiance, unshadowed.

    light:    one scene light
    position: (N, 3) float32 world-space surface points, metres
    returns:  l (N, 3) unit vectors from the surface towards the light,
              irradiance (N, 3) W/m^2 on a surface facing the light
    """
    color = np.asarray(light.color, np.float32)
    axis = np.asarray(light.direction, np.float32)
    if light.kind == "SUN":
        l_dir = np.broadcast_to(-axis, position.shape).astype(np.float32)
        return l_dir, np.broadcast_to(color, position.shape).astype(np.float32)

    l_dir, dist = _normalize(np.asarray(light.position, np.float32) - position)
    inv_d2 = 1.0 / np.maximum(dist * dist, 1e-8)
    if light.kind == "AREA":
        cos_light = np.maximum(0.0, -(l_dir @ axis))
        scale = cos_light * inv_d2 / np.pi
    else:
        scale = inv_d2 / (4.0 * np.pi)
        if light.kind == "SPOT":
            cos_half = np.cos(0.5 * light.spot_size)
            cos_theta = -(l_dir @ axis)
            if light.spot_blend > 0.0:
                cone = _smoothstep((cos_theta - cos_half) / ((1.0 - cos_half) * light.spot_blend))
            else:
                cone = (cos_theta > cos_half).astype(np.float32)
            scale = scale * cone
    return l_dir, (scale[:, None] * color).astype(np.float32)


def shade_direct(
    position: np.ndarray,
    normal: np.ndarray,
    view: np.ndarray,
    albedo: np.ndarray,
    rf0: np.ndarray,
    gloss: np.ndarray,
    lights: list[Light],
    model: str = "reference",
) -> tuple[np.ndarray, np.ndarray]:
    """Direct diffuse and specular radiance of every point from every light (no shadows yet).

    position, normal, view: (N, 3) float32; view points from the surface to the eye
    albedo, rf0: (N, 3) float32 linear;  gloss: (N,) float32 in [0, 1]
    model:   a name of ``brdf.MODELS``
    returns: diffuse (N, 3), specular (N, 3) radiance, W/(m^2 sr)
    """
    diffuse = np.zeros_like(albedo, dtype=np.float32)
    specular = np.zeros_like(albedo, dtype=np.float32)
    for light in lights:
        l_dir, irradiance = light_incidence(light, position)
        d, s = brdf.direct_brdf(normal, view, l_dir, albedo, rf0, gloss, model=model)
        diffuse += d * irradiance
        specular += s * irradiance
    return diffuse, specular


def indirect_specular(
    radiance: np.ndarray,
    normal: np.ndarray,
    view: np.ndarray,
    rf0: np.ndarray,
    gloss: np.ndarray,
    model: str = "bo2",
) -> np.ndarray:
    """Indirect specular radiance: prefiltered radiance times the environment BRDF.

    Slide "Environment lighting: split approximation" (Lazarov 2013): the first factor,
    ``radiance``, is the environment prefiltered with D_env and sampled along the reflection
    vector (the probes provide it, normalized); the second is ``env_brdf.environment_brdf``.

    radiance:     (N, 3) prefiltered environment radiance at each point, W/(m^2 sr)
    normal, view: (N, 3) unit normal and direction to the eye
    rf0:          (N, 3) specular colour;  gloss: (N,) gloss
    model:        a name of ``env_brdf.MODELS``
    returns:      (N, 3) float32 radiance towards the eye
    """
    n_dot_v = np.einsum("nc,nc->n", normal, view)
    e = env_brdf.environment_brdf(gloss[:, None], n_dot_v[:, None], rf0, model)
    return (np.asarray(radiance, np.float32) * e).astype(np.float32)
