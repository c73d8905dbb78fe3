"""Prefiltered environment maps: the cosine-power (Phong lobe) mip chain of Black Ops II and the
angular-Gaussian chain of Black Ops (AMD CubeMapGen), both seamless.

Sources:

- Lazarov 2013, "Getting More Physical in Call of Duty: Black Ops II", slides "Black Ops:
  environment map pre-filtering" (BO1: offline CubeMapGen, angular Gaussian filter, edge fixup;
  the shader picks lod = nMips - gloss * nMips) and "Improved environment map pre-filtering"
  (BO2: a cosine power filter, each mip filtered with the specular power of its gloss, the top
  mip's resolution tied to the maximum specular power, 256 -> 128, and the Blinn-Phong to Phong
  conversion alpha_phong = alpha_blinn_phong / 4).
- AMD CubeMapGen 1.1 (ATI Research 2005, ``CCubeMapProcessor``), and its modified version by
  Lagarde 2012, "AMD Cubemapgen for physically based rendering" (the cosine power filter that
  BO2's customised CubeMapGen and this module's BO2 chain follow).

BO2 chain (``prefilter_cosine_power``). A face size S = 2^M gives M + 1 mips (S, S/2, ..., 1).
The shader reads lod = M - gloss M, so mip m holds gloss g_m = 1 - m / M, whose Blinn-Phong power
is 8192^g_m (the project's alpha = 8192^g) and whose Phong power is p_m = 8192^g_m / 4. Mip m
is the normalized convolution of the radiance with the Phong lobe around each texel's direction r:

    L_m(r) = sum_d max(r.d, 0)^p_m L(d) dOmega(d) / sum_d max(r.d, 0)^p_m dOmega(d)

over source texels d with exact solid angles dOmega. The Phong lobe (r.d)^p ~ exp(-p theta^2 / 2)
is close to a Gaussian of standard deviation 1 / sqrt(p) radians, which ties the top mip to the
maximum power (``top_resolution``): a face of S texels has a texel spacing of 2 / S radians at
its centre, and keeping it within one standard deviation of the sharpest lobe needs
S >= 2 sqrt(p_0). For p_0 = 8192 / 4 = 2048 that is 90.5, so S = 128; without the Blinn-Phong to
Phong conversion (p_0 = 8192) it would be 181, so S = 256: the talk's drop from 256 to 128.

BO1 chain (``prefilter_angular_gaussian``), CubeMapGen's "Angular Gaussian" filter with its
parameters "base filter angle" (default 20 degrees), "initial mip filter angle" (1 degree) and
"mip filter angle scale" (2), the defaults of CubeMapGen's library sample. A filter of cone angle
A (degrees) averages the source texels within the half-angle h = A / 2 of the output direction,
each weighted by its solid angle and by exp(-theta^2 / (2 sigma^2)) with sigma = h / 3 ("fit 3
standard deviations within the angular extent"); h is clamped to [atan(1 / S_src), 90 degrees],
S_src the face size being filtered. Mip 0 filters the input with A = base angle; mip m >= 1
filters mip m - 1 (already filtered, twice the size) with A = initial * scale^(m - 1): a cascade,
so mip m's lobe is the composition of all the passes before it (``angular_gaussian_angles``
lists each pass's half-angle and the accumulated standard deviation). Nothing ties the angles to
gloss, the problem the BO2 chain fixes. Differences from CubeMapGen, all deliberate: the Gaussian
is evaluated exactly (CubeMapGen reads it from a 4096-entry table indexed by floor(4095 cos
theta), which flattens it below about 1.3 degrees); solid angles are exact (CubeMapGen 1.1 used
two planar triangles per texel); where no source texel centre falls inside the cone (small
angles at a face centre, where each output texel sits on the corner of four source texels)
CubeMapGen copies the texel under the centre tap, one of four equidistant texels picked by
rounding, while this module takes the seamless bilinear sample there (their average); and the
edge fixup (averaging the texels along the 12 edges for hardware that could not filter across
faces) is not applied, since the filters read across edges by construction and
``cubemap.sample`` filters seamlessly.

Implementation. Each output texel gathers the source texels whose angle to it is inside the
lobe's cone (BO2: where (r.d)^p >= ``cutoff``, 1e-4 of the peak by default; BO1: the half-angle
h, with a relative tolerance of 1e-5 so that texels exactly on the edge, which the clamp to
atan(1 / S_src) produces, count as inside), renormalized by the weights' sum. BO2 reads each mip
from the level of a source pyramid (``cubemap.build_pyramid``, solid-angle weighted 2 x 2 boxes)
whose texel spacing at a face centre is at most 1 / ``texels_per_sigma`` of the lobe's standard
deviation 1 / sqrt(p) (but not coarser than the mip itself nor than 32, unless the input is
smaller); BO1 reads the previous mip, as CubeMapGen does. The gather runs per tile of T x T
output texels of face +X: the candidate source texels are those within the cone plus the tile's
angular radius, the weights form a (T^2, n) matrix, and a matrix product applies them to the
source values. The weights depend only on the geometry, which is the same for all six faces and
for the eight symmetries of a face (its flips and transposition), so one weight matrix serves 48
output tiles: their source values are gathered through the texel permutations of those 48
rotations and reflections of the cube, and stacked as the columns of one product. 1 - r.d is
formed in the tile's own frame as a rank-5 product of small terms, so float32 keeps it accurate
for the sharpest lobes. T is picked per level from a cost model (gathers against wasted
weights). Tiles run on a thread pool; NumPy's loops release the GIL, and the matrix products,
which OpenBLAS already spreads over the cores, are issued one at a time.
"""

