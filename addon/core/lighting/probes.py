"""Light probes and the indirect light they give: SH irradiance and prefiltered reflections.

The talk's indirect lighting (Lazarov 2013):

- Indirect diffuse: albedo / pi times the irradiance at the shading normal, from order-3 SH
  light probes (Ramamoorthi & Hanrahan 2001). Irradiance volumes (Blender's Volume light probes)
  hold one SH per grid sample of the light that reached it (the sky too, as far as the sample
  sees it); a point gets the trilinear blend of the eight samples around it, fading outside
  the volume's box as Blender's (``IrradianceVolume.weight``). Where the volumes leave weight
  the world lights the point, times the fraction of the world's light that the point itself
  sees (``sky``): a wall just outside a volume's box is lit by the sky through the room's
  openings only, the ground under an object outdoors darkens, and a point leaving a volume
  blends from its light to the world's seen light without a seam.
- Indirect specular: the prefiltered cube map of the nearest reflection probes (Blender's Sphere
  light probes) along the reflection vector at lod = nMips - gloss nMips (slide "Black Ops:
  environment map pre-filtering"), normalized to the local lighting, times the environment BRDF
  (``env_brdf.py``). Normalization (slides "Black Ops: normalization algorithm" and "Improved
  normalization algorithm"):

  - "none": the prefiltered radiance as captured;
  - "bo1":  divided by the probe's average irradiance (its SH's constant term) and multiplied by
    the pixel's average irradiance (the constant term of the pixel's SH);
  - "bo2":  divided by the probe's irradiance at the normal (its tinted scalar SH) and multiplied
    by the pixel's irradiance at the normal.

  The ratio is bounded by ``MAX_NORMALIZATION`` so that a probe that captured (nearly) no light
  in some direction cannot blow a pixel up.

The weight that the reflection probes leave (1 - the sum of their weights, when that is
positive) goes to the world's prefiltered cube map in the share of the world's light that the
point sees (``sky``), and the rest to the two probes nearest the point (by inverse squared
distance): where the world is hidden, the surroundings are more like what the nearest probes
saw than like the sky. With the "bo1" and "bo2" normalizations every chain is scaled to the
pixel's irradiance, so the world's is dimmed where its light is occluded, as the pixel's SH is.

References
----------
- D. Lazarov, "Getting More Physical in Call of Duty: Black Ops II", SIGGRAPH 2013 course
  "Physically Based Shading in Theory and Practice".
- R. Ramamoorthi, P. Hanrahan, "An Efficient Representation for Irradiance Environment Maps",
  SIGGRAPH 2001.
"""

from __future__ import annotations

import functools
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from ..formulas import affine, cubemap, sh
from ..formulas import env_brdf as formulas_env_brdf
from ..scene import CHOICES
from . import sample_visibility

__all__ = [
    "MAX_NORMALIZATION",
    "NORMALIZATIONS",
    "PREFILTERS",
    "IrradianceVolume",
    "Probes",
    "ReflectionProbe",
    "grid_spacing",
    "indirect",
    "volume_sample_positions",
]

NORMALIZATIONS = tuple(c.id for c in CHOICES["normalization"])
PREFILTERS = tuple(c.id for c in CHOICES["prefilter"])
MAX_NORMALIZATION = 16.0
EPS = 1e-6
EXTRAPOLATION = (0.5, 1.5)
"""A volume's look-up past its outermost samples: the SH at the clamped point is scaled by at
least and at most these factors (``IrradianceVolume.sample_sh``)."""
# the fraction of the world's light that reaches the points of these indices: (k,) -> (k,)
SkyFn = Callable[[np.ndarray], np.ndarray]


