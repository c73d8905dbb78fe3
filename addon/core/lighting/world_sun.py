"""The sun in the world: an environment's brightest region taken out as a directional light.

An HDRI that holds the sun lights a scene mostly through a few texels; projected into SH, the
prefiltered chains and the dome of shadow maps (``sky``) its energy is smeared over the sphere
and casts no sharp shadow. As EEVEE does (World > Settings > Sun: Threshold, Angle, Shadow),
the radiance above a threshold around the brightest texel is taken out of the world and becomes
one sun light (``scene.Light`` "SUN") of the given angular diameter, shaded with the talk's
BRDF and shadowed as any sun; what is left, every texel clamped to the threshold, lights the
scene as before. The sun's energy is so counted once:

    E = sum_texels  max(0, L_t - L_t min(1, T / Y_t)) dw_t        (W/m^2, per channel)
    w = normalize(sum_texels  Y_excess,t dw_t d_t),

L_t the texel's radiance (texture times strength), Y_t its luminance (Rec. 709), T the
threshold, dw_t its solid angle (``sh.equirect_solid_angles``), d_t its direction. The region
is the connected set of texels above the threshold that holds the brightest one (the equirect
wraps around in azimuth), within ``MAX_RADIUS`` of it; a second bright region is left in the
world's light. A Sky Texture's sun disc is not found here: Blender's side
renders it on its own (``blender/worlds.py``) and hands over its exact irradiance.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from ..formulas import sh, texture
from ..scene import Light, World
from ..system.cache import Cache

__all__ = ["MAX_RADIUS", "Sun", "disc_radiance", "find", "split"]

MAX_RADIUS = math.radians(15.0)  # the widest region taken as the sun, from its brightest texel
_LUMA = np.array([0.2126, 0.7152, 0.0722], np.float32)


@dataclasses.dataclass(frozen=True)
class Sun:
    """A sun found in an equirect, in the texture's own axes.

    direction:  (3,) float64 unit direction towards the sun (texture space)
    irradiance: (3,) float32 W/m^2 at normal incidence (per unit of the world's strength)
    texels:     how many texels it was taken from
    others:     share of the sun's energy above the threshold elsewhere (other regions)
    """

    direction: np.ndarray
    irradiance: np.ndarray
    texels: int
    others: float


def _region(mask: np.ndarray, seed: tuple[int, int], near: np.ndarray) -> np.ndarray:
    """(H, W) bool: the texels of ``mask`` connected to ``seed`` (8-neighbours, wrapping in
    azimuth, clamped at the poles) and within ``near``."""
    allowed = mask & near
    region = np.zeros_like(mask)
    region[seed] = True
    while True:
        grown = region.copy()
        grown[1:] |= region[:-1]
        grown[:-1] |= region[1:]
        grown |= np.roll(grown, 1, axis=1) | np.roll(grown, -1, axis=1)
        grown &= allowed
        if np.array_equal(grown, region):
            return region
        region = grown


def find(pixels: np.ndarray, threshold: float) -> tuple[Sun | None, np.ndarray]:
    """The sun of an equirect, and the equirect without it.

    pixels:    (H, W, 3) radiance, W/(m^2 sr) (Environment Texture mapping, row 0 at the top);
               non-finite texels count as 0
    threshold: T, luminance above which a texel gives its excess to the sun; <= 0 finds none
    returns:   (Sun or None when no texel exceeds T, (H, W, 3) float32 pixels with the sun's
               texels clamped to luminance T)
    """
    px = np.nan_to_num(np.asarray(pixels, np.float32)[..., :3], nan=0.0, posinf=0.0,
                       neginf=0.0)
    px = np.maximum(px, 0.0)
    if not threshold > 0.0:
        return None, px
    lum = px @ _LUMA
    mask = lum > threshold
    if not mask.any():
        return None, px
    h, w = lum.shape
    dirs = sh.equirect_directions(h, w)
    seed = np.unravel_index(int(np.argmax(lum)), lum.shape)
    near = dirs @ dirs[seed] >= math.cos(MAX_RADIUS)
    region = _region(mask, seed, near)
    scale = np.ones_like(lum)
    scale[region] = threshold / lum[region]
    clamped = px * scale[..., None]
    d_omega = np.broadcast_to(sh.equirect_solid_angles(h, w)[:, None], (h, w))
    excess = (px - clamped) * d_omega[..., None]
    irradiance = excess.sum(axis=(0, 1), dtype=np.float64)
    weights = (excess @ _LUMA).astype(np.float64)
    axis = (weights[..., None] * dirs).sum(axis=(0, 1))
    total = float(weights.sum())
    elsewhere = float(((lum - threshold) * d_omega)[mask & ~region].sum())
    sun = Sun(axis / max(np.linalg.norm(axis), 1e-30), irradiance.astype(np.float32),
              int(region.sum()), elsewhere / total if total > 0.0 else 0.0)
    return sun, clamped.astype(np.float32)


def disc_radiance(world: World, directions: np.ndarray) -> np.ndarray:
    """(N, 3) float32 radiance of the world's sun disc (``World.sun``) seen along unit
    ``directions`` (N, 3): its irradiance spread evenly over the cap of its angular diameter,
    0 outside it or without a sun. What the camera sees of the sun taken out of the texture."""
    sun = world.sun
    out = np.zeros((len(directions), 3), np.float32)
    if sun is None:
        return out
    half = max(float(sun.radius), 1e-4) / 2.0
    towards = -np.asarray(sun.direction, np.float64)
    inside = directions @ towards >= math.cos(half)
    solid = 2.0 * math.pi * (1.0 - math.cos(half))
    out[inside] = np.asarray(sun.color, np.float32) / np.float32(solid)
    return out


_suns = Cache("world suns", kept=4)  # (texture digest, threshold) -> (Sun | None, Texture)


def _found(tex: texture.Texture, threshold: float) -> tuple[Sun | None, texture.Texture]:
    def make():
        sun, clamped = find(tex.linear(0)[..., :3], threshold)
        return (sun, tex if sun is None else texture.make_texture(
            clamped, srgb=False, extension="REPEAT", interpolation="Linear",
            name=f"{tex.name} (sun taken out)"))

    return _suns.get_or_make((tex.digest, float(threshold)), make)


def split(world: World, threshold: float, angle: float, shadow: bool = True) -> World:
    """``world`` with its sun taken out of its texture and set as ``World.sun``.

    threshold: luminance of the world's radiance (texture times strength) above which light
               goes to the sun (EEVEE's World > Sun Threshold); <= 0, or a world that has a sun
               already (a Sky Texture's disc), or one without a texture: unchanged
    angle:     the sun's angular diameter, radians (World > Sun Angle)
    shadow:    whether it casts shadows

    Other regions above the threshold stay in the world's light (nothing is dropped).
    """
    if world.sun is not None or world.texture is None or not threshold > 0.0 \
            or not world.strength > 0.0:
        return world
    sun, tex = _found(world.texture, threshold / world.strength)
    if sun is None:
        return world
    towards = np.asarray(world.rotation, np.float64).T @ sun.direction
    light = Light("SUN", sun.irradiance * np.float32(world.strength),
                  direction=-towards / np.linalg.norm(towards), radius=float(angle),
                  shadow=bool(shadow), name="World sun")
    return dataclasses.replace(world, texture=tex, sun=light)