from __future__ import annotations

import functools
import math
import threading
from concurrent.futures import ThreadPoolExecutor

import numpy as np

from . import cubemap

__all__ = [
    "BLINN_PHONG_MAX_POWER",
    "DEFAULT_BASE_ANGLE",
    "DEFAULT_INITIAL_MIP_ANGLE",
    "DEFAULT_MIP_ANGLE_SCALE",
    "angular_gaussian_angles",
    "cone_angle",
    "gloss_to_lod",
    "mip_gloss",
    "mip_powers",
    "cmft_powers",
    "prefilter_angular_gaussian",
    "prefilter_cosine_power",
    "prefilter_powers",
    "top_resolution",
]

# alpha = 8192^g (Lazarov 2013, slide "Black Ops: normal distribution function"); the BO2 chain's
# top power is the Phong equivalent 8192 / 4 (slide "Improved environment map pre-filtering").
BLINN_PHONG_MAX_POWER = 8192.0

# AMD CubeMapGen's defaults (CubeMapGen library sample: base filter angle 20, initial mip filter
# angle 1, mip filter angle scale 2, angular Gaussian, solid-angle weighting).
DEFAULT_BASE_ANGLE = 20.0
DEFAULT_INITIAL_MIP_ANGLE = 1.0
DEFAULT_MIP_ANGLE_SCALE = 2.0

# Weight-matrix entries per block of a tile's rows (1 MB of float32, cache-sized).
_BLOCK_ENTRIES = 1 << 18
# Relative tolerance of the BO1 cone's edge: theta <= h (1 + tol) is inside.
_EDGE_TOLERANCE = 1e-5
# Side of the output tiles that share one weight matrix.
_MAX_TILE = 32


# ---------------------------------------------------------------------------------------------
# Gloss, powers and resolutions (BO2)


def _mip_count(size: int) -> int:
    """M = log2(S) for a power-of-two face size S."""
    size = int(size)
    if size < 1 or size & (size - 1):
        raise ValueError(f"cube face size must be a power of two, got {size}")
    return size.bit_length() - 1


def mip_gloss(size: int) -> np.ndarray:
    """Gloss held by each mip of a chain: g_m = 1 - m / M, M = log2(S).

    The shader's lod = nMips - gloss * nMips with nMips = M (Lazarov 2013, slide "Black Ops:
    environment map pre-filtering") reads mip m at gloss g_m. A 1 x 1 cube (M = 0) holds g = 1.

    size:    S, the top mip's face size, a power of two
    returns: (M + 1,) float64 gloss in [0, 1], decreasing
    """
    m_count = _mip_count(size)
    if m_count == 0:
        return np.ones(1)
    return 1.0 - np.arange(m_count + 1) / m_count


def gloss_to_lod(gloss, n_mips: int) -> np.ndarray:
    """The shader's mip selection, lod = nMips - gloss * nMips.

    Lazarov 2013, slide "Black Ops: environment map pre-filtering".

    gloss:   any shape, gloss in [0, 1]
    n_mips:  nMips = M = log2(S), the index of the chain's 1 x 1 mip
    returns: same shape, float32 lod in mips
    """
    g = np.asarray(gloss, np.float32)
    return (np.float32(n_mips) - g * np.float32(n_mips)).astype(np.float32)


