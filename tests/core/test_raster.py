"""Tests of the vectorized rasterizer against independently computed values.

Independent references used here:
- analytic areas of polygons given in window coordinates, and per-pixel point-in-polygon tests
  with a safety margin (so samples exactly on an edge are left to the fill rule);
- per-pixel ray-plane and ray-triangle (Moller & Trumbore 1997) intersections for a pinhole
  camera with an OpenGL perspective projection, for perspective-correct attributes, view depth
  and near-plane clipping;
- summed coverage of triangles rasterized one at a time, for the fill rule (exactly one).
"""

import warnings

import numpy as np
import pytest

from bo2_lighting.addon.core.render import projection, raster, transparency

# --------------------------------------------------------------------------------------------
# helpers


def win_to_clip(pts, width, height, z=0.0, w=1.0):
    """Window coordinates (..., 2) (x right, y down from the top edge) -> clip (..., 4).

    z is NDC depth; w scales the homogeneous coordinates (the projection is unchanged).
    """
    pts = np.asarray(pts, np.float64)
    xn = 2.0 * pts[..., 0] / width - 1.0
    yn = 1.0 - 2.0 * pts[..., 1] / height
    z = np.broadcast_to(z, xn.shape)
    w = np.broadcast_to(w, xn.shape)
    return np.stack([xn * w, yn * w, z * w, w], axis=-1)


def perspective(fovy, aspect, near, far):
    """OpenGL perspective matrix (4, 4), camera at the origin looking down -Z, Y up."""
    f = 1.0 / np.tan(fovy / 2.0)
    return np.array(
        [
            [f / aspect, 0.0, 0.0, 0.0],
            [0.0, f, 0.0, 0.0],
            [0.0, 0.0, (far + near) / (near - far), 2.0 * far * near / (near - far)],
            [0.0, 0.0, -1.0, 0.0],
        ]
    )


def to_clip(world, proj):
    """(..., 3) camera-space points -> (..., 4) clip coordinates."""
    h = np.concatenate([world, np.ones(world.shape[:-1] + (1,))], axis=-1)
    return h @ proj.T


def pixel_rays(width, height, fovy, offset=(0.5, 0.5)):
    """(H, W, 3) ray directions through the pixel samples, with z = -1 (so t = view depth)."""
    f = 1.0 / np.tan(fovy / 2.0)
    aspect = width / height
    c = np.arange(width) + offset[0]
    r = np.arange(height) + offset[1]
    dx = (2.0 * c / width - 1.0) * aspect / f
    dy = (1.0 - 2.0 * r / height) / f
    d = np.empty((height, width, 3))
    d[..., 0] = dx[None, :]
    d[..., 1] = dy[:, None]
    d[..., 2] = -1.0
    return d


def sample_grid(width, height, offset=(0.5, 0.5)):
    """(H, W) x and y window coordinates of the pixel samples."""
    return np.meshgrid(np.arange(width) + offset[0], np.arange(height) + offset[1])


def inside_convex(poly, xs, ys, margin):
    """Point-in-convex-polygon with a margin (pixels): +1 inside, -1 outside, 0 on the fence.

    poly: (K, 2) window-space corners in either winding.
    """
    poly = np.asarray(poly, np.float64)
    p, q = poly, np.roll(poly, -1, axis=0)
    area2 = np.sum(p[:, 0] * q[:, 1] - q[:, 0] * p[:, 1])
    s = np.sign(area2)
    dist = []
    for (x0, y0), (x1, y1) in zip(p, q, strict=True):
        length = np.hypot(x1 - x0, y1 - y0)
        dist.append(s * ((x1 - x0) * (ys - y0) - (y1 - y0) * (xs - x0)) / length)
    dmin = np.min(dist, axis=0)
    return np.where(dmin > margin, 1, np.where(dmin < -margin, -1, 0))


def ray_triangle(d, p0, p1, p2):
    """Moller-Trumbore for rays from the origin: barycentrics (u, v) of p1, p2 and t, (H, W)."""
    e1, e2 = p1 - p0, p2 - p0
    pvec = np.cross(d, e2)
    det = pvec @ e1
    tvec = -p0
    u = np.einsum("hwk,k->hw", pvec, tvec) / det
    qvec = np.cross(tvec, e1)
    v = (d * qvec).sum(-1) / det
    t = (qvec @ e2) / det
    return u, v, t


def summed_coverage(clip, width, height, **kw):
    """Coverage count per pixel, each triangle rasterized on its own."""
    total = np.zeros((height, width), np.int32)
    for tri in clip:
        total += raster.coverage(raster.rasterize(tri[None], width, height, **kw))
    return total


# --------------------------------------------------------------------------------------------
# orientation, sample position, area


def test_row_zero_is_top_and_column_zero_is_left():
    w, h = 40, 30
    # a triangle in the top-left quadrant of NDC (x < 0, y > 0)
    clip = np.array([[[-0.9, 0.1, 0, 1], [-0.1, 0.1, 0, 1], [-0.5, 0.9, 0, 1]]], np.float32)
    cov = raster.coverage(raster.rasterize(clip, w, h))
    rows, cols = np.nonzero(cov)
    assert rows.size > 0
    assert rows.max() < h // 2 and cols.max() < w // 2


@pytest.mark.parametrize(
    "offset, cols, rows",
    [((0.5, 0.5), [2, 3, 4, 5], [1, 2]), ((0.1, 0.1), [3, 4, 5, 6], [2, 3])],
)
def test_sample_offset_measured_from_top_left(offset, cols, rows):
    # rectangle x in [2.25, 6.25], y in [1.25, 3.25] (window, from the top-left corner)
    x0, x1, y0, y1 = 2.25, 6.25, 1.25, 3.25
    quad = np.array([[x0, y0], [x0, y1], [x1, y1], [x1, y0]])
    clip = win_to_clip(quad[[[0, 1, 2], [0, 2, 3]]], 16, 8).astype(np.float32)
    cov = raster.coverage(raster.rasterize(clip, 16, 8, sample_offset=offset))
    expect = np.zeros((8, 16), bool)
    expect[np.ix_(rows, cols)] = True
    np.testing.assert_array_equal(cov, expect)


