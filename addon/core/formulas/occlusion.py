"""Contact occlusion of probe and world light: ambient occlusion from the frame's own surfaces,
and the specular occlusion of reflections derived from it.

Probe light has no occlusion finer than the probes' spacing, and the world's dome
(``sky``) none finer than its shadow maps' texels: under furniture, in corners and at contacts
the indirect light would be as bright as in the open. Ground-truth-based ambient occlusion
(GTAO; Jimenez, Wu, Pesce, Jarabo, "Practical real-time strategies for accurate indirect
occlusion", SIGGRAPH 2016 course "Physically Based Shading in Theory and Practice") finds, in
``kernels.occlusion.SLICES`` planes through the view vector, the highest horizon on each side
among the frame's surfaces within ``radius`` metres, and integrates the cosine-weighted visible
arc between them in closed form; the average over the slices is the visible fraction of the
cosine-weighted hemisphere, 1 in the open. The surfaces are the view-space positions of the
tile and a margin around it, drawn at the pixel centres (``pipeline``); surfaces hidden from
the camera are not seen, as in every screen-space method. Each pixel searches a few slices, in
angles that differ from its neighbours', and a filter averages them over 4 x 4 pixels of the
same surface (the paper's spatial distribution and bilateral filter); every shaded point of a
pixel takes its pixel's value.

Indirect diffuse is multiplied by the occlusion with the light that bounces between the
occluding surfaces put back (the paper's multi-bounce fit, ``multi_bounce``: a white corner is
darkened less than a black one); indirect specular by the specular occlusion of
Lagarde and de Rousiers ("Moving Frostbite to physically based rendering 3.0", SIGGRAPH 2014
course, section 4.10.2), saturate((n.v + ao)^(2^(-16 r - 1)) - 1 + ao), r the perceptual
roughness of the talk's gloss (``roughness``).
"""

from __future__ import annotations

import numpy as np

__all__ = ["REACH", "ambient", "multi_bounce", "roughness", "specular"]

REACH = 64  # pixels: the widest search, and the margin drawn around a tile for it
BLUR = 2  # pixels: the filter's reach beyond the tile (``kernels.occlusion.blur``)
# how far from a pixel's tangent plane a neighbour of the filter may lie: pixel footprints
_PLANE = 2.0


def ambient(depth: np.ndarray, normals: np.ndarray, rec: np.ndarray, origin: tuple[int, int],
            radius: float, scale: float, orthographic: bool, reach: float = REACH) -> np.ndarray:
    """(h, w) float32 ambient occlusion in [0, 1] (1: open) of a tile's pixels, filtered.

    depth:   (H, W) float32 view-space z at the pixel centres of the tile grown by ``REACH``
             pixels, NaN where nothing was drawn (camera looking along -z, y up)
    normals: (h + 2 BLUR, w + 2 BLUR, 3) float32 unit view-space normals of the tile grown by
             ``BLUR`` pixels, either side
    rec:     (8,) float64 view-space x, y of a buffer pixel from its depth
             (``kernels.occlusion.gtao``)
    origin:  the buffer's origin (x, y) in the frame, pixels
    radius:  metres; scale: pixels per metre at depth 1 (perspective) or anywhere (ortho)
    reach:   the widest search, pixels (the buffer's margin)
    """
    from ..kernels import occlusion as kernels

    h, w = normals.shape[0] - 2 * BLUR, normals.shape[1] - 2 * BLUR
    at = REACH - BLUR
    depth = np.require(depth, np.float32, ["C"])
    normals = np.require(normals, np.float32, ["C"])
    rec = np.ascontiguousarray(rec, np.float64)
    raw = np.empty(normals.shape[:2], np.float32)
    kernels.gtao(depth, normals, at, at, rec,
                 np.array([radius, scale, float(orthographic), reach], np.float64),
                 int(origin[0]), int(origin[1]), raw)
    out = np.empty((h, w), np.float32)
    kernels.blur(raw, depth, normals, at, at, rec, _PLANE / scale, out)
    return out


def multi_bounce(ao: np.ndarray, albedo: np.ndarray) -> np.ndarray:
    """(N, 3) float32 occlusion with the light that bounces between the occluding surfaces
    put back: Jimenez et al. 2016's cubic fit in the occlusion, per albedo (N, 3),
    max(ao, ((a ao + b) ao + c) ao), a = 2.0404 rho - 0.3324, b = -4.7951 rho + 0.6417,
    c = 2.7552 rho + 0.6903 (1 stays 1)."""
    x = np.asarray(ao, np.float32)[:, None]
    rho = np.asarray(albedo, np.float32)
    a, b, c = 2.0404 * rho - 0.3324, -4.7951 * rho + 0.6417, 2.7552 * rho + 0.6903
    return np.maximum(x, ((x * a + b) * x + c) * x).astype(np.float32)


def roughness(gloss: np.ndarray) -> np.ndarray:
    """Perceptual roughness of the talk's gloss: the Blinn-Phong exponent 8192^gloss (slide
    "Black Ops: gloss") as the Beckmann slope m = sqrt(2 / (alpha + 2)), whose square root is
    the perceptual roughness."""
    alpha = np.power(8192.0, np.asarray(gloss, np.float64))
    return np.power(2.0 / (alpha + 2.0), 0.25).astype(np.float32)


def specular(ao: np.ndarray, n_dot_v: np.ndarray, gloss: np.ndarray) -> np.ndarray:
    """(N,) float32 specular occlusion of points of ambient occlusion ``ao``, n.v and gloss
    (N,) (Lagarde and de Rousiers 2014)."""
    ao = np.asarray(ao, np.float64)
    nv = np.clip(np.asarray(n_dot_v, np.float64), 0.0, 1.0)
    power = np.exp2(-16.0 * roughness(gloss) - 1.0)
    return np.clip(np.power(nv + ao, power) - 1.0 + ao, 0.0, 1.0).astype(np.float32)