def mip_powers(size: int) -> np.ndarray:
    """Phong power of each BO2 mip: p_m = 8192^(g_m) / 4, g_m = 1 - m / M.

    Slide "Improved environment map pre-filtering" (each mip filtered with the matching gloss;
    alpha_phong = alpha_blinn_phong / 4), with alpha = 8192^g.

    size:    S, the top mip's face size, a power of two
    returns: (M + 1,) float64 Phong exponents, 2048 at mip 0 down to 0.25 at the 1 x 1 mip
    """
    return BLINN_PHONG_MAX_POWER ** mip_gloss(size) / 4.0


def top_resolution(max_power: float = BLINN_PHONG_MAX_POWER / 4.0) -> int:
    """Smallest power-of-two face size that resolves the sharpest Phong lobe of a chain.

    The lobe (r.d)^p ~ exp(-p theta^2 / 2) has a standard deviation of 1 / sqrt(p) radians; a
    face of S texels has a texel spacing of 2 / S radians at its centre (the largest on the
    face). Asking for one texel per standard deviation gives S >= 2 sqrt(p). Slide "Improved
    environment map pre-filtering": "top mip resolution tied to max specular power", which let
    BO2 drop from 256 to 128: top_resolution(8192 / 4) = 128, top_resolution(8192) = 256.

    max_power: Phong power of mip 0 (2048 = 8192 / 4 by default)
    returns:   face size S, a power of two
    """
    need = 2.0 * math.sqrt(float(max_power))
    return 1 << max(0, math.ceil(math.log2(max(need, 1.0)) - 1e-9))


def cone_angle(power: float, cutoff: float = 1e-4) -> float:
    """Half-angle of the cone where the Phong lobe (cos theta)^p is at least ``cutoff`` of its peak.

    power:   Phong exponent p > 0
    cutoff:  relative weight at the cone's edge, in (0, 1)
    returns: theta_c = acos(cutoff^(1/p)) in radians, at most pi / 2
    """
    return float(np.arccos(np.clip(cutoff ** (1.0 / float(power)), 0.0, 1.0)))


# ---------------------------------------------------------------------------------------------
# Angular Gaussian schedule (BO1)


def angular_gaussian_angles(
    size: int,
    base_angle: float = DEFAULT_BASE_ANGLE,
    initial_mip_angle: float = DEFAULT_INITIAL_MIP_ANGLE,
    mip_angle_scale: float = DEFAULT_MIP_ANGLE_SCALE,
) -> tuple[np.ndarray, np.ndarray]:
    """Per-mip filter angles of CubeMapGen's angular Gaussian chain, as this module applies them.

    Pass m filters a face of S_src texels (the input for m = 0, mip m - 1 otherwise) with the cone
    angle A_0 = base_angle, A_m = initial_mip_angle * mip_angle_scale^(m - 1); its half-angle is
    h_m = clamp(A_m / 2, atan(1 / S_src), 90 degrees) and its Gaussian sigma_m = h_m / 3
    (CubeMapGen's ``FilterCubeMapMipChain`` and ``PrecomputeFilterLookupTables``; slide "Black
    Ops: environment map pre-filtering"). Passes compose: for angles small against a radian,
    Gaussians on the sphere add their variances, so mip m's lobe has the accumulated standard
    deviation sqrt(sigma_0^2 + ... + sigma_m^2) (ignoring the resampling to half resolution,
    which adds about a texel's width).

    size:              S, the input face size, a power of two
    base_angle:        A_0 in degrees
    initial_mip_angle: A_1 in degrees
    mip_angle_scale:   ratio A_{m+1} / A_m
    returns:           half_angles (M + 1,) float64 degrees, the h_m used by each pass;
                       sigmas (M + 1,) float64 degrees, the accumulated standard deviations
    """
    m_count = _mip_count(size)
    half = np.empty(m_count + 1)
    for m in range(m_count + 1):
        src = size if m == 0 else size >> (m - 1)
        angle = base_angle if m == 0 else initial_mip_angle * mip_angle_scale ** (m - 1)
        texel = math.degrees(math.atan2(1.0, src))
        half[m] = min(max(angle / 2.0, texel), 90.0)
    return half, np.sqrt(np.cumsum((half / 3.0) ** 2))


# ---------------------------------------------------------------------------------------------
# The symmetric gather engine


def _d4_matrices() -> list[np.ndarray]:
    """The 8 symmetries of a face as 2 x 2 matrices acting on its coordinates (a, b)."""
    out = []
    for swap in (False, True):
        for sa in (1.0, -1.0):
            for sb in (1.0, -1.0):
                m = np.array([[0.0, 1.0], [1.0, 0.0]]) if swap else np.eye(2)
                out.append(np.diag([sa, sb]) @ m)
    return out