def test_covered_count_matches_analytic_area():
    w, h = 512, 384
    # rotated rectangle 300 x 170 px, area 51000 px^2, perimeter 940 px
    ang = 0.3
    u = np.array([np.cos(ang), np.sin(ang)])
    v = np.array([-np.sin(ang), np.cos(ang)])
    c = np.array([250.3, 190.7])
    quad = np.array(
        [c - 150 * u - 85 * v, c + 150 * u - 85 * v, c + 150 * u + 85 * v, c - 150 * u + 85 * v]
    )
    clip = win_to_clip(quad[[[0, 1, 2], [0, 2, 3]]], w, h).astype(np.float32)
    frags = raster.rasterize(clip, w, h)
    cov = raster.coverage(frags)
    assert abs(int(cov.sum()) - 300 * 170) <= 940
    xs, ys = sample_grid(w, h)
    side = inside_convex(quad, xs, ys, margin=1e-3)
    assert np.all(cov[side == 1]) and not np.any(cov[side == -1])
    # a single large triangle: area by the shoelace formula
    tri = np.array([[20.2, 370.1], [500.7, 300.4], [130.9, 10.6]])
    cov = raster.coverage(raster.rasterize(win_to_clip(tri[None], w, h), w, h))
    (ax, ay), (bx, by) = tri[1] - tri[0], tri[2] - tri[0]
    area = 0.5 * abs(ax * by - ay * bx)
    perimeter = np.sum(np.linalg.norm(tri - np.roll(tri, 1, axis=0), axis=1))
    assert abs(int(cov.sum()) - area) <= perimeter


# --------------------------------------------------------------------------------------------
# fill rule: shared edges and vertices are covered exactly once


@pytest.mark.parametrize("w_mode", ["affine", "perspective"])
def test_quad_split_along_diagonal_covers_each_pixel_once(w_mode):
    w, h = 64, 64
    # corners on sample centres: the diagonal (10.5, 10.5) -> (50.5, 30.5) passes through samples
    quad = np.array([[10.5, 10.5], [10.5, 40.5], [50.5, 30.5], [50.5, 3.5]])
    ws = np.array([1.0, 1.0, 1.0, 1.0]) if w_mode == "affine" else np.array([1.0, 2.5, 0.7, 4.0])
    corners = win_to_clip(quad, w, h, z=0.0, w=ws)
    clip = corners[[[0, 1, 2], [0, 2, 3]]].astype(np.float32)
    total = summed_coverage(clip, w, h)
    assert total.max() == 1
    xs, ys = sample_grid(w, h)
    side = inside_convex(quad, xs, ys, margin=1e-6)
    assert np.all(total[side == 1] == 1) and np.all(total[side == -1] == 0)
    # samples on the diagonal exist and are covered once
    diag = ((xs - 10.5) * 20.0 == (ys - 10.5) * 40.0) & (xs > 10.5) & (xs < 50.5)
    assert diag.sum() >= 10 and np.all(total[diag] == 1)
    np.testing.assert_array_equal(raster.coverage(raster.rasterize(clip, w, h)), total > 0)


@pytest.mark.parametrize("seed", range(6))
def test_triangle_fan_covers_each_pixel_once(seed):
    w, h = 64, 64
    rng = np.random.default_rng(seed)
    centre = np.array([32.5, 32.5])  # a sample centre
    spokes = np.array(
        [[20, 0], [20, 20], [0, 20], [-20, 20], [-20, 0], [-20, -20], [0, -20], [20, -20]],
        np.float64,
    )
    rim = centre + spokes
    pts = np.concatenate([centre[None], rim])
    ws = rng.uniform(0.5, 3.0, len(pts))
    corners = win_to_clip(pts, w, h, z=0.0, w=ws)
    idx = np.array([[0, 1 + k, 1 + (k + 1) % 8] for k in range(8)])
    flip = rng.random(8) < 0.5  # mixed winding: the fill rule must not depend on it
    idx[flip] = idx[flip][:, ::-1]
    clip = corners[idx].astype(np.float32)
    total = summed_coverage(clip, w, h)
    assert total.max() == 1
    assert total[32, 32] == 1  # the shared vertex itself
    xs, ys = sample_grid(w, h)
    side = inside_convex(rim, xs, ys, margin=1e-6)
    assert np.all(total[side == 1] == 1) and np.all(total[side == -1] == 0)


def test_random_mesh_is_watertight():
    """A jittered grid mesh with perspective w: every sample inside is covered exactly once."""
    w, h = 96, 80
    rng = np.random.default_rng(7)
    n = 9
    gx, gy = np.meshgrid(np.linspace(8, 88, n), np.linspace(6, 74, n))
    pts = np.stack([gx, gy], -1)
    pts[1:-1, 1:-1] += rng.uniform(-3, 3, (n - 2, n - 2, 2))
    pts = pts.reshape(-1, 2)
    ws = rng.uniform(0.5, 2.0, len(pts))
    corners = win_to_clip(pts, w, h, z=0.0, w=ws)
    i = np.arange(n - 1)
    a = (i[:, None] * n + i[None, :]).ravel()
    tris = np.concatenate([np.stack([a, a + n, a + n + 1], 1), np.stack([a, a + n + 1, a + 1], 1)])
    clip = corners[tris].astype(np.float32)
    total = summed_coverage(clip, w, h)
    assert total.max() == 1
    xs, ys = sample_grid(w, h)
    assert np.all(total[(xs > 8) & (xs < 88) & (ys > 6) & (ys < 74)] == 1)
    assert np.all(total[(xs < 8) | (xs > 88) | (ys < 6) | (ys > 74)] == 0)


def test_guard_band_clipping_keeps_coverage_and_attributes():
    """Corners millions of pixels off screen: clipped to the guard band, still exact."""
    w, h = 64, 48
    a = np.array([[-3.0e6, -2.9e6], [40.7, -2.0e6], [50.2, 45.1]])
    b = np.array([[-3.0e6, -2.9e6], [50.2, 45.1], [-4.0e6, 5.0e6]])  # shares the edge 0-2 with a
    clip = win_to_clip(np.stack([a, b]), w, h)
    frags = raster.rasterize(clip, w, h)
    xs, ys = sample_grid(w, h)
    for k, tri in enumerate((a, b)):
        side = inside_convex(tri, xs, ys, margin=1e-3)
        assert np.any(side == 1)
        assert np.all(frags.tri[side == 1] == k) and not np.any(frags.tri[side == -1] == k)
    total = summed_coverage(clip, w, h)
    assert total.max() == 1
    # window coordinates of the corners interpolate to the sample's (affine projection)
    got = raster.interpolate(frags, np.stack([a, b]))
    hit = raster.coverage(frags)
    assert hit.sum() > 0.2 * w * h
    np.testing.assert_allclose(got[hit], np.stack([xs[hit], ys[hit]], -1), rtol=1e-5)


