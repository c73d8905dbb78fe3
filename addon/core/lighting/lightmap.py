"""Lightmaps: the talk's diffuse indirect light of static surfaces, baked per object.

The talk takes diffuse indirect light from "lightmaps, light probes" (slide "Lighting model:
indirect diffuse"), and the BO2 normalization multiplies the reflections by the pixel's
irradiance (slide "Improved normalization algorithm"): for a lightmapped surface that is the
lightmap's. A lightmap holds, per texel of the object's lightmap UV layout, the irradiance
(W/m^2) that reaches the surface from everything but the lights' direct light: the world (as
far as the texel sees it), emission, and the light the scene bounces.

- Layout (``layout``): the object's own lightmap UV map, or charts made here: faces joined
  across shared edges while their normals stay within ``CHART_ANGLE`` of the chart's first
  face, each chart projected on the plane of its mean normal and turned to its smallest box,
  packed in rows at a density in texels per metre with padding between charts.
- Texels (``kernels.lightmap.texels``): each texel's point on the surface.
- Light (``lightmap_bake``): the direct light of the scene's lights at every texel (shadows ray
  traced, soft over the light's size), then ``bounces`` gathers: every texel shoots cosine-
  distributed rays through a BVH of the scene (``kernels.lightmap.gather``), and a ray brings
  the radiance of what it meets: a lightmapped surface's radiance from the previous gather
  (emission + albedo / pi (direct + indirect irradiance), read by its lightmap UV), an object
  without a lightmap's (lit by the probes), or the world's. The first gather sees direct light,
  emission and the world; each further one adds a bounce. The gathers before the last take a
  quarter of the rays, and are filtered before they are gathered again; the last gathers the
  irradiance of every bounce, the ones not gathered estimated as the geometric series that the
  last increments continue (a progressive radiosity's ambient term, Cohen et al. 1988). Rays
  leave the surface by an offset that follows the float precision of the triangle's
  coordinates (``lightmap_bake.ray_offset``), not the scene's size.
- Directional lightmaps (beyond the talk): the L1 SH of the incoming radiance per texel (as
  Bakery's SH mode and Godot's directional lightmaps), its constant term set so that the
  irradiance at the texel's normal is the gathered one: a normal map keeps its relief.
- Clean-up: an edge-avoiding a-trous filter within each chart (guided by position, normal
  and the estimate's variance, ``denoise``), seams stitched across chart edges (``stitch``),
  charts dilated into their padding (``dilate``), so bilinear look-ups never read an empty
  texel.

References
----------
- D. Lazarov, "Getting More Physical in Call of Duty: Black Ops II", SIGGRAPH 2013.
- T. Moeller, B. Trumbore, "Fast, minimum storage ray-triangle intersection", JGT 1997.
- P.-P. Sloan, "Stupid Spherical Harmonics (SH) Tricks", GDC 2008 (L1 SH irradiance).
- M. Cohen, S. Chen, J. Wallace, D. Greenberg, "A progressive refinement approach to fast
  radiosity image generation", SIGGRAPH 1988 (the ambient term).
"""

from __future__ import annotations

import os
from dataclasses import dataclass

import numpy as np

__all__ = ["CHART_ANGLE", "Lightmap", "LightmapError", "Settings", "Target", "as_sh", "denoise",
           "denoise_steps", "dilate", "layout", "memory_bytes", "overlaps", "sample",
           "seam_jumps", "seams", "size_for", "stitch", "uv_islands"]

CHART_ANGLE = 45.0  # degrees: a face joins a chart while its normal is within this of the seed's
SH_SCALE_C0 = 0.5 / np.sqrt(np.pi)
SH_SCALE_C1 = np.sqrt(3.0 / (4.0 * np.pi))


class LightmapError(Exception):
    """A lightmap that cannot be made or used; one line for the user."""


