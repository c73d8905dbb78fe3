"""The filtering of a cube map by a lobe around each texel's direction, seamless: the gather
that both prefiltered chains (``prefilter``) run.

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


def mip_count(size: int) -> int:
    """M = log2(S) for a power-of-two face size S."""
    size = int(size)
    if size < 1 or size & (size - 1):
        raise ValueError(f"cube face size must be a power of two, got {size}")
    return size.bit_length() - 1


# Weight-matrix entries per block of a tile's rows (1 MB of float32, cache-sized).
_BLOCK_ENTRIES = 1 << 18
# Relative tolerance of the BO1 cone's edge: theta <= h (1 + tol) is inside.
EDGE_TOLERANCE = 1e-5
# Side of the output tiles that share one weight matrix.
_MAX_TILE = 32


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


def weights_phong(power: float, cutoff: float):
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


def weights_gaussian(sigma: float, half_angle: float):
    """BO1 filter as a function of e = 1 - r.d, in place on float32 e:
    exp(-theta^2 / (2 sigma^2)) for theta <= half_angle, else 0.

    half_angle already includes ``EDGE_TOLERANCE``: texels exactly on the cone's edge (which
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


def filter_level(source: np.ndarray, out_size: int, weight, reach: float,
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


def check_cube(cube) -> np.ndarray:
    cube = np.asarray(cube, np.float32)
    if cube.ndim != 4 or cube.shape[0] != 6 or cube.shape[1] != cube.shape[2]:
        raise ValueError(f"expected a (6, S, S, C) cube map, got shape {cube.shape}")
    mip_count(cube.shape[1])
    return np.ascontiguousarray(np.nan_to_num(cube, nan=0.0, posinf=0.0, neginf=0.0))