@functools.lru_cache(maxsize=16)
def _d4_targets(size: int) -> np.ndarray:
    """(8, S^2) int64: flat index (row * S + col) of the texel that symmetry g maps texel i to."""
    t = cubemap.face_coordinates(size)
    rows, cols = np.meshgrid(np.arange(size), np.arange(size), indexing="ij")
    ab = np.stack([t[cols].ravel(), -t[rows].ravel()])  # (2, S^2)
    targets = []
    for g in _d4_matrices():
        a, b = g @ ab
        col = np.rint((a + 1.0) * size / 2.0 - 0.5).astype(np.int64)
        row = np.rint((1.0 - b) * size / 2.0 - 0.5).astype(np.int64)
        targets.append(row * size + col)
    targets = np.stack(targets)
    targets.setflags(write=False)
    return targets


def _cube_symmetries() -> np.ndarray:
    """(48, 3, 3) float64: the rotations and reflections of the cube, M[f * 8 + g] mapping the
    texel of face +X at coordinates (a, b) onto the texel of face f at g(a, b) (g one of
    ``_d4_matrices``), i.e. face +X texel i onto face f texel ``_d4_targets(S)[g, i]``."""
    f0 = cubemap.FACES[0]
    out = []
    for f in range(6):
        for g in _d4_matrices():
            block = np.eye(3)
            block[1:, 1:] = g
            out.append(cubemap.FACES[f].T @ block @ f0)
    return np.stack(out)


@functools.lru_cache(maxsize=1)
def _symmetry_maps() -> tuple[np.ndarray, np.ndarray]:
    """How the 48 cube symmetries of ``_cube_symmetries`` move faces and face coordinates.

    returns face_map (48, 6) int64 and sym_map (48, 6) int64: symmetry k maps face s onto face
    face_map[k, s], its coordinates (a, b) by the face symmetry sym_map[k, s] (an index into
    ``_d4_matrices``), so texel i of face s goes to texel ``_d4_targets(S)[sym_map[k, s], i]`` of
    face face_map[k, s], for every size S.
    """
    # All entries are 0 or +-1: compare them as small integers.
    sym_index = {tuple(np.rint(m).astype(int).ravel()): i for i, m in enumerate(_d4_matrices())}
    faces = np.rint(cubemap.FACES).astype(int)
    face_index = {tuple(f): i for i, f in enumerate(faces[:, 0])}
    images = np.rint(np.einsum("kij,sbj->ksbi", _cube_symmetries(), cubemap.FACES)).astype(int)
    face_map = np.empty((48, 6), np.int64)
    sym_map = np.empty((48, 6), np.int64)
    for k in range(48):
        for s in range(6):
            fwd, right, up = images[k, s]  # images of face s's forward, right, up
            s2 = face_index[tuple(fwd)]
            r2, u2 = faces[s2, 1], faces[s2, 2]
            g = (right @ r2, up @ r2, right @ u2, up @ u2)
            face_map[k, s] = s2
            sym_map[k, s] = sym_index[tuple(int(x) for x in g)]
    return face_map, sym_map


def _permuted_indices(idx: np.ndarray, cols: np.ndarray, size: int) -> np.ndarray:
    """(n, len(cols)) int64: face-major index of the texel at M_k d_s for s in idx, k in cols.

    M_k is ``_cube_symmetries()[k]``; idx are face-major texel indices of a face size S.
    """
    face_map, sym_map = _symmetry_maps()
    targets = _d4_targets(size).ravel()
    area = size * size
    face = idx // area
    local = (idx - face * area)[:, None]
    face_base = (face_map[cols].T * area)[face]  # (n, k): first texel of the image face
    sym_base = (sym_map[cols].T * area)[face]  # (n, k): row of the face symmetry in targets
    return face_base + np.take(targets, sym_base + local)


@functools.lru_cache(maxsize=4)
def _source_tables(size: int):
    """Geometry of a source level: texel directions and solid angles.

    returns dirs (N, 3) float64 and dirs32 (N, 3) float32 unit texel directions (N = 6 S^2,
    face-major) and omega (N,) float32 solid angles.
    """
    dirs = cubemap.texel_directions64(size).reshape(-1, 3)
    omega = np.broadcast_to(cubemap.texel_solid_angles(size), (6, size, size)).reshape(-1)
    return dirs, dirs.astype(np.float32), omega.astype(np.float32)