@dataclass
class ReflectionProbe:
    """A baked reflection probe (Blender's Sphere light probe).

    position:  (3,) world position of the capture, metres
    radius:    influence radius, metres;  falloff: fraction of the radius over which the
               influence fades to 0 at the radius (Blender's Falloff)
    mips:      {"bo2": cosine-power chain, "bo1": angular Gaussian chain}, each a list of
               float32 (6, S_m, S_m, 3) cube maps of radiance, S_m = S >> m
    sh:        (9, 3) float32 SH of the captured radiance (``sh.project`` of the cube)
    proxy:     "none", "sphere" or "box": the shape the reflections are corrected to
               (parallax-corrected cube maps, Lagarde and Zanuttini, "Local image-based
               lighting with parallax-corrected cubemaps", SIGGRAPH 2012): the unit sphere or
               the cube [-1, 1]^3 of ``proxy_to_world``
    proxy_to_world: (4, 4) float64, or None with proxy "none"
    """

    name: str
    position: np.ndarray
    radius: float
    falloff: float
    mips: dict[str, list[np.ndarray]]
    sh: np.ndarray
    proxy: str = "none"
    proxy_to_world: np.ndarray | None = None

    def weight(self, points: np.ndarray) -> np.ndarray:
        """(N,) influence in [0, 1] at world points (N, 3)."""
        d = np.linalg.norm(points - np.asarray(self.position, np.float32), axis=-1)
        fade = max(self.falloff, 1e-4) * self.radius
        return np.clip((self.radius - d) / max(fade, 1e-6), 0.0, 1.0).astype(np.float32)


@dataclass
class IrradianceVolume:
    """A baked irradiance volume (Blender's Volume light probe).

    local_to_world: (4, 4) float64: the grid spans the local cube [-1, 1]^3
    resolution:     (3,) samples along local x, y, z
    sh:             float32 (X, Y, Z, 9, 3) radiance SH at the samples
    influence:      distance outside the box in local units (the box's half size is 1), over
                    which the volume's weight fades to 0 (Blender's Distance)
    falloff:        the fraction of ``influence`` over which it fades (Blender's Falloff)
    validity:       float32 (X, Y, Z) in [0, 1], or None (all valid): a sample of validity 0 (in
                    geometry, and no valid neighbour to take its light from:
                    ``core.bakes.bake.dilate``) is left out of the blend
    normal_bias, view_bias: the look-up point moves this many sample spacings along the
                    shading normal and towards the eye (EEVEE's Normal and View Bias)
    facing_bias:    samples behind the surface are left out of the blend: each of the eight
                    weighs max(0, dot(unit(sample - point), normal) + facing_bias), so a larger
                    bias blends more smoothly and leaks more (EEVEE's Facing Bias); None: plain
                    trilinear
    moments:        float32 (X, Y, Z, 6, M, M, 2) the samples' depth moments
                    (``sample_visibility``), or None: no visibility test
    """

    name: str
    local_to_world: np.ndarray
    resolution: tuple[int, int, int]
    sh: np.ndarray
    influence: float = 0.0
    validity: np.ndarray | None = None
    normal_bias: float = 0.0
    view_bias: float = 0.0
    facing_bias: float | None = None
    falloff: float = 1.0
    moments: np.ndarray | None = None
    _positions: np.ndarray | None = field(default=None, init=False, repr=False, compare=False)
    _padded: np.ndarray | None = field(default=None, init=False, repr=False, compare=False)

    def _local(self, points: np.ndarray) -> np.ndarray:
        inv = affine.inverse(self.local_to_world)
        return affine.transform(points.astype(np.float64), inv).astype(np.float32)

    def weight(self, points: np.ndarray) -> np.ndarray:
        """(N,) influence in [0, 1]: 1 inside the box; outside, Blender's: fading linearly
        over the last ``falloff`` of ``influence``, both measured in the volume's local space
        (the box is [-1, 1]^3), to 0 at ``influence`` from the box."""
        q = self._local(points)
        dist = np.linalg.norm(np.maximum(np.abs(q) - 1.0, 0.0), axis=-1)
        if self.influence <= 0.0:
            return (dist <= 0.0).astype(np.float32)
        fac = 1.0 / max(float(self.falloff), 1e-4)
        return np.clip(fac * (1.0 - dist / self.influence), 0.0, 1.0).astype(np.float32)

    def sample_sh(self, points: np.ndarray, normals: np.ndarray | None = None,
                  view: np.ndarray | None = None, extrapolate: bool = False,
                  visibility: bool = False) -> np.ndarray:
        """(N, 9, 3) SH at world points (N, 3): the blend of the eight samples around each
        (clamped to the outermost samples), trilinear, times each sample's validity and, given
        the unit shading ``normals`` and directions to the eye ``view`` (N, 3), its facing
        weight, at the point moved by the normal and view biases. Where every weight is 0:
        trilinear over the valid samples, or over all when none is. With ``extrapolate``, up to
        the box's faces (half a cell beyond the outermost samples) the SH at the clamped point
        scaled by its luminance's linear extrapolation (within ``EXTRAPOLATION``), held beyond
        the box (``kernels.indirect.volume_blend``). With ``visibility`` and ``moments``, each
        sample's weight is also its visibility of the (moved) point (``sample_visibility``)."""
        res = np.asarray(self.resolution)
        pts = np.asarray(points, np.float32)
        if normals is not None:
            step = np.float32(grid_spacing(self.local_to_world, self.resolution))
            pts = pts + np.float32(self.normal_bias) * step * normals
            if view is not None:
                pts = pts + np.float32(self.view_bias) * step * view
        q = self._local(pts)
        # sample i sits at local (i + 0.5) / res * 2 - 1 (volume_sample_positions)
        f = np.clip((q + 1.0) * 0.5 * res - 0.5, -1.0, res).astype(np.float32)
        facing = normals is not None and self.facing_bias is not None
        if self._positions is None:
            self._positions = np.ascontiguousarray(volume_sample_positions(
                self.local_to_world, self.resolution).reshape(-1, 3), np.float32)
        from ..kernels import indirect as kernels

        visible = visibility and self.moments is not None
        out = np.empty((len(pts), 27), np.float32)
        n = np.ascontiguousarray(normals if facing else np.zeros((len(pts), 3)), np.float32)
        kernels.volume_blend(
            np.ascontiguousarray(f), np.asarray(res, np.int64), self._positions,
            np.ascontiguousarray(np.ones(1) if self.validity is None else self.validity,
                                 np.float32).reshape(-1), self.validity is not None,
            np.ascontiguousarray(pts, np.float32), n, facing,
            np.float32(self.facing_bias if facing else 0.0),
            self.padded_moments() if visible else np.zeros((1, 6, 1, 1, 2), np.float32),
            visible, np.array(cubemap.FACES, np.float64), self.variance_floor(),
            self.moment_clamp(),
            np.ascontiguousarray(self.sh, np.float32).reshape(-1, 27),
            *np.float32(EXTRAPOLATION if extrapolate else (1.0, 1.0)), out)
        return out.reshape(-1, 9, 3)

    def padded_moments(self) -> np.ndarray:
        """(S, 6, M + 2, M + 2, 2) float32: every sample's ``moments`` with the seamless
        one-texel border (``cubemap.with_border``), made once."""
        if self._padded is None:
            m = np.asarray(self.moments, np.float32)
            k, size = int(np.prod(self.resolution)), m.shape[-2]
            padded = cubemap.with_border(np.moveaxis(m.reshape(k, 6, size, size, 2), 0, 3)
                                         .reshape(6, size, size, 2 * k))
            self._padded = np.ascontiguousarray(np.moveaxis(
                padded.reshape(6, size + 2, size + 2, k, 2), 3, 0))
        return self._padded

    def moment_clamp(self) -> float:
        """The distance the moments are clamped at, metres (``sample_visibility.max_distance``):
        a point farther from a sample (in the influence band beyond the box) is tested at it."""
        return sample_visibility.max_distance(self.local_to_world, self.resolution)

    def variance_floor(self) -> float:
        """The smallest variance of the visibility test, m^2 (``VARIANCE_FLOOR`` spacings^2)."""
        return sample_visibility.VARIANCE_FLOOR * grid_spacing(self.local_to_world,
                                                               self.resolution) ** 2