@pytest.mark.parametrize("near", [0.1, 1e-3])
def test_ground_grid_through_the_near_plane_is_watertight(near):
    """A grid on the ground plane y = -1 running under and behind the camera."""
    w, h = 96, 64
    fovy = np.radians(60.0)
    proj = perspective(fovy, w / h, near, 100.0)
    n = 7
    gx, gz = np.meshgrid(np.linspace(-20.0, 20.0, n), np.linspace(6.0, -30.0, n))
    pts = np.stack([gx, np.full_like(gx, -1.0), gz], -1).reshape(-1, 3)
    corners = to_clip(pts, proj)
    i = np.arange(n - 1)
    a = (i[:, None] * n + i[None, :]).ravel()
    tris = np.concatenate([np.stack([a, a + n, a + n + 1], 1), np.stack([a, a + n + 1, a + 1], 1)])
    clip = corners[tris].astype(np.float32)
    total = summed_coverage(clip, w, h)
    assert total.max() == 1
    d = pixel_rays(w, h, fovy)
    with np.errstate(divide="ignore", invalid="ignore"):
        t = -1.0 / d[..., 1]  # ray hits y = -1 at view depth t
    hit_x = t * d[..., 0]
    m = 1e-6
    surely_in = (t > near * (1 + m)) & (np.abs(hit_x) < 20.0 - m) & (t < 30.0 - m)
    surely_out = ~((t > near * (1 - m)) & (np.abs(hit_x) < 20.0 + m) & (t < 30.0 + m))
    assert surely_in.sum() > 0.3 * w * h
    assert np.all(total[surely_in] == 1) and np.all(total[surely_out] == 0)
    frags = raster.rasterize(clip, w, h)
    np.testing.assert_array_equal(raster.coverage(frags), total > 0)
    got = raster.interpolate(frags, pts[tris].astype(np.float32))
    expect = t[..., None] * d
    cov = total > 0
    err = np.linalg.norm(got - expect, axis=-1) / np.linalg.norm(expect, axis=-1)
    assert err[cov].max() < 1e-4


# --------------------------------------------------------------------------------------------
# perspective-correct interpolation and depth


def test_perspective_correct_interpolation_matches_ray_plane_intersection():
    w, h = 160, 120
    fovy, near, far = np.radians(60.0), 0.1, 100.0
    proj = perspective(fovy, w / h, near, far)
    # a quad on a plane tilted in depth, from z = -1.5 to z = -12
    quad = np.array([[-2.0, -1.2, -1.5], [2.5, -1.0, -1.5], [3.0, 2.0, -12.0], [-3.0, 1.5, -12.0]])
    quad[3] = quad[0] + quad[2] - quad[1]  # make it planar
    tris = quad[[[0, 1, 2], [0, 2, 3]]]
    clip = to_clip(tris, proj).astype(np.float32)
    frags = raster.rasterize(clip, w, h)
    hit = raster.coverage(frags)
    assert hit.sum() > 0.2 * w * h

    d = pixel_rays(w, h, fovy)
    n = np.cross(quad[1] - quad[0], quad[2] - quad[0])
    t = (quad[0] @ n) / (d @ n)
    expect = t[..., None] * d
    got = raster.interpolate(frags, tris.astype(np.float32))
    err = np.linalg.norm(got - expect, axis=-1) / np.linalg.norm(expect, axis=-1)
    assert err[hit].max() < 1e-4
    assert np.all(got[~hit] == 0)
    np.testing.assert_allclose(frags.depth[hit], t[hit], rtol=1e-5)  # depth = clip w = -z_view
    assert np.all(np.isinf(frags.depth[~hit]))
    bary = frags.bary[hit]
    np.testing.assert_allclose(bary.sum(-1), 1.0, atol=1e-6)

    # the same attribute interpolated linearly in screen space is visibly wrong
    ndc = clip[..., :2] / clip[..., 3:]
    win = np.stack([(ndc[..., 0] + 1) * w / 2, (1 - ndc[..., 1]) * h / 2], -1).astype(np.float64)
    xs, ys = sample_grid(w, h)
    tv = win[frags.tri[hit]]  # (n, 3, 2)
    p = np.stack([xs[hit], ys[hit]], -1)

    def cross2(a, b):
        return a[..., 0] * b[..., 1] - a[..., 1] * b[..., 0]

    area = cross2(tv[:, 1] - tv[:, 0], tv[:, 2] - tv[:, 0])
    l1 = cross2(p - tv[:, 0], tv[:, 2] - tv[:, 0]) / area
    l2 = cross2(tv[:, 1] - tv[:, 0], p - tv[:, 0]) / area
    lin = np.stack([1 - l1 - l2, l1, l2], -1)
    naive = np.einsum("nk,nkc->nc", lin, tris[frags.tri[hit]])
    naive_err = np.linalg.norm(naive - expect[hit], axis=-1) / np.linalg.norm(expect[hit], axis=-1)
    assert naive_err.max() > 1e-2


def test_scalar_attribute_interpolation():
    w, h = 32, 32
    clip = win_to_clip(np.array([[[2.0, 2.0], [30.0, 2.0], [2.0, 30.0]]]), w, h).astype(np.float32)
    frags = raster.rasterize(clip, w, h)
    xs, _ = sample_grid(w, h)
    # an attribute equal to the window x of each corner interpolates to the sample's x (w = 1)
    got = raster.interpolate(frags, np.array([[2.0, 30.0, 2.0]], np.float32))
    hit = raster.coverage(frags)
    assert got.shape == (h, w)
    np.testing.assert_allclose(got[hit], xs[hit], rtol=1e-5)
    assert np.all(got[~hit] == 0)