def _output_directions(size: int, warp: bool) -> np.ndarray:
    """(6, S, S, 3) float64 directions the output texels are filtered at: the texel centres,
    or with ``warp`` the edge fixup of cmft and The Witness (Castano 2012, "Seamless cube map
    filtering"): face coordinates stretched by S / (S - 1), so that the texels along an edge
    hold the direction of the edge itself and agree with the neighbouring face's; a shader
    reading it scales the direction's two minor components by 1 - 1 / S_lod (S_lod the face
    size of the mip it reads) before a lookup that does not filter across faces."""
    if not warp or size < 2:
        return cubemap.texel_directions64(size)
    t = cubemap.face_coordinates(size) * (size / (size - 1.0))
    a, b = t[None, :], -t[:, None]
    f, r, u = cubemap.FACES[:, 0], cubemap.FACES[:, 1], cubemap.FACES[:, 2]
    d = (f[:, None, None, :] + a[None, :, :, None] * r[:, None, None, :]
         + b[None, :, :, None] * u[:, None, None, :])
    return d / np.linalg.norm(d, axis=-1, keepdims=True)


@functools.lru_cache(maxsize=16)
def _output_tiles(size: int, tile: int, warp: bool = False):
    """Tiles of face +X and their images under the face's 8 symmetries.

    returns dirs (S^2, 3) float64 face +X output directions (row-major,
    ``_output_directions``), targets (8, S^2) int64 (``_d4_targets``), and a list of canonical
    tiles, each (texels (T^2,) int64 flat indices, syms (k,) int64 symmetries giving its k
    distinct images).
    """
    dirs = _output_directions(size, warp)[0].reshape(-1, 3)
    targets = _d4_targets(size)
    n = size // tile
    seen = set()
    tiles = []
    for ti in range(n):
        for tj in range(n):
            r = np.arange(ti * tile, (ti + 1) * tile)
            c = np.arange(tj * tile, (tj + 1) * tile)
            texels = (r[:, None] * size + c[None, :]).ravel()
            if int(texels.min()) in seen:
                continue
            syms = []
            for gi in range(8):
                image = int(targets[gi, texels].min())
                if image not in seen:
                    seen.add(image)
                    syms.append(gi)
            tiles.append((texels, np.array(syms, np.int64)))
    return dirs, targets, tiles


def _weights_phong(power: float, cutoff: float):
    """BO2 lobe as a function of e = 1 - r.d, in place on float32 e: (1 - e)^p where that is at
    least ``cutoff``, else 0 (which also keeps denormals out of the matrix products)."""
    p = np.float32(power)
    floor = np.float32(cutoff)

    def weight(e: np.ndarray) -> np.ndarray:
        np.minimum(e, np.float32(1.0), out=e)
        np.negative(e, out=e)
        with np.errstate(divide="ignore"):
            np.log1p(e, out=e)
        e *= p
        np.exp(e, out=e)
        e[e < floor] = 0.0
        return e

    return weight


def _weights_gaussian(sigma: float, half_angle: float):
    """BO1 filter as a function of e = 1 - r.d, in place on float32 e:
    exp(-theta^2 / (2 sigma^2)) for theta <= half_angle, else 0.

    half_angle already includes ``_EDGE_TOLERANCE``: texels exactly on the cone's edge (which
    the clamp to atan(1 / S_src) produces by construction) count as inside.
    """
    k = np.float32(-0.5 / (sigma * sigma))
    limit = np.float32(half_angle * half_angle)

    def weight(e: np.ndarray) -> np.ndarray:
        # theta = 2 asin(sqrt(e / 2)), accurate for small angles where acos(1 - e) is not.
        np.clip(e, np.float32(0.0), np.float32(2.0), out=e)
        e *= np.float32(0.5)
        np.sqrt(e, out=e)
        np.arcsin(e, out=e)
        e *= np.float32(2.0)
        np.square(e, out=e)
        outside = e > limit
        e *= k
        np.exp(e, out=e)
        e[outside] = 0.0
        return e

    return weight


def _local_terms(v: np.ndarray, frame: np.ndarray):
    """Coordinates of unit vectors in a frame whose third axis is a tile's centre direction:
    (x, y, h) with h = 1 - z computed without cancellation.

    v: (n, 3) float64 unit vectors; frame: (3, 3) float64 orthonormal rows (t1, t2, centre)
    returns x, y, h: (n,) float64
    """
    x, y, z = (v @ frame.T).T
    near = z > 0.0
    h = np.where(near, (x * x + y * y) / np.where(near, 1.0 + z, 1.0), 1.0 - z)
    return x, y, h


