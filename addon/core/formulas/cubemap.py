"""Cube maps: face layout, direction <-> texel mapping, exact texel solid angles, seamless
trilinear sampling over a mip chain, lat-long -> cube conversion and source pyramids.

A cube map is a float32 array (6, S, S, C): six square faces of S x S texels, C channels of
scene-linear radiance, in the face order 0..5 = +X, -X, +Y, -Y, +Z, -Z (Blender world axes, Z up,
right-handed). A mip chain is a list of such arrays with S_m = S >> m.

Face frames (``FACES``). Each face has three unit rows (forward, right, up) with
right = cross(forward, up): a camera looking along ``forward`` with ``up`` as its up vector sees
``right`` to its right (a 90-degree perspective camera built from these rows renders the face).
Side faces use up = +Z; the top face +Z uses up = +Y and the bottom face -Z uses up = -Y, so
that -Z, -Y, +Z form a vertical strip with a common right vector -X (tilting a camera that
looks along -Y up by 90 degrees turns it into the +Z camera)::

    face  forward      right        up
    0 +X  (+1, 0, 0)   ( 0,-1, 0)   ( 0, 0,+1)
    1 -X  (-1, 0, 0)   ( 0,+1, 0)   ( 0, 0,+1)
    2 +Y  ( 0,+1, 0)   (+1, 0, 0)   ( 0, 0,+1)
    3 -Y  ( 0,-1, 0)   (-1, 0, 0)   ( 0, 0,+1)
    4 +Z  ( 0, 0,+1)   (-1, 0, 0)   ( 0,+1, 0)
    5 -Z  ( 0, 0,-1)   (-1, 0, 0)   ( 0,-1, 0)

Texel (row, col) of a face of size S, row 0 at the top, has the face coordinates
a = 2 (col + 0.5) / S - 1 (towards ``right``) and b = 1 - 2 (row + 0.5) / S (towards ``up``), and
the direction normalize(forward + a right + b up). Continuous texel coordinates (x, y) are
x = (a + 1) S / 2 along the columns and y = (1 - b) S / 2 along the rows, so texel centres sit at
(col + 0.5, row + 0.5) and a face spans [0, S] x [0, S].

What the module follows, and where from:

- Solid angles: the exact closed form of the area of a face rectangle projected on the unit
  sphere, E(x, y) = atan2(x y, sqrt(x^2 + y^2 + 1)) summed over the four corners (the "area
  element" of Manne Oehrstroem's thesis, as used by Ignacio Castano and by the modified AMD
  CubeMapGen of Lagarde 2012, "AMD Cubemapgen for physically based rendering").
- Seamless filtering: bilinear taps that fall beyond a face edge read the neighbouring face's
  edge texel, as if the two faces were unfolded flat (the seamless cube map filtering of
  ``ARB_seamless_cube_map`` / D3D10, which replaced the "edge fixup" of CubeMapGen on older
  hardware, Lazarov 2013, slide "Black Ops: environment map pre-filtering"). At a cube corner,
  where only three faces meet, the missing fourth tap is the average of the three corner texels,
  so bilinear sampling is continuous across all 12 edges and 8 corners at every mip.
- Trilinear mip selection: Williams 1983, "Pyramidal parametrics", between the two nearest
  levels, as the shader's texCUBElod (Lazarov 2013, slide "Black Ops: environment map
  pre-filtering": lod = nMips - gloss * nMips).
- Lat-long images: the Environment Texture mapping of ``texture.direction_to_equirect_uv``
  (Blender's equirectangular projection; row 0 of the image is the top).
"""

from __future__ import annotations

import functools

import numpy as np

from . import texture

__all__ = [
    "FACES",
    "FACE_NAMES",
    "build_pyramid",
    "direction_to_face",
    "downsample",
    "equirect_to_cube",
    "face_coordinates",
    "sample",
    "texel_directions",
    "texel_solid_angles",
]

FACE_NAMES = ("+X", "-X", "+Y", "-Y", "+Z", "-Z")

