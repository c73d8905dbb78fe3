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

from ..formulas import env_brdf
from ..scene import Light


def light_incidence(light: Light, position: np.ndarray, geo: np.ndarray):
    """Direction to the light and its irradiance, unshadowed (``kernels.shading.incidence``).

    light:    one scene light
    position: (N, 3) float32 world-space surface points, metres
    geo:      (N, 3) float32 unit geometric normals: what faces the light
    returns:  l (N, 3) float32 unit vectors from the surface towards the light,
              irradiance (N, 3) float32 W/m^2 on a surface facing the light (0 where not lit),
              lit (N,) bool: the geometric normal faces the light and the light gives light
    """
    from ..kernels import shading

    n = len(position)
    l_dir = np.empty((n, 3), np.float32)
    irradiance = np.empty((n, 3), np.float32)
    lit = np.empty(n, bool)
    shading.incidence(np.ascontiguousarray(position, np.float32),
                      np.ascontiguousarray(geo, np.float32), shading.KINDS[light.kind],
                      np.asarray(light.color, np.float32).ravel()[:3].copy(),
                      np.asarray(light.position, np.float32).ravel()[:3].copy(),
                      np.asarray(light.direction, np.float32).ravel()[:3].copy(),
                      float(np.cos(0.5 * light.spot_size)), float(light.spot_blend),
                      l_dir, irradiance, lit)
    return l_dir, irradiance, lit


def add_direct(normal, view, l_dir, irradiance, albedo, rf0, gloss, model, diffuse, specular,
               visibility=None):
    """Add one light's reflected radiance, (f_diffuse + f_specular) (n.l) E with the terms of
    ``brdf.direct_brdf`` for ``model`` (``kernels.shading.accumulate``), to ``diffuse`` and
    ``specular`` (N, 3) float32, W/(m^2 sr).

    normal, view, l_dir: (N, 3) unit vectors; irradiance: (N, 3) W/m^2, unshadowed
    albedo, rf0: (N, 3) linear;  gloss: (N,);  model: a name of ``brdf.MODELS``
    visibility: (N,) shadow term E is multiplied by (``shadow_filter.shadow_visibility``), or None
    """
    from ..kernels import shading

    def f32(a, shape):
        a = np.asarray(a, np.float32)
        return np.require(a if a.shape == shape else np.broadcast_to(a, shape), np.float32,
                          ["C", "W"])

    n = (len(normal), 3)
    vis = f32(1.0 if visibility is None else visibility, n[:1])
    shading.accumulate(f32(normal, n), f32(view, n), f32(l_dir, n), f32(irradiance, n), vis,
                       f32(albedo, n), f32(rf0, n), f32(gloss, n[:1]), shading.MODELS[model],
                       diffuse, specular)


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