def grid_spacing(local_to_world: np.ndarray, resolution) -> float:
    """The distance between neighbouring samples of a volume, metres: the smallest over the
    axes with two samples or more (over all axes when none has)."""
    scale = np.linalg.norm(np.asarray(local_to_world, np.float64)[:3, :3], axis=0)
    res = np.asarray(resolution)
    steps = 2.0 * scale / res
    return float(np.min(steps[res > 1]) if (res > 1).any() else np.min(steps))


def volume_sample_positions(local_to_world: np.ndarray, resolution) -> np.ndarray:
    """World positions (X, Y, Z, 3) of a volume's samples: local (i + 0.5)/res * 2 - 1."""
    axes = [(np.arange(r) + 0.5) / r * 2.0 - 1.0 for r in resolution]
    q = np.stack(np.meshgrid(*axes, indexing="ij"), -1)
    m = np.asarray(local_to_world, np.float64)
    return q @ m[:3, :3].T + m[:3, 3]


@dataclass
class Probes:
    """Everything indirect light needs: the world fallback and the baked probes.

    world_sh:   (9, 3) radiance SH of the world
    world_mips: {"bo2": [...], "bo1": [...]} prefiltered world cube chains, as in
                ``ReflectionProbe.mips``
    world_color: (3,) radiance of a world of one colour (its prefiltered chains are that
                colour everywhere, so they are not sampled), else None
    bounce:     the implicit volume of what surfaces send after one bounce (``bounce``),
                added to the world's light where it reaches a point, or None
    packed:     the chains as the indirect kernel takes them (``packed_chains``), once
    """

    world_sh: np.ndarray
    world_mips: dict[str, list[np.ndarray]]
    world_color: np.ndarray | None = None
    reflection: list[ReflectionProbe] = field(default_factory=list)
    volumes: list[IrradianceVolume] = field(default_factory=list)
    bounce: IrradianceVolume | None = None
    packed: tuple | None = field(default=None, init=False, repr=False, compare=False)