@dataclass(frozen=True)
class Settings:
    """How lightmaps are baked.

    texels_per_metre: density of generated layouts (an object may ask for its own)
    max_resolution:   no lightmap is larger than this many texels on a side (the density is
                      lowered to fit)
    padding:          texels between charts
    rays:             rays per texel of the last gather (the ones before it: a quarter)
    bounces:          gathers (1: direct light, emission and the world seen once); from 3
                      on, the last gather sees the bounces after them too, estimated as the
                      geometric series their last increments continue
    directional:      store the L1 SH of the incoming light (4 x RGB) instead of irradiance
    denoise:          the edge-avoiding filter within charts (``denoise``)
    memory_cap:       bytes the lightmaps of one scene may take in a frame
    """

    texels_per_metre: float = 20.0
    max_resolution: int = 1024
    padding: int = 2
    rays: int = 256
    bounces: int = 4
    directional: bool = False
    denoise: bool = True
    memory_cap: int = 1 << 30


@dataclass
class Lightmap:
    """One object's baked lightmap, as the renderer reads it.

    image: (H, W, 3) float32 irradiance, W/m^2, or (H, W, 12) the L1 SH of the radiance
           (coefficients Y00, Y1-1, Y10, Y11, each RGB), row 0 at v = 1
    uvs:   (T, 3, 2) float32 the lightmap UVs of the object's triangles, in [0, 1]
    """

    image: np.ndarray
    uvs: np.ndarray

    @property
    def directional(self) -> bool:
        return self.image.shape[2] == 12


@dataclass
class Target:
    """One object to bake: ``mesh`` indexes ``Scene.meshes``; its layout ``uvs`` (T, 3, 2)
    float32 and size in texels (``layout``)."""

    name: str
    mesh: int
    uvs: np.ndarray
    width: int
    height: int


def memory_bytes(width: int, height: int, directional: bool) -> int:
    """Bytes of one lightmap's image in a frame (float32)."""
    return int(width) * int(height) * (12 if directional else 3) * 4


# ---------------------------------------------------------------------------------------------
# Layout


def _weld(positions: np.ndarray) -> np.ndarray:
    """(T, 3) vertex ids of corners ``positions`` (T, 3, 3): corners within 1e-6 of the
    object's size share an id."""
    flat = np.nan_to_num(positions.reshape(-1, 3).astype(np.float64), posinf=0.0, neginf=0.0)
    size = float(np.ptp(flat, axis=0).max()) if len(flat) else 1.0
    q = np.round(flat / max(size * 1e-6, 1e-9)).astype(np.int64)
    _, ids = np.unique(q, axis=0, return_inverse=True)
    return ids.reshape(-1, 3)


