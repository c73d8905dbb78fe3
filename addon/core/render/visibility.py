"""What each sample sees: sample positions drawn from the pixel filter, tiles, the triangles
that may touch a tile, the raster of a tile's samples and stochastic transparency.

- Anti-aliasing as Cycles does it: every sample position is drawn from the pixel filter
  (Blackman-Harris of width 1.5 px by default, whose window Cycles spreads over twice the width;
  filter importance sampling, Ernst et al. 2006) and contributes to its own pixel only, so a
  plain average of the samples is the filtered pixel. Sample positions follow the R2
  low-discrepancy sequence (Roberts 2018) mapped through the filter's inverse CDF,
  independently in x and y as in Cycles' filter table.
- Tiles: the frame is cut into square tiles; each tile is rasterized with a projection that maps
  the tile to the whole viewport, so memory depends on the tile size, not the resolution.
"""

from __future__ import annotations

import numpy as np

from ..formulas import affine
from ..scene import Scene
from . import projection, raster, transparency
from .buffers import Frame
from .surfaces import face_normals, surface_alpha


def _blackman_harris(x: np.ndarray, width: float) -> np.ndarray:
    """Blackman-Harris window over [-width/2, width/2] (the form Cycles' filter table uses)."""
    t = 2.0 * np.pi * (x / width + 0.5)
    return 0.35875 - 0.48829 * np.cos(t) + 0.14128 * np.cos(2 * t) - 0.01168 * np.cos(3 * t)


def sample_offsets(count: int, filter_width: float = 1.5) -> np.ndarray:
    """(count, 2) float64 sample positions relative to the pixel's top-left corner.

    Distributed as Cycles' Blackman-Harris pixel filter of ``filter_width`` pixels centred on
    the pixel. Cycles evaluates that window over twice the width (so the samples reach
    0.5 - width .. 0.5 + width); rendering a hard edge in both engines confirms it
    (tests/blender). A single sample sits at the centre.
    """
    if count == 1:
        return np.array([[0.5, 0.5]])
    g = 1.32471795724474602596  # plastic number: root of x^3 = x + 1
    u = (0.5 + np.array([1.0 / g, 1.0 / (g * g)]) * np.arange(count)[:, None]) % 1.0
    if filter_width <= 0.01:
        return np.full((count, 2), 0.5)
    support = 2.0 * filter_width  # Cycles widens the Blackman-Harris window to twice the width
    xs = np.linspace(-support / 2, support / 2, 1025)
    cdf = np.concatenate([[0.0], np.cumsum(0.5 * (_blackman_harris(xs[1:], support)
                                                  + _blackman_harris(xs[:-1], support)))])
    cdf /= cdf[-1]
    return 0.5 + np.interp(u, cdf, xs)