def sends_light(probes: Probes) -> bool:
    """False when ``probes`` can light nothing: no baked probe, and a world of one colour that
    is black (a world image is taken to send light)."""
    if probes.volumes or probes.reflection or probes.world_color is None:
        return True
    return bool(np.any(np.asarray(probes.world_sh) != 0.0)
                or np.any(np.asarray(probes.world_color) != 0.0))


def _pixel_sh(probes: Probes, points: np.ndarray, normals: np.ndarray | None = None,
              view: np.ndarray | None = None, sky: SkyFn | None = None,
              extrapolate: bool = False, visibility: bool = False) -> np.ndarray:
    """SH at each point (N, 3), (N, 9, 3): the volumes' blend (``sample_sh``, with the unit
    shading ``normals`` and directions to the eye ``view`` (N, 3)), the world where they leave
    weight, times the fraction of its light that reaches the point (``sky`` of the indices of
    those points; None: all of it); (9, 3), the world's, when no volume reaches any point and
    there is no ``sky``. ``extrapolate``, ``visibility``: as ``sample_sh``'s."""
    n = len(points)
    total = np.zeros(n, np.float32)
    acc = None
    for vol in probes.volumes:
        w = vol.weight(points)
        k = np.flatnonzero(w > 0)
        if k.size:
            if acc is None:
                acc = np.zeros((n, 9, 3), np.float32)
            acc[k] += w[k, None, None] * vol.sample_sh(
                points[k], None if normals is None else normals[k],
                None if view is None else view[k], extrapolate, visibility)
            total[k] += w[k]
    world_sh = np.asarray(probes.world_sh, np.float32)
    if acc is None and sky is None and probes.bounce is None:
        return world_sh
    if acc is None:
        acc = np.zeros((n, 9, 3), np.float32)
    over = total > 1.0
    acc[over] /= total[over, None, None]
    share = np.maximum(1.0 - total, 0.0)
    if probes.bounce is not None:  # where the world's light reaches, what bounced off surfaces
        w = probes.bounce.weight(points) * share
        k = np.flatnonzero(w > 0)
        if k.size:
            acc[k] += w[k, None, None] * probes.bounce.sample_sh(
                points[k], None if normals is None else normals[k],
                None if view is None else view[k], extrapolate, visibility)
    if sky is not None:
        k = np.flatnonzero(share > 0.0)
        if k.size:
            share[k] *= np.asarray(sky(k), np.float32)
    acc += share[:, None, None] * world_sh[None]
    return acc


def packed_chains(probes: Probes, prefilter: str) -> tuple:
    """The chains of ``prefilter`` of every reflection probe, then the world's, as the indirect
    kernel takes them (``kernels.indirect``): padded levels in one flat float32 array, level
    offsets and sides (C, L) int64, level counts (C,); built again only when the chains (the
    list objects), the prefilter or the world colour change."""
    key = (prefilter, probes.world_color is None,
           [probes.world_mips.get(prefilter), *(p.mips.get(prefilter) for p in probes.reflection)])
    if probes.packed is not None:
        (name, no_color, chains), packed = probes.packed
        if (name, no_color) == key[:2] and len(chains) == len(key[2]) and all(
                a is b for a, b in zip(chains, key[2], strict=True)):  # the same list objects
            return packed
    chains = [p.mips[prefilter] for p in probes.reflection]
    chains.append(probes.world_mips[prefilter] if probes.world_color is None else [])
    count = max(len(c) for c in chains) or 1
    offsets = np.zeros((len(chains), count), np.int64)
    sides = np.ones((len(chains), count), np.int64)
    parts, at = [], 0
    for i, chain in enumerate(chains):
        for m, level in enumerate(chain):
            padded = cubemap.with_border(
                np.ascontiguousarray(level[..., :3], np.float32)).reshape(-1)
            offsets[i, m], sides[i, m] = at, level.shape[1]
            parts.append(padded)
            at += padded.size
    flat = np.concatenate(parts) if parts else np.zeros(1, np.float32)
    packed = (flat, offsets, sides, np.array([len(c) for c in chains], np.int64))
    probes.packed = (key, packed)
    return packed