# (6, 3, 3) float64: rows (forward, right, up) of each face, right = cross(forward, up).
FACES = np.array(
    [
        [[1, 0, 0], [0, -1, 0], [0, 0, 1]],
        [[-1, 0, 0], [0, 1, 0], [0, 0, 1]],
        [[0, 1, 0], [1, 0, 0], [0, 0, 1]],
        [[0, -1, 0], [-1, 0, 0], [0, 0, 1]],
        [[0, 0, 1], [-1, 0, 0], [0, 1, 0]],
        [[0, 0, -1], [-1, 0, 0], [0, -1, 0]],
    ],
    np.float64,
)
FACES.setflags(write=False)


# ---------------------------------------------------------------------------------------------
# Texel geometry


def face_coordinates(size: int) -> np.ndarray:
    """Face coordinate of the texel centres along one axis: 2 (i + 0.5) / S - 1.

    size:    S, texels per face side
    returns: (S,) float64 in (-1, 1), increasing; a = this[col], b = -this[row]
    """
    return (2.0 * np.arange(size) + 1.0) / size - 1.0


@functools.lru_cache(maxsize=16)
def texel_directions64(size: int) -> np.ndarray:
    """(6, S, S, 3) float64 unit texel directions (read-only, cached)."""
    t = face_coordinates(size)
    a = t[None, :]  # columns
    b = -t[:, None]  # rows, row 0 at the top
    f, r, u = FACES[:, 0], FACES[:, 1], FACES[:, 2]
    d = (
        f[:, None, None, :]
        + a[None, :, :, None] * r[:, None, None, :]
        + b[None, :, :, None] * u[:, None, None, :]
    )
    d /= np.linalg.norm(d, axis=-1, keepdims=True)
    d.setflags(write=False)
    return d


@functools.lru_cache(maxsize=16)
def _texel_directions32(size: int) -> np.ndarray:
    d = texel_directions64(size).astype(np.float32)
    d.setflags(write=False)
    return d


def texel_directions(size: int) -> np.ndarray:
    """Unit direction of every texel centre, normalize(forward + a right + b up).

    See the module docstring for the face frames and (a, b); cached per size.

    size:    S, texels per face side (>= 1)
    returns: (6, S, S, 3) float32, read-only, Blender world axes
    """
    return _texel_directions32(int(size))