@pytest.mark.parametrize("mode", ["affine", "perspective"])
def test_depth_test_nearest_wins_in_either_order(mode):
    w, h = 64, 48
    a = np.array([[4.0, 4.0], [50.0, 8.0], [20.0, 44.0]])
    b = np.array([[60.0, 40.0], [14.0, 30.0], [40.0, 2.0]])
    if mode == "affine":  # orthographic-like: w = 1, nearer = smaller z/w
        ca = win_to_clip(a, w, h, z=-0.2)
        cb = win_to_clip(b, w, h, z=0.3)
    else:  # the same window positions, a at view depth 2, b at view depth 5 (z_ndc by proj.)
        proj = perspective(np.radians(50.0), w / h, 0.1, 100.0)

        def at_depth(pts, depth):
            zc, wc = proj[2, 2] * -depth + proj[2, 3], depth
            return win_to_clip(pts, w, h, z=zc / wc, w=wc)

        ca, cb = at_depth(a, 2.0), at_depth(b, 5.0)
    colour = np.array([[1.0, 0.0, 0.0], [0.0, 1.0, 0.0]], np.float32)
    attr_ab = np.repeat(colour[:, None], 3, axis=1)
    img_ab = raster.interpolate(raster.rasterize(np.stack([ca, cb]), w, h), attr_ab)
    img_ba = raster.interpolate(raster.rasterize(np.stack([cb, ca]), w, h), attr_ab[::-1])
    np.testing.assert_array_equal(img_ab, img_ba)
    xs, ys = sample_grid(w, h)
    in_a = inside_convex(a, xs, ys, 1e-6) == 1
    in_b = inside_convex(b, xs, ys, 1e-6) == 1
    assert np.any(in_a & in_b)
    only_b = in_b & ~in_a
    np.testing.assert_allclose(img_ab[in_a] - colour[0], 0.0, atol=1e-6)
    np.testing.assert_allclose(img_ab[only_b] - colour[1], 0.0, atol=1e-6)


def test_far_plane_drops_fragments_beyond_it():
    w, h = 64, 16
    # z/w grows linearly with window x from 0 at x = 0 to 2 at x = 64: visible where x <= 32
    pts = np.array([[0.0, 0.0], [64.0, 0.0], [64.0, 16.0], [0.0, 16.0]])
    z = pts[:, 0] / 32.0
    corners = win_to_clip(pts, w, h, z=z)
    frags = raster.rasterize(corners[[[0, 3, 2], [0, 2, 1]]].astype(np.float32), w, h)
    cov = raster.coverage(frags)
    xs, _ = sample_grid(w, h)
    np.testing.assert_array_equal(cov, xs <= 32.0)


def test_extreme_depths_are_handled_quietly():
    w, h = 32, 32
    pts = np.array([[1.0, 1.0], [31.0, 2.0], [16.0, 30.0]])
    steep = win_to_clip(pts, w, h, z=np.array([0.0, 1e25, 0.0]))  # z/w up to 1e25: past far
    near_edge = win_to_clip(pts + 0.25, w, h, z=np.array([-1.0, -1.0, -1.0]))  # on the near plane
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        frags = raster.rasterize(np.stack([steep]), w, h)
        both = raster.rasterize(np.stack([steep, near_edge]), w, h)
    assert not raster.coverage(frags).any()  # z/w is affine in window space: > 1 at samples
    assert np.all(both.tri[raster.coverage(both)] == 1)  # z/w = -1 is in front of everything


# --------------------------------------------------------------------------------------------
# near-plane clipping


@pytest.mark.parametrize(
    "tri",
    [
        # two corners in front, one behind the camera: clipped into a quad (two triangles)
        [[-3.0, -1.0, -10.0], [3.5, -1.2, -10.0], [0.4, -0.9, 4.0]],
        # one corner in front, two behind: clipped into one triangle
        [[0.3, -1.0, -8.0], [-3.0, -0.8, 3.0], [3.0, -1.1, 2.5]],
        # corners between the eye and the near plane, in view: that part must not be drawn
        [[-0.2, -0.1, -0.3], [0.2, -0.12, -0.3], [0.05, 0.3, -6.0]],
        [[-0.3, -0.1, -4.0], [0.3, -0.15, -4.0], [0.0, 0.1, -0.2]],
    ],
)
def test_near_plane_clipping_keeps_exact_coverage_and_attributes(tri):
    w, h = 128, 96
    fovy, near, far = np.radians(70.0), 0.5, 50.0
    proj = perspective(fovy, w / h, near, far)
    tri = np.array(tri)
    clip = to_clip(tri, proj)[None].astype(np.float32)
    assert np.any(clip[0, :, 2] < -clip[0, :, 3]) and np.any(clip[0, :, 2] > -clip[0, :, 3])
    frags = raster.rasterize(clip, w, h)
    hit = raster.coverage(frags)

    d = pixel_rays(w, h, fovy)
    u, v, t = ray_triangle(d, tri[0], tri[1], tri[2])
    m = 1e-5
    surely_in = (u > m) & (v > m) & (1 - u - v > m) & (t > near * (1 + m))
    surely_out = (u < -m) | (v < -m) | (1 - u - v < -m) | (t < near * (1 - m))
    assert surely_in.sum() > 100
    assert np.all(hit[surely_in]) and not np.any(hit[surely_out])
    in_view_before_near = (u > m) & (v > m) & (1 - u - v > m) & (t > 0) & (t < near * (1 - m))
    if tri[:, 2].max() < 0:  # every corner ahead of the eye: part of it is in view before near
        assert in_view_before_near.sum() > 50

    expect = t[..., None] * d
    got = raster.interpolate(frags, tri[None].astype(np.float32))
    err = np.linalg.norm(got - expect, axis=-1) / np.linalg.norm(expect, axis=-1)
    assert err[hit].max() < 1e-4
    np.testing.assert_allclose(frags.depth[hit], t[hit], rtol=1e-5)
    # perspective-correct weights of the original corners, against Moller-Trumbore's
    np.testing.assert_allclose(frags.bary[hit][:, 1], u[hit], atol=1e-4)
    np.testing.assert_allclose(frags.bary[hit][:, 2], v[hit], atol=1e-4)


def test_triangles_outside_the_frustum_are_dropped():
    w, h = 32, 32
    clip = np.array(
        [
            [[2.0, 0, 0, 1], [3.0, 0, 0, 1], [2.5, 1, 0, 1]],  # right of the frustum
            [[0, 0, -2.0, 1], [0.5, 0, -2.0, 1], [0, 0.5, -3.0, 1]],  # in front of near
            [[0, 0, 0.5, -1], [0.5, 0, 0.5, -1], [0, 0.5, 0.5, -1]],  # behind the camera
        ],
        np.float32,
    )
    frags = raster.rasterize(clip, w, h)
    assert not raster.coverage(frags).any()
    assert frags.skipped_degenerate == 0 and frags.skipped_nan == 0