def tiles(scene: Scene, rows: int = 0) -> list[tuple[int, int, int, int]]:
    """(x0, y0, x1, y1) tiles covering the render border (or the frame), top-left origin;
    when ``rows`` is given, at most that many rows tall (a rolling shutter's bands,
    ``motion_blur.band_rows``) and as wide as holds a tile's pixels."""
    cam, st = scene.camera, scene.settings
    bx0, by0, bx1, by1 = st.border or (0, 0, cam.width, cam.height)
    size = max(16, int(st.tile_size))
    tall = min(size, rows) if rows > 0 else size
    wide = max(size, size * size // tall)
    return [(x, y, min(x + wide, bx1), min(y + tall, by1))
            for y in range(by0, by1, tall) for x in range(bx0, bx1, wide)]


def tile_matrix(width: int, height: int, tile) -> np.ndarray:
    """(4, 4) float64: the frame's clip coordinates to those in which ``tile`` (x0, y0, x1,
    y1) fills the viewport (``tile_clip``)."""
    x0, y0, x1, y1 = tile
    tw, th = x1 - x0, y1 - y0
    m = np.eye(4)
    m[0, 0], m[0, 3] = width / tw, (width - 2.0 * x0) / tw - 1.0
    m[1, 1], m[1, 3] = height / th, 1.0 - height / th + 2.0 * y0 / th
    return m


def reprojected(clip, matrix: np.ndarray):
    """``clip`` (K, 3, 4) float32, or its ``projection.Projection``, times the clip-space
    ``matrix`` (4, 4) (a lens point's, ``depth_of_field.clip_transform``)."""
    if isinstance(clip, projection.Projection):
        return projection.Projection(clip.positions, matrix @ clip.matrix, clip.dtype,
                                     clip.index)
    return np.ascontiguousarray(clip @ matrix.T.astype(np.float32), np.float32)


def tile_clip(clip: np.ndarray, width: int, height: int, tile) -> tuple[np.ndarray, np.ndarray]:
    """Clip coordinates re-projected so that ``tile`` fills the viewport, of the triangles that
    may touch it (the others lie wholly beyond one plane of its frustum).

    clip: (T, 3, 4) float32 of the whole frame (``Frame.clip``), or its ``projection.Projection``
    returns: (K, 3, 4) float32 clip coordinates and (K,) int64 indices into ``clip``, increasing
             (for a Projection of more triangles than a raster sets up at once: the Projection
             of the tile's triangles, and their indices; a smaller one is projected and culled
             in one pass, ``kernels.raster.project_survivors``)
    """
    from ..kernels import raster as kernels

    x0, y0, x1, y1 = tile
    tw, th = x1 - x0, y1 - y0
    ax, bx = np.float32(width / tw), np.float32((width - 2.0 * x0) / tw - 1.0)
    ay, by = np.float32(height / th), np.float32(1.0 - height / th + 2.0 * y0 / th)
    if isinstance(clip, projection.Projection) and len(clip.positions) <= raster.SETUP_TRIANGLES:
        # a view drawn as one tile (``with_camera``'s ``once``): projected and culled at once
        seen = np.zeros(0, bool)
        if clip.index is not None:
            seen = np.zeros(len(clip.positions), bool)
            seen[clip.index] = True
        out = np.empty((len(clip.positions), 3, 4), np.float32)
        index = np.empty(len(clip.positions), np.int64)
        count = kernels.project_survivors(np.ascontiguousarray(clip.positions, np.float32),
                                          np.ascontiguousarray(clip.matrix, np.float64), seen,
                                          ax, bx, ay, by, out, index)
        return out[:count], index[:count]
    if isinstance(clip, projection.Projection):  # re-projected a chunk at a time when drawn
        tile = projection.Projection(clip.positions, tile_matrix(width, height, tile)
                                     @ clip.matrix, clip.dtype, clip.index).survivors()
        return tile, tile.index
    clip = np.ascontiguousarray(clip, np.float32)
    out = np.empty_like(clip)
    index = np.empty(len(clip), np.int64)
    count = kernels.tile_survivors(clip, ax, bx, ay, by, out, index)
    return out[:count], index[:count]


def nearest_faces(frame: Frame) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """What the camera of ``frame`` sees first at each pixel centre (no shading): the
    triangle (H W,) int32, -1 where none, its view depth (H W,) float32 (``raster``), and the
    unnormalized front-face normals (M, 3) of the M pixels that see one, row-major."""
    cam = frame.scene.camera
    tile = (0, 0, cam.width, cam.height)
    tri, _, depth, *_ = sample_raster(frame, tile, tile_margin(frame, tile), (0.5, 0.5))
    return tri, depth, face_normals(frame, tri[tri >= 0])


def tile_margin(frame: Frame, tile):
    """The tile grown by the filter's reach (samples drawn from the pixel filter land up to its
    width beyond their pixel, so triangles next to the tile must not be rejected) and by the
    lens's and the shutter's (``Frame.lens_reach``, ``motion_reach``): the margin m, pixels,
    ``tile_clip`` of the grown tile with the culling flags of its triangles, and the raster's
    ``keep`` dict (None unless the frame keeps its tiles: ``Frame.tiles``)."""
    cam = frame.scene.camera
    x0, y0, x1, y1 = tile
    m = int(np.ceil(frame.scene.settings.filter_width)) + frame.lens_reach + frame.motion_reach
    key = (tuple(tile), m)
    if frame.tiles is not None and key in frame.tiles:
        return frame.tiles[key]
    clip, index = tile_clip(frame.clip, cam.width, cam.height, (x0 - m, y0 - m, x1 + m, y1 + m))
    cull = None if frame.cull is None else frame.cull[index]
    margin = (m, clip, index, cull, None if frame.tiles is None else {})
    if frame.tiles is not None:
        frame.tiles[key] = margin
    return margin


def draw_samples(cam, clip, width: int, height: int, cull, offsets, keep=None, keys: bool = False,
          behind=None) -> list[raster.Fragments]:
    """The camera ``cam``'s clip coordinates rasterized at each sample offset of ``offsets``
    (S, 2): for a perspective camera, when the raster's ``keys`` are not wanted nor the layer
    ``behind`` them (depth peeling), by ``raster.nearest`` (no set-up), else by
    ``raster.rasterize`` sample by sample (its set-up in ``keep``, or kept for the last
    input)."""
    proj = np.asarray(cam.projection, np.float64)
    plane = None if cam.orthographic else (proj[2, 2], proj[2, 3])
    if plane is not None and not keys and behind is None and isinstance(clip, np.ndarray):
        return raster.nearest(clip, width, height, cull=cull, sample_offsets=offsets,
                              depth_plane=plane)
    return [raster.rasterize(clip, width, height, cull=cull, sample_offset=tuple(offset),
                             behind=behind, keep=keep, depth_plane=plane)
            for offset in offsets]


def sample_raster(frame: Frame, tile, margin, offset, behind=None, frags=None):
    """One sample position over one tile (``margin``: ``tile_margin`` of the tile): (tri, bary,
    depth) per pixel, flattened, the sample's window coordinates sx, sy (npx,) in the whole
    frame, and the raster's keys (``raster.rasterize``; with ``behind``, the next layer).
    ``frags``: the tile's fragments at this sample when drawn already (``draw_samples``)."""
    cam = frame.scene.camera
    x0, y0, x1, y1 = tile
    tw, th = x1 - x0, y1 - y0
    m, clip, index, cull, keep = margin
    if frags is None:
        frags = draw_samples(cam, clip, tw + 2 * m, th + 2 * m, cull, [offset], keep,
                      frame.fades.any(), behind)[0]
    inner = (slice(m, m + th), slice(m, m + tw))
    tri = np.ascontiguousarray(frags.tri[inner]).reshape(-1)
    if len(index):  # the subset's triangles -> the frame's
        tri = np.where(tri >= 0, index.take(tri, mode="clip"), -1).astype(np.int32)
    bary = frags.bary[inner].reshape(-1, 3)
    depth = frags.depth[inner].reshape(-1)
    if cam.orthographic:  # clip w is 1: the view-axis distance comes from the corners' view z
        hit = np.flatnonzero(tri >= 0)
        row = np.asarray(cam.world_to_camera, np.float64)[2]
        z = affine.linear(frame.positions[tri[hit]], row[None, :3])[..., 0] + np.float32(row[3])
        depth = depth.copy()
        depth[hit] = -np.einsum("nk,nk->n", bary[hit], z)
    rows, cols = np.divmod(np.arange(tw * th), tw)
    return tri, bary, depth, x0 + cols + offset[0], y0 + rows + offset[1], frags.keys


def _peeling(frame: Frame, tile, margin, offset, sample: int, layer0):
    """What ``transparency.dither`` and ``blend`` peel one sample's layers with: each pixel's
    index in the raster's keys, and the functions alpha, thresholds and next_layer."""
    sx, sy = layer0[3], layer0[4]
    x0, y0, x1, y1 = tile
    m = margin[0]
    tw = x1 - x0
    rows, cols = np.divmod(np.arange(len(sx)), tw)

    def alpha(pixels, t, b):
        return surface_alpha(frame, t, b, sx[pixels], sy[pixels])

    def next_layer(floor):
        t, b, d, _, _, k = sample_raster(frame, tile, margin, offset, behind=floor)
        return t, b, d, k

    def thresholds(pixels, layer):
        return transparency.dither_thresholds(x0 + cols[pixels], y0 + rows[pixels], sample, layer)

    return (rows + m) * (tw + 2 * m) + cols + m, alpha, thresholds, next_layer


def dither_sample(frame: Frame, tile, margin, offset, sample: int, layer0):
    """Stochastic transparency of one sample (Blender's "Dithered" render method,
    ``transparency.dither``): over the samples a pixel is covered by a fraction alpha of each
    surface. layer0: ``sample_raster``'s result, updated."""
    tri, bary, depth, sx, sy, keys = layer0
    at, alpha, thresholds, next_layer = _peeling(frame, tile, margin, offset, sample, layer0)
    transparency.dither((tri, bary, depth, keys), at, frame.dithers, alpha, thresholds,
                        next_layer)
    return tri, bary, depth, sx, sy


def blend_sample(frame: Frame, tile, margin, offset, sample: int, layer0, start):
    """Blended transparency of one sample (``transparency.blend``) behind the pixels
    ``start`` (their surfaces are blended). layer0: ``sample_raster``'s result after
    ``dither_sample``, not changed. Returns ``transparency.blend``'s result."""
    tri, bary, depth, _, _, keys = layer0
    at, alpha, thresholds, next_layer = _peeling(frame, tile, margin, offset, sample, layer0)
    return transparency.blend((tri, bary, depth, keys), at, start, frame.blends, frame.dithers,
                              alpha, thresholds, next_layer, rank=frame.blend_rank,
                              solo=frame.blend_solo)