def _tile_size(out_size: int, src_size: int, reach: float) -> int:
    """Side T of the output tiles that share one weight matrix (a power of two).

    Larger tiles mean fewer, larger gathers but more wasted weights (a tile's candidates are the
    union of its texels' cones). The estimate per canonical tile: a scan of all source texels,
    a gather of n candidates for 48 tiles, and T^2 n weights and products, with n the source
    texels within the cone plus the tile's angular half-diagonal; relative costs measured with
    NumPy and OpenBLAS.
    """
    n_all = 6 * src_size * src_size
    best, best_cost = 1, math.inf
    t = 1
    while t <= min(out_size, _MAX_TILE):
        spread = math.atan(math.sqrt(2.0) * t / out_size)
        cap = min(math.pi, reach + spread)
        n = max(1.0, n_all * (1.0 - math.cos(cap)) / 2.0)
        tiles = max(1.0, (out_size / t) ** 2 / 8.0)
        cost = tiles * (4.5 * n_all + 1400.0 * n + 12.0 * t * t * n + 2e5)
        if cost < best_cost:
            best, best_cost = t, cost
        t *= 2
    return best


def _filter_level(source: np.ndarray, out_size: int, weight, reach: float,
                  workers: int, warp: bool = False) -> np.ndarray:
    """Normalized spherical convolution of a cube with an isotropic kernel, on a new grid.

    source:   (6, S_s, S_s, C) float32 cube
    out_size: S_m, output face size (a power of two)
    weight:   in-place function of e = 1 - r.d ((rows, n) float32) -> float32 weights, zero
              outside the kernel's support
    reach:    the kernel's support half-angle in radians (no weight beyond it)
    workers:  threads
    warp:     filter at the edge fixup's stretched directions (``_output_directions``)
    returns   (6, S_m, S_m, C) float32: sum w(r.d) L(d) dOmega / sum w(r.d) dOmega; where no
              source texel has weight, the seamless bilinear sample of the source at r
    """
    s_src = source.shape[1]
    c = source.shape[-1]
    dirs, dirs32, omega = _source_tables(s_src)
    out_dirs, targets, tiles = _output_tiles(out_size, _tile_size(out_size, s_src, reach),
                                             warp)
    values = np.ascontiguousarray(source, np.float32).reshape(-1, c)
    out = np.empty((6, out_size * out_size, c), np.float32)
    n_all = len(dirs)
    blas = threading.Lock()

    def run(item):
        texels, syms = item
        k = len(syms)
        r = out_dirs[texels]
        centre = r.sum(axis=0)
        centre /= np.linalg.norm(centre)
        spread = float(np.arccos(np.clip((r @ centre).min(), -1.0, 1.0)))
        bound = reach + spread + 1e-6
        if bound >= math.pi:
            idx = np.arange(n_all)
        else:
            cosine = dirs32[:, 0] * np.float32(centre[0])
            cosine += dirs32[:, 1] * np.float32(centre[1])
            cosine += dirs32[:, 2] * np.float32(centre[2])
            idx = np.flatnonzero(cosine >= np.float32(math.cos(bound) - 1e-6))
        n = len(idx)
        # Source values seen by the 6 faces x k symmetries of the tile, as columns (n, 6 k C).
        cols = (np.arange(6)[:, None] * 8 + syms[None, :]).ravel()
        v = np.take(values, _permuted_indices(idx, cols, s_src), axis=0).reshape(n, 6 * k * c)
        # e = 1 - r.d = h_r + h_d - h_r h_d - x_r x_d - y_r y_d in the tile's frame: a rank-5
        # product of small terms, accurate in float32 where 1 - r.d is not.
        t1 = np.cross(centre, [1.0, 0.0, 0.0] if abs(centre[0]) < 0.9 else [0.0, 1.0, 0.0])
        t1 /= np.linalg.norm(t1)
        frame = np.stack([t1, np.cross(centre, t1), centre])
        xr, yr, hr = _local_terms(r, frame)
        xd, yd, hd = _local_terms(dirs[idx], frame)
        lhs = np.stack([hr, np.ones_like(hr), -hr, -xr, -yr], axis=1).astype(np.float32)
        rhs = np.stack([np.ones_like(hd), hd, hd, xd, yd]).astype(np.float32)
        w_omega = omega[idx]
        rows = max(1, min(len(texels), _BLOCK_ENTRIES // max(1, n)))
        for r0 in range(0, len(texels), rows):
            r1 = min(len(texels), r0 + rows)
            with blas:
                e = lhs[r0:r1] @ rhs
            w = weight(e)
            w *= w_omega
            den = w.sum(axis=1, dtype=np.float64)
            with blas:
                num = w @ v  # (rows, 6 k C)
            empty = ~(den > 0.0)
            res = num / np.where(empty, 1.0, den).astype(np.float32)[:, None]
            res = res.reshape(r1 - r0, 6, k, c)
            if empty.any():
                miss = np.flatnonzero(empty)
                for gk, g in enumerate(syms):
                    tgt = targets[g, texels[r0 + miss]]
                    for f in range(6):
                        face_dirs = _output_directions(out_size, warp)[f].reshape(-1, 3)
                        res[miss, f, gk] = cubemap.sample(source, face_dirs[tgt])
            for gk, g in enumerate(syms):
                out[:, targets[g, texels[r0:r1]], :] = res[:, :, gk, :].transpose(1, 0, 2)

    if workers > 1 and len(tiles) > 1:
        with ThreadPoolExecutor(max_workers=workers) as pool:
            list(pool.map(run, tiles))
    else:
        for item in tiles:
            run(item)
    return out.reshape(6, out_size, out_size, c)


def _check_cube(cube) -> np.ndarray:
    cube = np.asarray(cube, np.float32)
    if cube.ndim != 4 or cube.shape[0] != 6 or cube.shape[1] != cube.shape[2]:
        raise ValueError(f"expected a (6, S, S, C) cube map, got shape {cube.shape}")
    _mip_count(cube.shape[1])
    return np.ascontiguousarray(np.nan_to_num(cube, nan=0.0, posinf=0.0, neginf=0.0))


# ---------------------------------------------------------------------------------------------
# Public filters


def prefilter_cosine_power(
    cube,
    *,
    cutoff: float = 1e-4,
    texels_per_sigma: float = 4.0,
    min_source: int = 32,
    workers: int = 2,
) -> list[np.ndarray]:
    """BO2 prefiltered mip chain: mip m convolved with the Phong lobe (r.d)^p_m, p_m = 8192^g_m / 4.

    Slide "Improved environment map pre-filtering" (cosine power filter, each mip filtered with
    the matching gloss, alpha_phong = alpha_blinn_phong / 4), with the mip <-> gloss mapping of
    slide "Black Ops: environment map pre-filtering" (g_m = 1 - m / M, ``mip_gloss``). Each
    output texel r gets sum (r.d)^p L(d) dOmega(d) / sum (r.d)^p dOmega(d) over the source
    texels d where (r.d)^p >= cutoff; mip m reads the coarsest level of the source pyramid whose
    face size is at least 2 texels_per_sigma sqrt(p_m) (texel spacing 2 / S_src <= sigma /
    texels_per_sigma, sigma = 1 / sqrt(p_m)), at least the mip's own size and at least
    min_source (or the input's size if smaller). See the module docstring for the method.

    cube:             (6, S, S, C) float32 radiance, S a power of two, ``cubemap.FACES`` layout
    cutoff:           relative lobe weight below which source texels are skipped
    texels_per_sigma: source texels per lobe standard deviation (accuracy vs time)
    min_source:       smallest source face size used for the wide lobes
    workers:          threads
    returns:          list of M + 1 float32 arrays (6, S >> m, S >> m, C), M = log2(S)
    """
    return prefilter_powers(cube, mip_powers(cube.shape[1]), cutoff=cutoff,
                            texels_per_sigma=texels_per_sigma, min_source=min_source,
                            workers=workers)


def prefilter_powers(
    cube,
    powers,
    *,
    cutoff: float = 1e-4,
    texels_per_sigma: float = 4.0,
    min_source: int = 32,
    workers: int = 2,
    warp: bool = False,
    exclude_base: bool = False,
    should_stop=None,
) -> list[np.ndarray]:
    """A mip chain whose mip m is the cube convolved with the Phong lobe (r.d)^powers[m]
    (``prefilter_cosine_power``'s method, any powers: cmft's ``cmft_powers`` for instance).

    cube:         (6, S, S, C) float32 radiance, S a power of two
    powers:       (N,) Phong exponents of mips 0 .. N - 1, N <= log2(S) + 1
    warp:         filter at the edge fixup's directions (``_output_directions``)
    exclude_base: mip 0 is the input itself, unfiltered (cmft's ``excludeBase``)
    should_stop:  called before each mip; True stops with ``InterruptedError``
    returns:      list of N float32 arrays (6, S >> m, S >> m, C)
    """
    cube = _check_cube(cube)
    size = cube.shape[1]
    powers = [float(p) for p in np.atleast_1d(powers)]
    if not 1 <= len(powers) <= _mip_count(size) + 1 or not all(p > 0 for p in powers):
        raise ValueError(f"expected 1 to {_mip_count(size) + 1} positive powers for a face "
                         f"of {size}, got {powers}")
    pyramid = cubemap.build_pyramid(cube)
    mips = []
    for m, power in enumerate(powers):
        if should_stop is not None and should_stop():
            raise InterruptedError("prefiltering stopped")
        out_size = size >> m
        if m == 0 and exclude_base:
            mips.append(cube.copy())
            continue
        want = 2.0 * texels_per_sigma * math.sqrt(power)
        src_size = 1 << max(0, math.ceil(math.log2(max(want, 1.0)) - 1e-9))
        src_size = min(size, max(src_size, out_size, min(min_source, size)))
        source = pyramid[_mip_count(size) - _mip_count(src_size)]
        reach = cone_angle(power, cutoff)
        mips.append(_filter_level(source, out_size, _weights_phong(power, cutoff), reach,
                                  workers, warp))
    return mips


CMFT_MODELS = ("phong", "phongbrdf", "blinn", "blinnbrdf")


def cmft_powers(mip_count: int, gloss_scale: float = 10.0, gloss_bias: float = 1.0,
                model: str = "blinnbrdf") -> np.ndarray:
    """Phong exponents of the mips of cmft's radiance filter (Manesku, cmft, "specularPowerFor"
    and "applyLightningModel"): gloss g_m = max(0, 1 - m / (N - 1)), specular power
    2^(glossScale g_m + glossBias), then by lighting model: phong p, phongbrdf p + 1, blinn
    p / 4, blinnbrdf p / 4 + 1 (Lagarde 2012, the Blinn-Phong to Phong conversion). The BO2
    chain (slide "Improved environment map pre-filtering") is blinn with glossScale 13,
    glossBias 0 (8192^g / 4) over the whole chain. Defaults: cmft's.

    mip_count: N >= 1
    returns:   (N,) float64 Phong exponents
    """
    if model not in CMFT_MODELS:
        raise ValueError(f"lighting model {model!r}: expected one of {', '.join(CMFT_MODELS)}")
    m = np.arange(int(mip_count), dtype=np.float64)
    gloss = np.maximum(0.0, 1.0 - m / (mip_count - 1.0)) if mip_count > 1 else np.ones(1)
    power = 2.0 ** (gloss_scale * gloss + gloss_bias)
    if model.startswith("blinn"):
        power = power / 4.0
    return power + 1.0 if model.endswith("brdf") else power


def prefilter_angular_gaussian(
    cube,
    base_angle: float = DEFAULT_BASE_ANGLE,
    initial_mip_angle: float = DEFAULT_INITIAL_MIP_ANGLE,
    mip_angle_scale: float = DEFAULT_MIP_ANGLE_SCALE,
    *,
    workers: int = 2,
    warp: bool = False,
) -> list[np.ndarray]:
    """BO1 prefiltered mip chain: AMD CubeMapGen's angular Gaussian cascade.

    Slide "Black Ops: environment map pre-filtering" (offline CubeMapGen, angular Gaussian
    filter). Mip 0 filters the input with the cone angle ``base_angle``; mip m >= 1 filters mip
    m - 1 with initial_mip_angle * mip_angle_scale^(m - 1). A pass of half-angle h (clamped to
    [atan(1 / S_src), 90 degrees]) averages the source texels within h of the output direction
    with weights dOmega exp(-theta^2 / (2 sigma^2)), sigma = h / 3, renormalized; where no
    source texel centre lies within h, the output is the seamless bilinear sample of the source.
    ``angular_gaussian_angles`` gives each mip's angles; the module docstring lists the
    differences from CubeMapGen.

    cube:              (6, S, S, C) float32 radiance, S a power of two
    base_angle:        cone angle of mip 0, degrees (CubeMapGen "Base Filter Angle")
    initial_mip_angle: cone angle of mip 1, degrees ("Initial Mip Filter Angle")
    mip_angle_scale:   ratio of successive cone angles ("Mip Filter Angle Scale")
    workers:           threads
    warp:              filter at the edge fixup's directions (``_output_directions``)
    returns:           list of M + 1 float32 arrays (6, S >> m, S >> m, C)
    """
    cube = _check_cube(cube)
    size = cube.shape[1]
    half_angles, _ = angular_gaussian_angles(size, base_angle, initial_mip_angle,
                                             mip_angle_scale)
    mips = []
    source = cube
    for m, half in enumerate(half_angles):
        h = math.radians(float(half))
        edge = h * (1.0 + _EDGE_TOLERANCE)
        weight = _weights_gaussian(h / 3.0, edge)
        level = _filter_level(source, size >> m, weight, edge, workers, warp)
        mips.append(level)
        source = level
    return mips