# --------------------------------------------------------------------------------------------
# culling and degenerate input


def test_backface_culling_with_mask():
    w, h = 64, 32
    front = [[-0.9, -0.8, 0, 1], [-0.1, -0.8, 0, 1], [-0.5, 0.8, 0, 1]]  # CCW, y up
    back = [[0.1, -0.8, 0, 1], [0.5, 0.8, 0, 1], [0.9, -0.8, 0, 1]]  # CW, y up
    clip = np.array([front, back], np.float32)
    none = raster.rasterize(clip, w, h)
    assert set(np.unique(none.tri)) == {-1, 0, 1}
    both = raster.rasterize(clip, w, h, cull=np.array([True, True]))
    assert set(np.unique(both.tri)) == {-1, 0}
    np.testing.assert_array_equal(both.tri == 0, none.tri == 0)
    only_front_flagged = raster.rasterize(clip, w, h, cull=np.array([True, False]))
    np.testing.assert_array_equal(only_front_flagged.tri, none.tri)


def test_nan_and_zero_area_triangles_are_skipped_and_counted():
    w, h = 48, 48
    good_a = win_to_clip(np.array([[2.0, 2.0], [40.0, 5.0], [10.0, 30.0]]), w, h, z=0.1)
    good_b = win_to_clip(np.array([[45.0, 45.0], [20.0, 44.0], [44.0, 12.0]]), w, h, z=0.2)
    nan = good_a.copy()
    nan[1, 0] = np.nan
    inf = good_b.copy()
    inf[2, 3] = np.inf
    collinear = win_to_clip(np.array([[1.0, 1.0], [20.0, 20.0], [40.0, 40.0]]), w, h)
    repeated = win_to_clip(np.array([[5.0, 40.0], [5.0, 40.0], [30.0, 20.0]]), w, h)
    zeros = np.zeros((3, 4))  # w = 0: no window-space position at all
    clip = np.stack([good_a, nan, collinear, inf, repeated, zeros, good_b]).astype(np.float32)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        frags = raster.rasterize(clip, w, h)
        ref = raster.rasterize(np.stack([good_a, good_b]).astype(np.float32), w, h)
    assert frags.skipped_nan == 2
    assert frags.skipped_degenerate == 3
    expect_tri = np.where(ref.tri < 0, -1, np.where(ref.tri == 0, 0, 6))
    np.testing.assert_array_equal(frags.tri, expect_tri)
    np.testing.assert_array_equal(frags.bary, ref.bary)
    np.testing.assert_array_equal(frags.depth, ref.depth)


def test_empty_input():
    frags = raster.rasterize(np.zeros((0, 3, 4), np.float32), 8, 4)
    assert frags.tri.shape == (4, 8) and frags.bary.shape == (4, 8, 3)
    assert np.all(frags.tri == -1) and np.all(np.isinf(frags.depth))
    assert raster.interpolate(frags, np.zeros((0, 3, 2))).shape == (4, 8, 2)


# --------------------------------------------------------------------------------------------
# scale: big triangles, many triangles, independence from tiling


def test_full_screen_quad_at_4k():
    w, h = 3840, 2160
    quad = np.array([[-1.0, -1.0], [1.0, -1.0], [1.0, 1.0], [-1.0, 1.0]])
    corners = np.concatenate([quad, np.full((4, 1), 0.5), np.ones((4, 1))], axis=1)
    clip = corners[[[0, 1, 2], [0, 2, 3]]].astype(np.float32)
    frags = raster.rasterize(clip, w, h)
    assert np.all(frags.tri >= 0)
    assert np.all(frags.depth == 1.0)
    # the diagonal from the bottom-left to the top-right corner splits the image in two
    r, c = np.ogrid[:h, :w]
    below = (c + 0.5) / w > 1.0 - (r + 0.5) / h  # below-right of the diagonal, window y down
    on = (c + 0.5) / w == 1.0 - (r + 0.5) / h
    np.testing.assert_array_equal((frags.tri == 0)[~on], below[~on])


def random_tiny_triangles(n, w, h, seed):
    rng = np.random.default_rng(seed)
    centre = rng.uniform([0, 0], [w, h], (n, 1, 2))
    pts = centre + rng.uniform(-3.0, 3.0, (n, 3, 2))
    z = rng.uniform(-0.9, 0.9, (n, 3))
    ws = rng.uniform(1.0, 3.0, (n, 3))
    return win_to_clip(pts, w, h, z=z, w=ws).astype(np.float32)


def test_many_tiny_triangles_independent_of_their_order():
    """The nearest fragment does not depend on the order the triangles come in (random depths:
    no ties), only their indices follow the permutation."""
    w, h = 512, 512
    clip = random_tiny_triangles(100_000, w, h, seed=3)
    cull = np.random.default_rng(4).random(len(clip)) < 0.3
    perm = np.random.default_rng(5).permutation(len(clip))
    a = raster.rasterize(clip, w, h, cull=cull)
    b = raster.rasterize(clip[perm], w, h, cull=cull[perm])
    assert raster.coverage(a).mean() > 0.5
    np.testing.assert_array_equal(a.tri, np.where(b.tri >= 0, perm[b.tri], -1))
    np.testing.assert_array_equal(a.bary, b.bary)
    np.testing.assert_array_equal(a.depth, b.depth)


def test_the_kept_setup_gives_the_same_fragments():
    """The set-up kept for the next sample is reused only for the same input, bit for bit."""
    w, h = 64, 48
    clip = random_tiny_triangles(300, w, h, seed=11)
    clip[:3] = win_to_clip(np.array([[[-20.0, -9.0], [90.0, 3.0], [30.0, 70.0]]] * 3), w, h)
    a = raster.rasterize(clip, w, h, sample_offset=(0.2, 0.9))
    other = clip.copy()
    other[0, 0, 0] = np.nextafter(other[0, 0, 0], np.float32(np.inf))  # one bit differs
    c = raster.rasterize(other, w, h, sample_offset=(0.2, 0.9))
    b = raster.rasterize(clip, w, h, sample_offset=(0.2, 0.9))
    np.testing.assert_array_equal(a.tri, b.tri)
    np.testing.assert_array_equal(a.bary, b.bary)
    np.testing.assert_array_equal(a.depth, b.depth)
    assert not np.array_equal(a.bary, c.bary)