def _area_element(x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """Solid angle of the face rectangle [0, x] x [0, y] (signed), atan2(xy, sqrt(x^2+y^2+1))."""
    return np.arctan2(x * y, np.sqrt(x * x + y * y + 1.0))


@functools.lru_cache(maxsize=16)
def _solid_angles(size: int) -> np.ndarray:
    e = np.linspace(-1.0, 1.0, size + 1)
    x0, x1 = e[None, :-1], e[None, 1:]
    y0, y1 = e[:-1, None], e[1:, None]
    omega = np.abs(
        _area_element(x0, y0) - _area_element(x0, y1) - _area_element(x1, y0)
        + _area_element(x1, y1)
    )
    omega.setflags(write=False)
    return omega


def texel_solid_angles(size: int) -> np.ndarray:
    """Exact solid angle of each texel of a face (the same for all six faces).

    Closed form: with E(x, y) = atan2(x y, sqrt(x^2 + y^2 + 1)), the texel [x0, x1] x [y0, y1] of
    face coordinates subtends E(x0, y0) - E(x0, y1) - E(x1, y0) + E(x1, y1) (Oehrstroem's area
    element, see the module docstring). The 6 S^2 values sum to 4 pi.

    size:    S, texels per face side (>= 1)
    returns: (S, S) float64 steradians, read-only, indexed [row, col]
    """
    return _solid_angles(int(size))


def direction_to_face(directions, size: int = 1):
    """Face and continuous texel coordinates of directions (the inverse of the texel mapping).

    The face is the one of the largest absolute component (ties go to X before Y before Z);
    a = d.right / d.forward, b = d.up / d.forward, x = (a + 1) S / 2, y = (1 - b) S / 2.

    directions: (N, 3) or (3,) directions, any non-zero length; zero or non-finite vectors map to
                the centre of face +X
    size:       S, texels per face side; the default 1 gives coordinates in [0, 1]
    returns:    face (N,) int64 in 0..5; x (N,) float64 in [0, S] along the columns; y (N,)
                float64 in [0, S] along the rows (row 0 at the top); texel centres at
                (col + 0.5, row + 0.5)
    """
    d = np.asarray(directions, np.float64).reshape(-1, 3)
    bad = ~np.isfinite(d).all(axis=1) | ~(np.abs(d).max(axis=1, initial=0.0) > 0.0)
    if bad.any():
        d = np.where(bad[:, None], np.array([1.0, 0.0, 0.0]), d)
    ad = np.abs(d)
    axis = np.argmax(ad, axis=1)
    rows = np.arange(len(d))
    negative = d[rows, axis] < 0.0
    face = 2 * axis + negative
    frame = FACES[face]  # (N, 3, 3)
    depth = ad[rows, axis]
    a = np.einsum("nc,nc->n", d, frame[:, 1]) / depth
    b = np.einsum("nc,nc->n", d, frame[:, 2]) / depth
    a = np.clip(a, -1.0, 1.0)
    b = np.clip(b, -1.0, 1.0)
    return face.astype(np.int64), (a + 1.0) * (0.5 * size), (1.0 - b) * (0.5 * size)


# ---------------------------------------------------------------------------------------------
# Seamless sampling


@functools.lru_cache(maxsize=16)
def _pad_tables(size: int):
    """Index tables that add a one-texel border to each face from its neighbours.

    Returns (src, corner_pos, corner_src): src is (6, S+2, S+2) int64 flat texel indices into a
    (6 S S) face-major array, for the interior and the four border strips (a strip texel is the
    neighbouring face's edge texel across that edge, as if the faces were unfolded); the border's
    four corner cells point anywhere and are overwritten by the average of the three texels of
    corner_src (6, 4, 3) int64, for the cells at corner_pos (4, 2) (padded row, col).
    """
    s = size
    p = np.arange(s + 2) - 1  # texel index of each padded row / column, -1 .. S
    rr, cc = np.meshgrid(p, p, indexing="ij")
    inside_r = (rr >= 0) & (rr < s)
    inside_c = (cc >= 0) & (cc < s)
    eps = 1e-7
    t = face_coordinates(s)
    a = np.where(cc < 0, -1.0 - eps, np.where(cc >= s, 1.0 + eps, t[np.clip(cc, 0, s - 1)]))
    b = -np.where(rr < 0, -1.0 - eps, np.where(rr >= s, 1.0 + eps, t[np.clip(rr, 0, s - 1)]))
    src = np.empty((6, s + 2, s + 2), np.int64)
    for f in range(6):
        fwd, right, up = FACES[f]
        d = fwd + a[..., None] * right + b[..., None] * up
        face, x, y = direction_to_face(d.reshape(-1, 3), s)
        col = np.clip(np.floor(x), 0, s - 1).astype(np.int64)
        row = np.clip(np.floor(y), 0, s - 1).astype(np.int64)
        flat = (face * s + row) * s + col
        own = (f * s + np.clip(rr, 0, s - 1)) * s + np.clip(cc, 0, s - 1)
        src[f] = np.where((inside_r & inside_c).ravel(), own.ravel(), flat).reshape(s + 2, s + 2)
    corner_pos = np.array([[0, 0], [0, s + 1], [s + 1, 0], [s + 1, s + 1]])
    corner_src = np.empty((6, 4, 3), np.int64)
    for k, (pr, pc) in enumerate(corner_pos):
        ir = 1 if pr == 0 else s  # the face's own corner texel, padded coordinates
        ic = 1 if pc == 0 else s
        corner_src[:, k, 0] = src[:, ir, ic]
        corner_src[:, k, 1] = src[:, pr, ic]  # across the top / bottom edge
        corner_src[:, k, 2] = src[:, ir, pc]  # across the left / right edge
    return src, corner_pos, corner_src


def with_border(level: np.ndarray) -> np.ndarray:
    """(6, S, S, C) -> (6, S+2, S+2, C) float32 with the seamless one-texel border."""
    s = level.shape[1]
    c = level.shape[-1]
    src, corner_pos, corner_src = _pad_tables(s)
    flat = np.ascontiguousarray(level, np.float32).reshape(6 * s * s, c)
    out = np.take(flat, src, axis=0)
    corners = np.take(flat, corner_src, axis=0).mean(axis=2)  # (6, 4, C)
    out[:, corner_pos[:, 0], corner_pos[:, 1]] = corners
    return out


def _bilinear_padded(padded: np.ndarray, face, x, y) -> np.ndarray:
    """Bilinear taps of padded faces at continuous texel coordinates.

    padded: (6, S+2, S+2, C) float32 from ``with_border``
    face:   (N,) int64; x, y: (N,) float64 in [0, S]
    returns (N, C) float32
    """
    s = padded.shape[1] - 2
    c = padded.shape[-1]
    fx = x - 0.5
    fy = y - 0.5
    x0 = np.clip(np.floor(fx), -1, s - 1)
    y0 = np.clip(np.floor(fy), -1, s - 1)
    tx = np.clip(fx - x0, 0.0, 1.0).astype(np.float32)[:, None]
    ty = np.clip(fy - y0, 0.0, 1.0).astype(np.float32)[:, None]
    xi = x0.astype(np.int64) + 1
    yi = y0.astype(np.int64) + 1
    flat = padded.reshape(-1, c)
    base = (face * (s + 2) + yi) * (s + 2) + xi
    top = np.take(flat, base, axis=0) * (1.0 - tx) + np.take(flat, base + 1, axis=0) * tx
    below = base + (s + 2)
    bottom = np.take(flat, below, axis=0) * (1.0 - tx) + np.take(flat, below + 1, axis=0) * tx
    return top * (1.0 - ty) + bottom * ty


def sample(mips, directions, lod=None) -> np.ndarray:
    """Seamless trilinear lookups in a cube-map mip chain (texCUBElod).

    Bilinear within a level with taps beyond a face edge read from the neighbouring face (and the
    average of the three corner texels at a cube corner), so the result is continuous across all
    edges and corners; linear between the two nearest levels (Williams 1983). Lazarov 2013, slide
    "Black Ops: environment map pre-filtering" (the shader's texCUBElod).

    mips:       list of (6, S_m, S_m, C) float32 levels, S_m = S >> m (a single (6, S, S, C)
                array is a one-level chain)
    directions: (N, 3) lookup directions, any non-zero length
    lod:        None for level 0, or a scalar or (N,) level of detail in levels, clamped to
                [0, len(mips) - 1]; NaN means the coarsest level
    returns:    (N, C) float32
    """
    if isinstance(mips, np.ndarray):
        mips = [mips]
    face, u, v = direction_to_face(directions)  # u, v in [0, 1]
    n = len(face)
    c = mips[0].shape[-1]
    top = len(mips) - 1
    if lod is None:
        lod = np.zeros(n)
    lod = np.broadcast_to(np.asarray(lod, np.float64), (n,))
    lod = np.clip(np.nan_to_num(lod, nan=top, posinf=top, neginf=0.0), 0.0, top)
    base = np.floor(lod).astype(np.int64)
    frac = (lod - base).astype(np.float32)
    out = np.zeros((n, c), np.float32)
    for k in range(int(base.min(initial=0)), int(base.max(initial=0)) + 2):
        if k > top:
            break
        weight = np.where(base == k, 1.0 - frac, 0.0) + np.where(base + 1 == k, frac, 0.0)
        idx = np.flatnonzero(weight > 0.0)
        if idx.size == 0:
            continue
        s = mips[k].shape[1]
        taps = _bilinear_padded(with_border(mips[k]), face[idx], u[idx] * s, v[idx] * s)
        out[idx] += weight[idx, None].astype(np.float32) * taps
    return out


# ---------------------------------------------------------------------------------------------
# Building cube maps


def _equirect_bilinear(level: np.ndarray, u: np.ndarray, v: np.ndarray) -> np.ndarray:
    """Bilinear lookup in a lat-long level: u wraps around, v clamps at the poles.

    level: (h, w, C) float32, row 0 at the top (v = 1); u, v: (N,) float64
    returns (N, C) float32
    """
    h, w, c = level.shape
    flat = level.reshape(h * w, c)
    x = u * w - 0.5
    y = (1.0 - v) * h - 0.5
    x0 = np.floor(x)
    y0 = np.floor(y)
    tx = (x - x0).astype(np.float32)[:, None]
    ty = np.clip(y - y0, 0.0, 1.0).astype(np.float32)[:, None]
    xa = np.mod(x0.astype(np.int64), w)
    xb = np.mod(xa + 1, w)
    ya = np.clip(y0.astype(np.int64), 0, h - 1) * w
    yb = np.clip(y0.astype(np.int64) + 1, 0, h - 1) * w
    top = np.take(flat, ya + xa, axis=0) * (1.0 - tx) + np.take(flat, ya + xb, axis=0) * tx
    bottom = np.take(flat, yb + xa, axis=0) * (1.0 - tx) + np.take(flat, yb + xb, axis=0) * tx
    return top * (1.0 - ty) + bottom * ty


def _equirect_trilinear(mips, u, v, lod) -> np.ndarray:
    top = len(mips) - 1
    lod = np.clip(lod, 0.0, top)
    base = np.floor(lod).astype(np.int64)
    frac = (lod - base).astype(np.float32)
    out = np.zeros((len(u), mips[0].shape[-1]), np.float32)
    for k in range(int(base.min(initial=0)), int(base.max(initial=0)) + 2):
        if k > top:
            break
        weight = np.where(base == k, 1.0 - frac, 0.0) + np.where(base + 1 == k, frac, 0.0)
        idx = np.flatnonzero(weight > 0.0)
        if idx.size:
            out[idx] += weight[idx, None] * _equirect_bilinear(mips[k], u[idx], v[idx])
    return out


def _uv(d: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Float64 lat-long UV of (N, 3) directions (``texture.direction_to_equirect_uv``)."""
    x, y, z = d[:, 0], d[:, 1], d[:, 2]
    return 0.5 - np.arctan2(y, x) / (2.0 * np.pi), 0.5 + np.arctan2(z, np.hypot(x, y)) / np.pi


def _equirect_anisotropic(mips, u, v, ext_u, ext_v) -> np.ndarray:
    """Anisotropic lat-long lookups: n trilinear probes spread along u, n = ext_u / ext_v.

    Near the poles a sample's footprint spans many more columns than rows (1 / cos(latitude)
    times as many for a 2:1 image, all columns at the pole), which an isotropic level of detail
    would turn into a blur over many rows. As in hardware anisotropic filtering, the level comes
    from the minor axis (rows) and n probes (a power of two) cover the major axis (columns).

    mips:         lat-long mip chain (``texture.build_mips``)
    u, v:         (N,) float64 UV of the samples
    ext_u, ext_v: (N,) footprint in level-0 texels along u and v
    returns:      (N, C) float32
    """
    w = mips[0].shape[1]
    ratio = np.clip(ext_u / np.maximum(ext_v, 1.0), 1.0, w)
    probes = np.left_shift(1, np.ceil(np.log2(ratio) - 1e-9).astype(np.int64))
    lod = np.log2(np.maximum(np.maximum(ext_v, ext_u / probes), 1e-12))
    out = np.empty((len(u), mips[0].shape[-1]), np.float32)
    for n in np.unique(probes):
        idx = np.flatnonzero(probes == n)
        offset = ((np.arange(n) + 0.5) / n - 0.5)[None, :] * (ext_u[idx] / w)[:, None]
        uu = (u[idx, None] + offset).ravel()
        vv = np.repeat(v[idx], n)
        ll = np.repeat(lod[idx], n)
        out[idx] = _equirect_trilinear(mips, uu, vv, ll).reshape(len(idx), n, -1).mean(axis=1)
    return out


def equirect_to_cube(image, size: int, *, supersample: int | None = None,
                     rotation=None) -> np.ndarray:
    """Resample a lat-long (equirectangular) image into a cube map without aliasing.

    The image is read with the mapping of Blender's Environment Texture node
    (``texture.direction_to_equirect_uv``; row 0 is the top, +Z). Each cube texel averages
    ``supersample``^2 sub-texel samples, and each sample reads the image's mip chain (Williams
    1983, box-filtered levels of ``texture.build_mips``) trilinearly at the level whose texel
    matches the sample spacing along the rows, with extra probes along the columns where the
    footprint is wider in u (near the poles; anisotropic filtering, as in
    ``EXT_texture_filter_anisotropic``), so a cube smaller than the image and the converging
    columns near the poles are filtered instead of point-sampled or over-blurred. u wraps
    around; v clamps at the poles.

    image:       (H, W, C) or (H, W) float32 scene-linear lat-long image, row 0 at the top
    size:        S, texels per face side of the result
    supersample: samples per texel side; default ceil(2 H / (pi S)) (the image rows that one
                 texel spans at a face centre) clamped to [1, 4], the mip levels filtering the rest
    rotation:    optional (3, 3) world-to-image rotation R (a Mapping node's): texel direction d
                 reads the image at R d
    returns:     (6, S, S, C) float32 cube map (face order and texel convention of ``FACES``)
    """
    img = np.asarray(image, np.float32)
    if img.ndim == 2:
        img = img[:, :, None]
    if img.ndim != 3 or 0 in img.shape:
        raise ValueError(f"expected an (H, W, C) image, got shape {img.shape}")
    img = np.nan_to_num(img, nan=0.0, posinf=0.0, neginf=0.0)
    h, w, c = img.shape
    size = int(size)
    if supersample is None:
        supersample = int(np.clip(np.ceil(2.0 * h / (np.pi * size)), 1, 4))
    ss = int(supersample)
    mips = texture.build_mips(np.ascontiguousarray(img))
    n = size * ss
    t = (2.0 * np.arange(n) + 1.0) / n - 1.0
    step = 2.0 / n
    out = np.empty((6, size, size, c), np.float32)
    rows_per_chunk = max(1, 65536 // (n * ss))  # texel rows per chunk: ~64k samples
    turn = np.eye(3) if rotation is None else np.asarray(rotation, np.float64)
    for f in range(6):
        fwd, right, up = (turn @ axis for axis in FACES[f])
        for r0 in range(0, size, rows_per_chunk):
            r1 = min(size, r0 + rows_per_chunk)
            b = -t[r0 * ss : r1 * ss]
            aa, bb = np.meshgrid(t, b)
            aa = aa.ravel()
            bb = bb.ravel()
            d = fwd + aa[:, None] * right + bb[:, None] * up
            u, v = _uv(d)
            # UV footprint of one sample step along a and b, in image texels.
            ua, va = _uv(d + step * right)
            ub, vb = _uv(d - step * up)
            # Bounding box of the footprint parallelogram.
            ext_u = (np.abs((ua - u + 0.5) % 1.0 - 0.5) + np.abs((ub - u + 0.5) % 1.0 - 0.5)) * w
            ext_v = (np.abs(va - v) + np.abs(vb - v)) * h
            vals = _equirect_anisotropic(mips, u, v, ext_u, ext_v)
            vals = vals.reshape(r1 - r0, ss, size, ss, c).mean(axis=(1, 3))
            out[f, r0:r1] = vals
    return out


def downsample(cube) -> np.ndarray:
    """Halve a cube map: each 2 x 2 block of texels becomes one texel (a box filter).

    The four texels are weighted by their exact solid angles, so the coarse texel holds the mean
    radiance over its footprint and the integral over the sphere is kept (Williams 1983 box
    pyramid, on the sphere).

    cube:    (6, S, S, C) float32, S even
    returns: (6, S/2, S/2, C) float32
    """
    cube = np.asarray(cube, np.float32)
    s = cube.shape[1]
    if s % 2 or cube.shape[2] != s or cube.shape[0] != 6:
        raise ValueError(f"expected a (6, S, S, C) cube with even S, got {cube.shape}")
    h = s // 2
    c = cube.shape[-1]
    omega = texel_solid_angles(s).astype(np.float32)
    weighted = (cube * omega[None, :, :, None]).reshape(6, h, 2, h, 2, c).sum(axis=(2, 4))
    norm = omega.reshape(h, 2, h, 2).sum(axis=(1, 3))
    return (weighted / norm[None, :, :, None]).astype(np.float32)


def build_pyramid(cube) -> list[np.ndarray]:
    """Source pyramid of a cube map: the cube and its ``downsample`` halvings down to 1 x 1.

    cube:    (6, S, S, C) float32, S a power of two
    returns: list of log2(S) + 1 arrays (6, S >> m, S >> m, C) float32; level 0 is the input
    """
    levels = [np.ascontiguousarray(cube, np.float32)]
    while levels[-1].shape[1] > 1:
        levels.append(downsample(levels[-1]))
    return levels