def indirect(
    probes: Probes,
    points: np.ndarray,
    normals: np.ndarray,
    view: np.ndarray,
    albedo: np.ndarray,
    rf0: np.ndarray,
    gloss: np.ndarray,
    normalization: str = "bo2",
    prefilter: str = "bo2",
    env_brdf: str = "bo2",
    sky: SkyFn | None = None,
    baked: tuple[np.ndarray, np.ndarray] | None = None,
    extrapolate: bool = False,
    visibility: bool = True,
    nearest: bool = False,
) -> tuple[np.ndarray, np.ndarray]:
    """Indirect diffuse and specular radiance at N shaded points.

    points, normals, view: (N, 3) float32 world positions, unit shading normals and unit
                 directions to the eye
    albedo, rf0: (N, 3) float32;  gloss: (N,) float32
    normalization: one of ``NORMALIZATIONS``; prefilter: one of ``PREFILTERS``;
    env_brdf:    one of ``env_brdf.MODELS`` but "truth" (a quadrature per point: tools and
                 tests call ``env_brdf`` for it; "table" is its look-up)
    sky:         the fraction of the world's light that reaches the points of given indices
                 (k,) -> (k,) in [0, 1] (``sky.visibility``), or None: all of it; where the
                 reflection probes leave weight, the world's reflection takes that share of
                 it and the nearest probes the rest (``kernels.indirect.indirect``)
    baked:       (indices (K,), SH (K, 9, 3)): these points' SH is given (their lightmaps',
                 ``lightmap.as_sh``) rather than looked up in the volumes, or None
    extrapolate: volumes' light extrapolated up to their boxes' faces (``sample_sh``)
    visibility:  volumes' samples weighted by their visibility of the points (``sample_sh``)
    nearest:     where the world is hidden (``sky``), the nearest probes reflect in its place;
                 False: the world reflects wherever the probes leave weight
    returns:     (diffuse (N, 3), specular (N, 3)) float32 radiance, W/(m^2 sr)
    """
    from ..kernels import indirect as kernels

    if prefilter not in PREFILTERS:
        raise ValueError(f"unknown prefilter {prefilter!r}; expected one of: "
                         f"{', '.join(PREFILTERS)}")
    if normalization not in NORMALIZATIONS:
        raise ValueError(f"unknown normalization {normalization!r}; expected one of: "
                         f"{', '.join(NORMALIZATIONS)}")
    if env_brdf not in kernels.ENV_MODELS:
        raise ValueError(f"unknown environment BRDF {env_brdf!r} for shading; expected one of: "
                         f"{', '.join(kernels.ENV_MODELS)}")
    n = len(points)
    normals3 = np.broadcast_to(np.asarray(normals, np.float32), (n, 3))
    view3 = np.broadcast_to(np.asarray(view, np.float32), (n, 3))
    seen = np.ones(1, np.float32)
    if nearest and sky is not None and probes.reflection:  # where they leave the world weight
        seen, sky = _seen_where_left(probes, np.asarray(points), sky,
                                     None if baked is None else baked[0])
    if baked is None:
        pixel_sh = np.asarray(_pixel_sh(probes, points, normals3, view3, sky, extrapolate,
                                        visibility), np.float32)
        pixel_sh = np.ascontiguousarray(pixel_sh.reshape(-1, 9, 3) if pixel_sh.ndim == 3
                                        else pixel_sh[None])
    else:
        where, given = baked
        rest = np.setdiff1d(np.arange(n), where)
        pixel_sh = np.empty((n, 9, 3), np.float32)
        pixel_sh[where] = given
        if rest.size:
            pixel_sh[rest] = _pixel_sh(probes, np.asarray(points)[rest], normals3[rest],
                                       view3[rest], None if sky is None else
                                       (lambda k: sky(rest[k])), extrapolate, visibility)
    chains, offsets, sides, levels = packed_chains(probes, prefilter)
    shs = [p.sh for p in probes.reflection] + [probes.world_sh]
    tinted = [sh.to_tinted(np.asarray(c, np.float64)) for c in shs]
    radius_fade = np.array([[p.radius, max(max(p.falloff, 1e-4) * p.radius, 1e-6)]
                            for p in probes.reflection], np.float32).reshape(-1, 2)
    proxies = np.zeros((len(probes.reflection), 12), np.float32)
    proxy_kinds = np.zeros(len(probes.reflection), np.int64)
    for k, p in enumerate(probes.reflection):
        if p.proxy != "none" and p.proxy_to_world is not None:
            m = np.asarray(p.proxy_to_world, np.float64)
            if abs(np.linalg.det(m[:3, :3])) > 1e-12:
                proxies[k] = affine.inverse(m)[:3].reshape(-1)
                proxy_kinds[k] = kernels.PROXIES[p.proxy]

    def f32(a, shape):
        return np.require(np.broadcast_to(np.asarray(a, np.float32), shape), np.float32,
                          ["C", "W"])

    table, table_gloss, table_nv = env_table()
    diffuse = np.empty((n, 3), np.float32)
    specular = np.empty((n, 3), np.float32)
    kernels.indirect(
        f32(points, (n, 3)), f32(normals, (n, 3)), f32(view, (n, 3)), f32(albedo, (n, 3)),
        f32(rf0, (n, 3)), f32(gloss, (n,)), pixel_sh, seen, sh.BAND_FACTORS.astype(np.float32),
        chains,
        offsets, sides, levels, np.array(cubemap.FACES),
        np.array([p.position for p in probes.reflection], np.float32).reshape(-1, 3),
        radius_fade, proxies, proxy_kinds,
        np.array([np.asarray(c, np.float64)[0] + EPS for c in shs]),
        np.array([t[0] for t in tinted], np.float32), np.array([t[1] for t in tinted], np.float32),
        probes.world_color is not None,
        np.asarray(probes.world_color if probes.world_color is not None else np.zeros(3),
                   np.float32).reshape(-1)[:3].copy(),
        kernels.NORMALIZATIONS[normalization],
        np.array([EPS, MAX_NORMALIZATION, formulas_env_brdf.N_DOT_V_MIN]),
        kernels.ENV_MODELS[env_brdf], table, table_gloss, table_nv,
        np.array(formulas_env_brdf.FIT_A0 + formulas_env_brdf.FIT_A1, np.float64),
        diffuse, specular)
    return diffuse, specular