@pytest.mark.parametrize("offset", [(0.5, 0.5), (-0.25, 1.25), (1.0, 0.0)])
def test_float_span_ends_equal_integer_division(monkeypatch, offset):
    """Span ends are floor quotients computed in float64, exact by the bound in the module doc;
    images of 2^20 pixels a side or more divide in int64: the same fragments either way."""
    w, h = 160, 120
    rng = np.random.default_rng(12)
    parts = [random_tiny_triangles(3000, w, h, seed=13)]
    pts = rng.uniform(-2e5, 2e5, (40, 3, 2))  # large, through the guard band
    parts.append(win_to_clip(pts, w, h, z=rng.uniform(-0.9, 0.9, (40, 3))).astype(np.float32))
    grid = np.stack(np.meshgrid(np.arange(0.5, w, 7.0), np.arange(0.5, h, 5.0)), -1)
    p = grid[:-1, :-1].reshape(-1, 2)  # corners on sample centres: edges through samples
    q, r = p + [7.0, 0.0], p + [0.0, 5.0]
    parts.append(win_to_clip(np.stack([p, q, r], 1), w, h, z=0.1).astype(np.float32))
    clip = np.concatenate(parts)
    a = raster.rasterize(clip, w, h, sample_offset=offset)
    monkeypatch.setattr(raster, "_FLOAT_SPANS", 1)
    b = raster.rasterize(clip, w, h, sample_offset=offset)
    assert raster.coverage(a).mean() > 0.5
    np.testing.assert_array_equal(a.tri, b.tri)
    np.testing.assert_array_equal(a.bary, b.bary)
    np.testing.assert_array_equal(a.depth, b.depth)


def test_image_wider_than_float_spans():
    w, h = (1 << 20) + 16, 3
    tri = np.array([[3.3, 0.1], [w - 2.6, 1.2], [200.9, 2.95]])
    cov = raster.coverage(raster.rasterize(win_to_clip(tri[None], w, h), w, h))
    xs, ys = sample_grid(w, h)
    side = inside_convex(tri, xs, ys, margin=0.05)
    assert (side == 1).sum() > 1000
    assert np.all(cov[side == 1]) and not np.any(cov[side == -1])


def test_set_up_kept_for_the_same_input_only():
    """``rasterize`` keeps the set-up of the last input: the same input (another array, another
    sample offset), the same array changed in place, another cull mask or another size must
    all give what a first call gives."""
    w, h = 64, 48
    clip = random_tiny_triangles(400, w, h, seed=14)
    cull = np.random.default_rng(15).random(len(clip)) < 0.5
    other = random_tiny_triangles(10, 8, 8, seed=16)

    def first_call(*args, **kw):
        raster.rasterize(other, 8, 8)  # replaces the kept set-up
        return raster.rasterize(*args, **kw)

    def same(f, g):
        np.testing.assert_array_equal(f.tri, g.tri)
        np.testing.assert_array_equal(f.bary, g.bary)
        np.testing.assert_array_equal(f.depth, g.depth)

    raster.rasterize(clip, w, h, sample_offset=(0.1, 0.2))
    same(raster.rasterize(clip.copy(), w, h), first_call(clip, w, h))
    clip[7, 1, :2] += 0.25
    same(raster.rasterize(clip, w, h), first_call(clip, w, h))
    same(raster.rasterize(clip, w, h, cull=cull), first_call(clip, w, h, cull=cull))
    same(raster.rasterize(clip, w, h, cull=~cull), first_call(clip, w, h, cull=~cull))
    same(raster.rasterize(clip, w + 1, h), first_call(clip, w + 1, h))
    same(raster.rasterize(clip.astype(np.float64), w, h), first_call(clip, w, h))


def test_rasterizing_on_threads_at_once_gives_the_serial_fragments():
    """The kernels release Python's lock and keep no shared state: tiles (and a viewport beside
    a final render) rasterize on several threads at once with the serial results."""
    from concurrent.futures import ThreadPoolExecutor

    w, h = 200, 150
    inputs = [random_tiny_triangles(20_000, w, h, seed=s) for s in range(6)]
    serial = [raster.rasterize(c, w, h, sample_offset=(0.3, 0.6)) for c in inputs]
    with ThreadPoolExecutor(4) as pool:
        threaded = list(pool.map(lambda c: raster.rasterize(c, w, h, sample_offset=(0.3, 0.6)),
                                 inputs * 3))
    for i, frags in enumerate(threaded):
        np.testing.assert_array_equal(frags.tri, serial[i % len(inputs)].tri)
        np.testing.assert_array_equal(frags.bary, serial[i % len(inputs)].bary)


def test_clipped_depths_bound_the_points_inside_the_region():
    """``kernels.raster.clipped_depths`` against dense samples of each triangle: the depths of
    the sampled points inside |x| <= w, |y| <= w, depth >= near lie within its range, and its
    range is theirs to within the sampling step; nothing inside gives (inf, -inf)."""
    from bo2_lighting.addon.core.kernels import raster as kernels

    rng = np.random.default_rng(21)
    rows = np.array([[1.2, 0.1, 0.3, 0.2], [0.0, 1.5, -0.2, 0.1], [0.1, 0.0, -1.0, 0.0],
                     [0.05, 0.0, -1.0, 0.3]])  # x, y, w, depth
    near = 0.5
    n = 120
    i, j = np.meshgrid(np.arange(n + 1), np.arange(n + 1), indexing="ij")
    keep = i + j <= n
    bary = np.stack([i[keep], j[keep], n - i[keep] - j[keep]], 1) / n
    for _ in range(60):
        tri = rng.uniform(-3.0, 3.0, (1, 3, 3))
        tri[0, :, 2] -= rng.uniform(0.0, 4.0)
        lo, hi = kernels.clipped_depths(np.ascontiguousarray(tri), rows, near)
        pts = bary @ tri[0]
        x, y, w, depth = (pts @ rows[:, :3].T + rows[:, 3]).T
        inside = (np.abs(x) <= w) & (np.abs(y) <= w) & (depth >= near)
        if not inside.any():
            assert not lo <= hi or hi - lo < 0.2  # (a sliver between the samples)
            continue
        step = np.ptp(tri[0] @ rows[3, :3]) / n + 1e-9
        assert lo <= depth[inside].min() + 1e-9 and hi >= depth[inside].max() - 1e-9
        assert depth[inside].min() - lo <= 2 * step and hi - depth[inside].max() <= 2 * step
    far = np.ascontiguousarray(np.full((1, 3, 3), 100.0))  # all beyond |x| <= w
    assert kernels.clipped_depths(far, rows, near) == (np.inf, -np.inf)