def _edges(ids: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Pairs of triangles sharing an edge (E, 2) and the edge's two vertex ids (E, 2) in the
    first triangle's order; an edge of more than two faces joins none."""
    t = len(ids)
    a = ids[:, [0, 1, 2]].reshape(-1)
    b = ids[:, [1, 2, 0]].reshape(-1)
    key = np.stack([np.minimum(a, b), np.maximum(a, b)], 1)
    order = np.lexsort((key[:, 1], key[:, 0]))
    key = key[order]
    same = (key[1:] == key[:-1]).all(1)
    start = np.flatnonzero(np.concatenate([[True], ~same]))
    count = np.diff(np.concatenate([start, [len(key)]]))
    two = start[count == 2]
    first, second = order[two], order[two + 1]
    faces = np.stack([first // 3, second // 3], 1)
    verts = np.stack([a[first], b[first]], 1)
    keep = faces[:, 0] != faces[:, 1]
    del t
    return faces[keep], verts[keep]


def _charts(positions: np.ndarray) -> np.ndarray:
    """(T,) chart id of each triangle (``CHART_ANGLE``)."""
    n = len(positions)
    cross = np.cross(positions[:, 1] - positions[:, 0], positions[:, 2] - positions[:, 0])
    area = np.linalg.norm(cross, axis=1)
    normal = cross / np.maximum(area, 1e-30)[:, None]
    pairs, _ = _edges(_weld(positions))
    neighbours = [[] for _ in range(n)]
    for a, b in pairs.tolist():
        neighbours[a].append(b)
        neighbours[b].append(a)
    chart = np.full(n, -1, np.int64)
    limit = np.cos(np.radians(CHART_ANGLE))
    count = 0
    for seed in np.argsort(-area, kind="stable"):
        if chart[seed] >= 0:
            continue
        chart[seed] = count
        axis = normal[seed]
        todo = [int(seed)]
        while todo:
            f = todo.pop()
            for g in neighbours[f]:
                if chart[g] < 0 and float(normal[g] @ axis) >= limit:
                    chart[g] = count
                    todo.append(g)
        count += 1
    return chart


def _flatten(positions: np.ndarray, chart: np.ndarray) -> np.ndarray:
    """(T, 3, 2) float64 metres: each chart projected on the plane of its mean normal, turned
    to its smallest box (whose side lies along one of its longest edges) and scaled to keep
    its surface's area."""
    out = np.zeros((len(positions), 3, 2))
    cross = np.cross(positions[:, 1] - positions[:, 0], positions[:, 2] - positions[:, 0])
    order = np.argsort(chart, kind="stable")
    bounds = np.flatnonzero(np.diff(np.concatenate([[-1], chart[order], [-2]])))
    for lo, hi in zip(bounds[:-1], bounds[1:], strict=True):
        faces = order[lo:hi]
        n = cross[faces].sum(0)
        length = np.linalg.norm(n)
        n = n / length if length > 0.0 else np.array([0.0, 0.0, 1.0])  # no area: any plane
        t = np.cross(n, [0.0, 0.0, 1.0] if abs(n[2]) < 0.9 else [1.0, 0.0, 0.0])
        t /= np.linalg.norm(t)
        b = np.cross(n, t)
        q = positions[faces].astype(np.float64)
        flat = np.stack([q @ t, q @ b], -1)
        pts = flat.reshape(-1, 2)
        centred = pts - pts.mean(0)
        # the smallest box has a side along an edge of the hull: try the longest edges' angles
        edge = (flat[:, [1, 2, 0]] - flat).reshape(-1, 2)
        length = np.hypot(edge[:, 0], edge[:, 1])
        longest = np.argpartition(-length, 32)[:32] if len(length) > 32 else np.arange(len(length))
        angle = np.arctan2(edge[longest, 1], edge[longest, 0])
        axes = np.stack([np.cos(angle), np.sin(angle)])  # (2, A): the box's first axis
        u, v = centred @ axes, centred @ np.stack([-axes[1], axes[0]])
        best = int(np.argmin(np.ptp(u, axis=0) * np.ptp(v, axis=0)))
        chart_uv = np.stack([u[:, best], v[:, best]], -1).reshape(-1, 3, 2)
        # a curved chart's projection is smaller than its surface: scaled to the same area
        e1, e2 = chart_uv[:, 1] - chart_uv[:, 0], chart_uv[:, 2] - chart_uv[:, 0]
        flat_area = 0.5 * np.abs(e1[:, 0] * e2[:, 1] - e1[:, 1] * e2[:, 0]).sum()
        surface = 0.5 * np.linalg.norm(cross[faces], axis=1).sum()
        out[faces] = chart_uv * np.sqrt(surface / flat_area) if flat_area > 0.0 else chart_uv
    return out


def _pack(flat: np.ndarray, chart: np.ndarray, density: float, padding: int
          ) -> tuple[np.ndarray, int, int]:
    """Charts (metres, ``_flatten``) at ``density`` texels per metre placed in rows, tallest
    first: (T, 3, 2) texel coordinates (x right, y down) and the atlas's width, height."""
    count = int(chart.max()) + 1 if len(chart) else 0
    texel = flat * density
    lo = np.full((count, 2), np.inf)
    hi = np.full((count, 2), -np.inf)
    np.minimum.at(lo, chart, texel.min(1))
    np.maximum.at(hi, chart, texel.max(1))
    size = np.ceil(hi - lo).astype(np.int64) + 1  # the texels a chart touches, at most
    cell = size + padding
    area = float((cell[:, 0] * cell[:, 1]).sum())
    width = max(int(np.ceil(np.sqrt(area) * 1.05)), int(cell[:, 0].max(initial=1)) + padding)
    order = np.argsort(-cell[:, 1], kind="stable")
    place = np.zeros((count, 2), np.int64)
    x = y = padding
    row = 0
    for c in order:
        if x + cell[c, 0] > width:
            x, y, row = padding, y + row, 0
        place[c] = (x, y)
        x += cell[c, 0]
        row = max(row, cell[c, 1])
    height = y + row
    # 0.3: no chart edge on the texel centres of an integer-sized chart
    out = texel - lo[chart][:, None, :] + place[chart][:, None, :] + 0.3
    return out, int(width), int(max(height, 1))


def layout(positions: np.ndarray, texels_per_metre: float, padding: int = 2,
           max_resolution: int = 1024) -> tuple[np.ndarray, int, int, float]:
    """A lightmap UV layout of an object's triangles ``positions`` (T, 3, 3), metres.

    returns: (uvs (T, 3, 2) float32 in [0, 1] with v up, width, height in texels, the density
             used, texels per metre: ``texels_per_metre`` or less to fit ``max_resolution``)
    """
    positions = np.asarray(positions, np.float64)
    if not len(positions):
        raise LightmapError("no triangles to lay out")
    chart = _charts(positions)
    flat = _flatten(positions, chart)
    density = float(texels_per_metre)
    if not density > 0.0:
        raise LightmapError(f"texels per metre must be positive, not {texels_per_metre}")
    for _ in range(40):
        texel, width, height = _pack(flat, chart, density, padding)
        if max(width, height) <= max_resolution:
            break
        density *= 0.97 * max_resolution / max(width, height)
    else:
        raise LightmapError(f"{len(np.unique(chart))} charts do not fit in "
                            f"{max_resolution} x {max_resolution} texels")
    uv = np.empty_like(texel)
    uv[..., 0] = texel[..., 0] / width
    uv[..., 1] = 1.0 - texel[..., 1] / height
    return uv.astype(np.float32), width, height, density


def size_for(uvs: np.ndarray, positions: np.ndarray, texels_per_metre: float,
             max_resolution: int) -> tuple[int, int]:
    """The square texel size of an artist's lightmap UV map (``uvs`` (T, 3, 2)) that gives
    ``texels_per_metre`` on average over the surface, at most ``max_resolution``."""
    p = np.asarray(positions, np.float64)
    q = np.asarray(uvs, np.float64)
    area3 = 0.5 * np.linalg.norm(np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0]), axis=1).sum()
    e1, e2 = q[:, 1] - q[:, 0], q[:, 2] - q[:, 0]
    area2 = 0.5 * np.abs(e1[:, 0] * e2[:, 1] - e1[:, 1] * e2[:, 0]).sum()
    side = texels_per_metre * np.sqrt(area3 / max(area2, 1e-12))
    side = int(np.clip(np.ceil(side / 4.0) * 4, 4, max_resolution))
    return side, side


def overlaps(uvs: np.ndarray, width: int, height: int) -> int:
    """Texel centres covered by more than one triangle of the layout ``uvs`` (T, 3, 2)."""
    from ..kernels import lightmap as kernels

    count = np.zeros(width * height, np.int32)
    kernels.coverage(np.ascontiguousarray(uvs, np.float32), width, height, count)
    return int((count > 1).sum())


# ---------------------------------------------------------------------------------------------
# Image clean-up


def dilate(image: np.ndarray, valid: np.ndarray, passes: int = 16) -> np.ndarray:
    """``image`` (H, W, C) with the texels outside ``valid`` (H, W) filled by the mean of
    their valid neighbours (8-connected), ``passes`` times outwards
    (``kernels.lightmap.dilate_pass``); the rest stay 0. (H, W, C) float32."""
    from ..kernels import lightmap as kernels

    out = np.ascontiguousarray(np.where(valid[..., None], image, 0.0), np.float32)
    have = np.array(valid, bool)  # a copy: the passes write into it
    spare, spare_have = np.empty_like(out), np.empty_like(have)
    for _ in range(passes):
        if not kernels.dilate_pass(out, have, spare, spare_have):
            break
        out, spare, have, spare_have = spare, out, spare_have, have
    return out


def denoise(image: np.ndarray, chart: np.ndarray, position: np.ndarray, normal: np.ndarray,
            variance: np.ndarray, texel: float, levels: int = 3, sigma_normal: float = 0.1,
            sigma_luminance: float = 4.0) -> np.ndarray:
    """``denoise_steps`` run to its end: the filtered (H, W, C) float32 image."""
    steps = denoise_steps(image, chart, position, normal, variance, texel, levels,
                          sigma_normal, sigma_luminance)
    while True:
        try:
            next(steps)
        except StopIteration as done:
            return done.value


BAND = 1 << 18  # texels of the rows filtered between two progress steps of ``denoise_steps``


def denoise_steps(image: np.ndarray, chart: np.ndarray, position: np.ndarray,
                  normal: np.ndarray, variance: np.ndarray, texel: float, levels: int = 3,
                  sigma_normal: float = 0.1, sigma_luminance: float = 4.0,
                  threads: int | None = None):
    """Edge-avoiding a-trous filter of ``image`` (H, W, C) within charts (Dammertz et al.,
    "Edge-avoiding a-trous wavelet transform for fast global illumination filtering", HPG
    2010, with the variance-guided luminance weight of Schied et al., "Spatiotemporal
    variance-guided filtering", HPG 2017): ``levels`` passes of a 5 x 5 B3-spline kernel with
    holes of 2^k texels (``kernels.lightmap.atrous``). A neighbour counts if it is in the same
    chart (``chart`` (H, W), -1 none), weighted by exp(-(1 - n.n') / ``sigma_normal``)
    (``normal`` (H, W, 3)), by its distance to the texel's tangent plane over the texel size
    ``texel`` (metres; ``position`` (H, W, 3)), and by its luminance difference over
    ``sigma_luminance`` standard deviations of the estimate (``variance`` (H, W), of the
    luminance, quartered each pass).

    A generator: it yields the finished fraction after each band of ``BAND`` texels (filtered
    on ``threads`` threads) and returns the filtered (H, W, C) float32 image."""
    from concurrent.futures import ThreadPoolExecutor

    from ..kernels import lightmap as kernels

    h, w, c = image.shape
    luma = np.array([0.2126, 0.7152, 0.0722]) if c == 3 else np.eye(c)[0]
    src = np.ascontiguousarray(image, np.float32)
    chart = np.ascontiguousarray(chart, np.int64)
    pos = np.ascontiguousarray(position, np.float32)
    nor = np.ascontiguousarray(normal, np.float32)
    var = np.ascontiguousarray(variance, np.float32)
    rows = max(1, BAND // max(w, 1))
    bands = [(y, min(y + rows, h)) for y in range(0, h, rows)]
    total = max(levels * len(bands), 1)
    done = 0
    with ThreadPoolExecutor(max_workers=max(1, threads or os.cpu_count() or 1)) as pool:
        for level in range(levels):
            out = np.empty_like(src)
            jobs = [pool.submit(kernels.atrous, src, chart, pos, nor, var, luma, float(texel),
                                1 << level, float(sigma_normal), float(sigma_luminance),
                                0.25 ** level, y0, y1, out) for y0, y1 in bands]
            try:
                for job in jobs:
                    job.result()
                    done += 1
                    yield done / total
            finally:
                for job in jobs:
                    job.cancel()
            src = out
    return src


def seams(positions: np.ndarray, uvs: np.ndarray) -> np.ndarray:
    """The seams of a layout: edges shared by two triangles whose UVs differ there, as
    (E, 2, 3, 2) float64: per seam, per side, the UVs of the edge's two ends (in the same
    order on both sides) and of the triangle's third corner (which says where its inside is)."""
    ids = _weld(np.asarray(positions, np.float64))
    pairs, verts = _edges(ids)
    if not len(pairs):
        return np.zeros((0, 2, 3, 2))
    q = np.asarray(uvs, np.float64)
    sides = []
    for side in range(2):
        tri = pairs[:, side]
        at = [np.argmax(ids[tri] == verts[:, v, None], axis=1) for v in range(2)]
        third = 3 - at[0] - at[1]
        sides.append(np.stack([q[tri, at[0]], q[tri, at[1]], q[tri, third]], 1))
    out = np.stack(sides, 1)  # (E, side, corner, 2)
    differ = np.abs(out[:, 0, :2] - out[:, 1, :2]).max(axis=(1, 2)) > 1e-6
    return out[differ]


def _seam_points(seam: np.ndarray, width: int, height: int):
    """Points along the seams, two per texel of their length: UVs on side 0 and side 1 (N, 2)
    and the unit inward directions (N, 2) of each side, in UV."""
    size = np.array([width, height], np.float64)
    length = np.linalg.norm((seam[:, 0, 1] - seam[:, 0, 0]) * size, axis=1)
    steps = np.maximum(np.ceil(length * 2.0).astype(np.int64), 1)
    rows = np.repeat(np.arange(len(seam)), steps + 1)
    t = np.concatenate([np.linspace(0.0, 1.0, s + 1) for s in steps])[:, None]
    points, inward = [], []
    for side in range(2):
        a, b, c = (seam[rows, side, k] for k in range(3))
        points.append(a + t * (b - a))
        edge = (b - a) * size
        normal = np.stack([-edge[:, 1], edge[:, 0]], 1)
        normal *= np.sign(((c - a) * size * normal).sum(1, keepdims=True))
        normal /= np.maximum(np.linalg.norm(normal, axis=1, keepdims=True), 1e-12)
        inward.append(normal / size)  # one texel, in UV
    return points, inward


def seam_jumps(image: np.ndarray, seam: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """At points along the seams (``seams``): the jump across each (the largest channel
    difference of the bilinear values on its two sides) and the gradient beside it (the
    largest difference between a side's value and its value one texel inward), (N,) each."""
    if not len(seam):
        return np.zeros(0), np.zeros(0)
    h, w, _ = image.shape
    (a, b), (na, nb) = _seam_points(seam, w, h)
    va, vb = sample(image, a), sample(image, b)
    jump = np.abs(va - vb).max(1)
    beside = np.maximum(np.abs(va - sample(image, a + na)).max(1),
                        np.abs(vb - sample(image, b + nb)).max(1))
    return jump, beside


def uv_islands(uvs: np.ndarray) -> np.ndarray:
    """(T,) island id: triangles joined where they share two UV corners."""
    q = np.round(np.asarray(uvs, np.float64) * (1 << 20)).astype(np.int64)
    flat = q.reshape(-1, 2)
    _, ids = np.unique(flat, axis=0, return_inverse=True)
    ids = ids.reshape(-1, 3)
    pairs, _ = _edges(np.column_stack([ids[:, 0], ids[:, 1], ids[:, 2]]))
    parent = np.arange(len(ids))

    def find(x):
        while parent[x] != x:
            parent[x] = parent[parent[x]]
            x = parent[x]
        return x

    for a, b in pairs.tolist():
        ra, rb = find(a), find(b)
        if ra != rb:
            parent[ra] = rb
    return np.array([find(x) for x in range(len(ids))], np.int64)


def _bilinear_taps(uv: np.ndarray, width: int, height: int):
    """The four texels (N, 4) flat indices and weights (N, 4) of bilinear look-ups at ``uv``
    (N, 2) (row 0 at v = 1), clamped to the image."""
    fx = uv[:, 0] * width - 0.5
    fy = (1.0 - uv[:, 1]) * height - 0.5
    x0 = np.clip(np.floor(fx), 0, width - 1)
    y0 = np.clip(np.floor(fy), 0, height - 1)
    tx, ty = np.clip(fx - x0, 0, 1), np.clip(fy - y0, 0, 1)
    x0, y0 = x0.astype(np.int64), y0.astype(np.int64)
    x1, y1 = np.minimum(x0 + 1, width - 1), np.minimum(y0 + 1, height - 1)
    idx = np.stack([y0 * width + x0, y0 * width + x1, y1 * width + x0, y1 * width + x1], 1)
    wgt = np.stack([(1 - tx) * (1 - ty), tx * (1 - ty), (1 - tx) * ty, tx * ty], 1)
    return idx, wgt


def sample(image: np.ndarray, uv: np.ndarray) -> np.ndarray:
    """Bilinear look-up of ``image`` (H, W, C) at ``uv`` (N, 2): (N, C) float32."""
    h, w, c = image.shape
    idx, wgt = _bilinear_taps(np.asarray(uv, np.float64), w, h)
    flat = image.reshape(-1, c)
    return np.einsum("nk,nkc->nc", wgt, flat[idx]).astype(np.float32)


def as_sh(values: np.ndarray) -> np.ndarray:
    """(N, 9, 3) float32 radiance SH of lightmap values (N, 3) (irradiance: the constant
    term alone, pi Y00 L00 = E) or (N, 12) (the L1 SH of a directional lightmap), as the
    indirect kernel reads a pixel's SH."""
    out = np.zeros((len(values), 9, 3), np.float32)
    if values.shape[1] == 12:
        out[:, :4] = values.reshape(-1, 4, 3)
    else:
        out[:, 0] = values / np.float32(np.pi * SH_SCALE_C0)
    return out


def stitch(image: np.ndarray, seam: np.ndarray, iterations: int = 32) -> np.ndarray:
    """``image`` (H, W, C) with its values along the seams (``seams``) made to agree: at
    points along each seam (two per texel of its length) the bilinear values of both sides
    are pulled to their mean by moving each side's four texels (iterated; a least-squares
    seam erasure in the manner of Liu, Ferguson and Jacobson, "Seamless", 2017)."""
    if not len(seam):
        return image
    h, w, c = image.shape
    (a, b), _ = _seam_points(seam, w, h)
    ia, wa = _bilinear_taps(a, w, h)
    ib, wb = _bilinear_taps(b, w, h)
    flat = image.reshape(-1, c).astype(np.float64).copy()
    for _ in range(iterations):
        va = np.einsum("nk,nkc->nc", wa, flat[ia])
        vb = np.einsum("nk,nkc->nc", wb, flat[ib])
        diff = va - vb
        if not np.abs(diff).max(initial=0.0) > 1e-7 * max(np.abs(flat).max(), 1e-30):
            break
        step = np.zeros_like(flat)
        norm = np.zeros(len(flat))
        # each side moves half the difference, shared by its taps in proportion to weight
        for idx, wgt, sign in ((ia, wa, -0.5), (ib, wb, 0.5)):
            scale = wgt / np.maximum((wgt ** 2).sum(1, keepdims=True), 1e-12)
            np.add.at(step, idx.reshape(-1), (sign * scale[..., None] * diff[:, None, :]
                                             * wgt[..., None]).reshape(-1, c))
            np.add.at(norm, idx.reshape(-1), wgt.reshape(-1))
        flat += step / np.maximum(norm, 1.0)[:, None]
    return flat.reshape(h, w, c).astype(np.float32)
