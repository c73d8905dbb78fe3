"""The contact-occlusion stage: the ambient occlusion of a tile's pixels from the depth and
normals drawn around it (``occlusion.ambient``, Jimenez et al. 2016).
"""

from __future__ import annotations

import numpy as np

from ..formulas import affine, occlusion
from .buffers import Frame
from .visibility import draw_samples, tile_clip


def tile_ambient(frame: Frame, tile) -> np.ndarray:
    """(h, w) float32 ambient occlusion of a tile's pixels (``occlusion.ambient``), from the
    surfaces drawn at the pixel centres of the tile grown by ``occlusion.REACH`` pixels."""
    cam, s = frame.scene.camera, frame.scene.settings
    x0, y0, x1, y1 = tile
    m, b = occlusion.REACH, occlusion.BLUR
    gw, gh = x1 - x0 + 2 * m, y1 - y0 + 2 * m
    clip, index = tile_clip(frame.clip, cam.width, cam.height, (x0 - m, y0 - m, x1 + m, y1 + m))
    cull = None if frame.cull is None else frame.cull[index]
    proj = np.asarray(cam.projection, np.float64)
    frags = draw_samples(cam, clip, gw, gh, cull, [(0.5, 0.5)])[0]
    tri = frags.tri
    if len(index):
        tri = np.where(tri >= 0, index.take(np.maximum(tri, 0), mode="clip"), -1)
    if frame.holdout.any():  # holdout objects are holes, not occluders
        tri = np.where((tri >= 0) & frame.holdout[np.maximum(tri, 0)], -1, tri)
    w2c = np.asarray(cam.world_to_camera, np.float64)
    hit = tri >= 0
    depth = np.full((gh, gw), np.nan, np.float32)
    if cam.orthographic:
        world = np.einsum("nk,nkc->nc", frags.bary[hit], frame.positions[tri[hit]])
        depth[hit] = affine.transform(world, w2c)[:, 2]
    else:
        depth[hit] = -frags.depth[hit]
    # the view-space x, y of a buffer pixel from its depth z (the projection undone)
    ux, vx = 2.0 / cam.width, 2.0 * (x0 - m + 0.5) / cam.width - 1.0
    uy, vy = -2.0 / cam.height, 1.0 - 2.0 * (y0 - m + 0.5) / cam.height
    p32, p33 = proj[3, 2], proj[3, 3]
    rec = np.array([p32 * ux / proj[0, 0], (p32 * vx - proj[0, 2]) / proj[0, 0],
                    p33 * ux / proj[0, 0], (p33 * vx - proj[0, 3]) / proj[0, 0],
                    p32 * uy / proj[1, 1], (p32 * vy - proj[1, 2]) / proj[1, 1],
                    p33 * uy / proj[1, 1], (p33 * vy - proj[1, 3]) / proj[1, 1]])
    # the normals of the tile grown by the filter's reach, in view space
    inner = (slice(m - b, gh - m + b), slice(m - b, gw - m + b))
    on = hit[inner]
    n = affine.linear(np.einsum("nk,nkc->nc", frags.bary[inner][on],
                                frame.normals[tri[inner][on]]), w2c[:3, :3])
    normals = np.zeros((*on.shape, 3), np.float32)
    normals[on] = n / np.maximum(np.linalg.norm(n, axis=1, keepdims=True), 1e-12)
    scale = 0.5 * proj[1, 1] * cam.height  # pixels per metre (at depth 1: perspective)
    return occlusion.ambient(depth, normals, rec, (x0 - m, y0 - m), s.ao_distance, scale,
                             cam.orthographic)