def test_layers_of_shadow_dither_are_independent():
    """Stacked transparent casters: a texel passes layer k where alpha <= its threshold; over
    a map, k layers of alpha a let (1 - a)^k through (independent thresholds, the product of
    the probabilities), and one layer is stratified in 4 x 4 blocks."""
    py, px = np.divmod(np.arange(256 * 256), 256)
    t = [transparency.ordered_thresholds(px, py, layer)
         for layer in range(transparency.DITHER_LAYERS)]
    for a in (0.25, 0.5, 0.75):
        passed = np.ones(len(px), bool)
        for k in range(min(4, transparency.DITHER_LAYERS)):
            passed &= t[k] >= a
            assert passed.mean() == pytest.approx((1 - a) ** (k + 1), abs=0.015), (a, k)
        for i in range(transparency.DITHER_LAYERS):
            for j in range(i):
                both = ((t[i] >= a) & (t[j] >= a)).mean()
                assert both == pytest.approx((1 - a) ** 2, abs=0.012), (a, i, j)
    for layer in t:
        blocks = (layer >= 0.5).reshape(64, 4, 64, 4).mean((1, 3))
        assert np.abs(blocks - 0.5).mean() < 0.06


@pytest.mark.parametrize("offset", [(0.5, 0.5), (0.1, 0.85)])
def test_large_inputs_in_chunks_give_the_same_fragments(monkeypatch, offset):
    """Inputs too large to keep their set-up are set up a chunk at a time, for one sample
    offset each (triangles whose box holds no sample left out first): the same visible
    triangles as one set-up of the whole, for tiny and large triangles, through the guard
    band and the near plane, with back faces culled, layer after layer of depth peeling, and
    from a ``Projection`` of world triangles."""
    w, h = 96, 64
    rng = np.random.default_rng(21)
    parts = [random_tiny_triangles(20_000, w, h, seed=22)]
    parts[0][::2] *= np.float32(0.05)  # many far smaller than a pixel
    pts = rng.uniform(-2e5, 2e5, (30, 3, 2))
    parts.append(win_to_clip(pts, w, h, z=rng.uniform(-0.9, 0.9, (30, 3))).astype(np.float32))
    clip = np.concatenate(parts)
    clip[5, 0, 3] = -0.5  # a corner behind the camera: clipped at the near plane
    cull = rng.random(len(clip)) < 0.3
    whole = raster.rasterize(clip, w, h, cull=cull, sample_offset=offset)
    whole_next = raster.rasterize(clip, w, h, cull=cull, sample_offset=offset,
                                  behind=whole.keys)
    monkeypatch.setattr(raster, "SETUP_TRIANGLES", 1000)
    monkeypatch.setattr(projection, "CHUNK", 3000)
    parts = raster.rasterize(clip, w, h, cull=cull, sample_offset=offset)
    parts_next = raster.rasterize(clip, w, h, cull=cull, sample_offset=offset,
                                  behind=parts.keys)
    assert raster.coverage(whole).mean() > 0.5 and raster.coverage(whole_next).mean() > 0.2
    for a, b in ((whole, parts), (whole_next, parts_next)):
        # keys quantize depth to fewer levels in chunks: near-ties may go either way
        same = a.tri == b.tri
        assert same.mean() > 0.999, same.mean()
        np.testing.assert_allclose(a.bary[same], b.bary[same], atol=1e-6)
        np.testing.assert_allclose(a.depth[same], b.depth[same], rtol=1e-6)
    world = rng.uniform(-1.0, 1.0, (8000, 3, 3)).astype(np.float32) * [3, 3, 1] + [0, 0, -6]
    proj = perspective(np.radians(50.0), w / h, 0.5, 20.0)
    monkeypatch.setattr(raster, "SETUP_TRIANGLES", 10**9)
    direct = raster.rasterize(projection.project(world, proj, np.float64), w, h)
    monkeypatch.setattr(raster, "SETUP_TRIANGLES", 1000)
    lazy = raster.rasterize(projection.Projection(world, proj), w, h)
    assert raster.coverage(direct).mean() > 0.5
    assert (direct.tri == lazy.tri).mean() > 0.999


@pytest.mark.parametrize("dtype", [np.float32, np.float64])
def test_extent_and_distances_of_casters(dtype):
    """The shadow maps' reductions over every caster, in one pass (no temporary the size of
    the scene), against NumPy over all corners: extents along directions, the nearest plane
    and the farthest corner from a light; a NaN triangle is left out."""
    from bo2_lighting.addon.core.kernels import raster as kernels

    rng = np.random.default_rng(31)
    tris = rng.normal(size=(500, 3, 3)).astype(dtype) * 4.0
    tris[7, 1, 2] = np.nan
    finite = np.isfinite(tris).all(axis=(1, 2))
    rows = rng.normal(size=(3, 4))
    out = np.empty((3, 2))
    kernels.extent(tris, rows, out)
    values = tris[finite].reshape(-1, 3).astype(np.float64) @ rows[:, :3].T + rows[:, 3]
    np.testing.assert_allclose(out[:, 0], values.min(0), rtol=1e-12)
    np.testing.assert_allclose(out[:, 1], values.max(0), rtol=1e-12)
    origin = np.array([0.5, -1.0, 2.0])
    near, far = kernels.distances(tris, origin)
    q = tris[finite].astype(np.float64)
    n = np.cross(q[:, 1] - q[:, 0], q[:, 2] - q[:, 0])
    planes = np.abs(np.einsum("tk,tk->t", n, origin - q[:, 0])) / np.linalg.norm(n, axis=1)
    assert near == pytest.approx(planes.min(), rel=1e-9)
    assert far == pytest.approx(np.linalg.norm(q - origin, axis=-1).max(), rel=1e-12)