def _seen_where_left(probes: Probes, points: np.ndarray, sky: SkyFn,
                     baked: np.ndarray | None) -> tuple[np.ndarray, SkyFn]:
    """The world's seen fraction (N,) float32 for the kernel: ``sky`` of the points that the
    reflection probes' influence leaves weight to the world, 1 elsewhere and at the ``baked``
    points (the GPU's frame has no dome answer for lightmapped pixels either: they reflect the
    world there); and ``sky`` again, answering from those values where it can (each point's
    visibility is computed once)."""
    n = len(points)
    total = np.zeros(n, np.float32)
    for p in probes.reflection:
        total += p.weight(points)
    need = total < 1.0
    if baked is not None:
        need[baked] = False
    seen = np.ones(n, np.float32)
    known = np.zeros(n, bool)
    k = np.flatnonzero(need)
    if k.size:
        seen[k] = np.asarray(sky(k), np.float32)
        known[k] = True

    def cached(idx):
        idx = np.asarray(idx)
        out = seen[idx].copy()
        missing = ~known[idx]
        if missing.any():
            out[missing] = np.asarray(sky(idx[missing]), np.float32)
        return out

    return seen, cached


@functools.lru_cache(maxsize=1)
def env_table() -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The environment BRDF's table for the kernel: parts (2, G, N), gloss (G,), n.v (N,),
    float64 (the reference visibility, as ``env_brdf.table_parts``)."""
    t = formulas_env_brdf.table_arrays()
    return tuple(np.ascontiguousarray(t[name], np.float64)
                 for name in ("reference", "gloss", "n_dot_v"))