def test_place_puts_a_mesh_where_each_instance_is():
    """``kernels.raster.place`` against NumPy per instance: corners through parent @ local
    (local column-major, as Blender stores instance transforms), normals through the inverse
    transpose, world-to-object inverses; a mirrored instance has its corners reversed (fronts
    stay counter-clockwise), a flat one an identity inverse."""
    from bo2_lighting.addon.core.kernels import raster as kernels

    rng = np.random.default_rng(41)
    pos = rng.normal(size=(5, 3, 3)).astype(np.float32)
    nrm = rng.normal(size=(5, 3, 3)).astype(np.float32)
    nrm /= np.linalg.norm(nrm, axis=-1, keepdims=True)
    mats = np.tile(np.eye(4), (4, 1, 1))
    mats[:, :3, :3] = rng.normal(size=(4, 3, 3))
    mats[:, :3, 3] = rng.normal(size=(4, 3)) * 10.0
    mats[1, :3, :3] = np.diag([-1.0, 2.0, 0.5])  # mirrored
    mats[2, 2, :3] = 0.0  # flat
    parent = np.eye(4)
    parent[:3, :3] = rng.normal(size=(3, 3)) + 2.0 * np.eye(3)
    parent[:3, 3] = [1.0, -2.0, 3.0]
    local = np.ascontiguousarray(mats.transpose(0, 2, 1).reshape(4, 16), np.float32)
    out_p, out_n = np.empty((20, 3, 3), np.float32), np.empty((20, 3, 3), np.float32)
    inverse, mirrored = np.empty((4, 4, 4)), np.empty(4, bool)
    kernels.place(pos, nrm, local, parent, out_p, out_n, inverse, mirrored)
    for i in range(4):
        m = parent @ local[i].astype(np.float64).reshape(4, 4).T
        lin = m[:3, :3]
        det = np.linalg.det(lin)
        if abs(det) > 1e-9:  # (a flat instance's triangles have no front to keep)
            assert mirrored[i] == (det < 0)
        order = [2, 1, 0] if mirrored[i] else [0, 1, 2]
        want_p = pos.astype(np.float64) @ lin.T + m[:3, 3]
        np.testing.assert_allclose(out_p[5 * i:5 * i + 5], want_p[:, order], rtol=1e-5,
                                   atol=1e-4)
        if abs(det) > 1e-20:
            n = nrm.astype(np.float64) @ np.linalg.inv(lin)
            n /= np.linalg.norm(n, axis=-1, keepdims=True)
            np.testing.assert_allclose(out_n[5 * i:5 * i + 5], n[:, order], atol=1e-5)
            np.testing.assert_allclose(inverse[i], np.linalg.inv(m), atol=1e-9)
        else:
            np.testing.assert_array_equal(inverse[i][:3, :3], np.eye(3))


def test_nearest_draws_what_the_set_up_draws():
    """``raster.nearest`` (no set-up) gives the fragments of ``rasterize`` for a perspective
    projection: triangles crossing the near plane, beyond the far plane, culled back faces,
    several sample offsets at once. A sample exactly on a shared edge may go to either
    triangle: random corners put none there."""
    rng = np.random.default_rng(3)
    near, far = 0.1, 10.0
    proj = np.array([[1.2, 0, 0, 0], [0, 1.6, 0, 0],
                     [0, 0, (far + near) / (near - far), 2 * far * near / (near - far)],
                     [0, 0, -1, 0]])
    centres = rng.uniform([-3, -3, -12], [3, 3, -0.5], (1500, 1, 3))
    tris = centres + rng.normal(0, 0.5, (1500, 3, 3))
    clip = projection.project(tris.astype(np.float32), proj)
    cull = rng.uniform(size=len(clip)) < 0.5
    crossing = ((clip[..., 2] < -clip[..., 3]).any(1) & (clip[..., 2] > -clip[..., 3]).any(1))
    beyond = (clip[..., 2] > clip[..., 3]).any(1)
    assert crossing.sum() > 10 and beyond.sum() > 10
    offsets = ((0.5, 0.5), (0.125, 0.875), (0.9, 0.3))
    for culled in (None, cull):
        drawn = raster.nearest(clip, 96, 72, cull=culled, sample_offsets=offsets,
                               depth_plane=(proj[2, 2], proj[2, 3]))
        assert len(drawn) == len(offsets)
        for offset, b in zip(offsets, drawn, strict=True):
            a = raster.rasterize(clip, 96, 72, cull=culled, sample_offset=offset,
                                 depth_plane=(proj[2, 2], proj[2, 3]))
            np.testing.assert_array_equal(b.tri, a.tri)
            hit = a.tri >= 0
            assert 0.3 < hit.mean() < 1.0 and len(np.unique(a.tri[hit])) > 100
            np.testing.assert_allclose(b.bary[hit], a.bary[hit], atol=1e-5)
            np.testing.assert_allclose(b.depth[hit], a.depth[hit], rtol=1e-5)
            assert np.isinf(b.depth[~hit]).all() and (b.bary[~hit] == 0).all()


def test_a_view_drawn_once_is_projected_and_culled_in_one_pass_bit_for_bit():
    """``visibility.tile_clip`` of a view's ``Projection`` (``with_camera(once=True)``) gives
    the clip coordinates and triangles of the projected view's, bit for bit, unseen triangles
    left out."""
    from bo2_lighting.addon.core.render import visibility

    rng = np.random.default_rng(4)
    positions = (rng.uniform(-4, 4, (2000, 1, 3)) + rng.normal(0, 0.5, (2000, 3, 3)))
    positions = positions.astype(np.float32)
    matrix = np.array([[1.2, 0, 0, 0.1], [0, 1.6, 0, -0.2], [0, 0, -1.02, -0.2], [0, 0, -1, 0]])
    seen = rng.uniform(size=2000) < 0.7
    clip = projection.project(positions, matrix)
    clip[~seen] = (0.0, 0.0, 0.0, -1.0)
    for tile in ((0, 0, 64, 48), (-2, -2, 66, 50), (10, 20, 30, 40)):
        a, ia = visibility.tile_clip(clip, 64, 48, tile)
        b, ib = visibility.tile_clip(projection.Projection(positions, matrix, np.float32,
                                                     np.flatnonzero(seen)), 64, 48, tile)
        assert 10 < len(ia) < seen.sum()
        np.testing.assert_array_equal(ib, ia)
        np.testing.assert_array_equal(b.view(np.uint32), a.view(np.uint32))
