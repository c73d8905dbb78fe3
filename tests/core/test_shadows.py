"""Tests of the shadow maps against independently computed shadows.

Independent references used here (computed in this file, never with the module's helpers):
- ray casting by hand: the segment from a ground point to the light against an axis-aligned
  square occluder (plane z = h, |x - cx| <= a, |y - cy| <= a) or an axis-aligned box (slabs);
- soft shadows: the visible fraction of a spherical light (its silhouette disc, 2000 stratified
  points) or of the sun's disc (2000 directions in its cone) by the same ray casts, and the
  geometric penumbra half-width R (d_r - d_b) / d_b (sun: tan(angle / 2) (d_r - d_b)).
"""

import numpy as np
import pytest

from bo2_lighting.addon.core.render import shadow_filter, shadows
from bo2_lighting.addon.core.scene import Camera, Light

# --------------------------------------------------------------------------------------------
# scene helpers


def quad(centre, u, v):
    """(2, 3, 3) float32 triangles of the parallelogram centre +- u +- v."""
    c, u, v = (np.asarray(a, np.float64) for a in (centre, u, v))
    p = [c - u - v, c + u - v, c + u + v, c - u + v]
    return np.array([[p[0], p[1], p[2]], [p[0], p[2], p[3]]], np.float32)


def ground(half=5.0, cells=20):
    """(2 cells^2, 3, 3) float32 tessellated square z = 0 of side 2 half."""
    xs = np.linspace(-half, half, cells + 1)
    gx, gy = np.meshgrid(xs, xs)
    pts = np.stack([gx, gy, np.zeros_like(gx)], -1)
    a, b = pts[:-1, :-1].reshape(-1, 3), pts[:-1, 1:].reshape(-1, 3)
    c, d = pts[1:, 1:].reshape(-1, 3), pts[1:, :-1].reshape(-1, 3)
    return np.concatenate([np.stack([a, b, c], 1), np.stack([a, c, d], 1)]).astype(np.float32)


def box(lo, hi):
    """(12, 3, 3) float32 triangles of the axis-aligned box [lo, hi]."""
    lo, hi = np.asarray(lo, np.float64), np.asarray(hi, np.float64)
    c, h, e = (lo + hi) / 2, (hi - lo) / 2, np.eye(3)
    faces = []
    for ax in range(3):
        u, v = e[(ax + 1) % 3] * h[(ax + 1) % 3], e[(ax + 2) % 3] * h[(ax + 2) % 3]
        faces += [quad(c + s * e[ax] * h[ax], u, v) for s in (-1.0, 1.0)]
    return np.concatenate(faces)


def look_at(eye, target, fov_deg=50.0, width=320, height=240, near=0.1, far=100.0):
    """Perspective Camera at ``eye`` looking at ``target`` (OpenGL matrices, Z up)."""
    return Camera.look_at(eye, target, np.radians(fov_deg), width, height, near, far)


def in_view(camera, pts):
    """(N,) bool: the points project inside the camera's image."""
    h = np.concatenate([pts, np.ones((len(pts), 1))], 1) @ (
        camera.projection @ camera.world_to_camera
    ).T
    ndc = h[:, :3] / h[:, 3:]
    return (h[:, 3] > 0) & (np.abs(ndc[:, 0]) < 0.98) & (np.abs(ndc[:, 1]) < 0.98)


def ground_points(lo, hi, n):
    """(n^2, 3) float32 grid of points on z = 0 and (n^2, 3) up normals."""
    xs = np.linspace(lo[0], hi[0], n)
    ys = np.linspace(lo[1], hi[1], n)
    gx, gy = np.meshgrid(xs, ys)
    p = np.stack([gx.ravel(), gy.ravel(), np.zeros(gx.size)], 1).astype(np.float32)
    return p, np.tile(np.float32([0.0, 0.0, 1.0]), (len(p), 1))


def unit(v):
    v = np.asarray(v, np.float64)
    return v / np.linalg.norm(v)


# --------------------------------------------------------------------------------------------
# independent ray casts


def square_crossing(origins, targets, height, half, centre=(0.0, 0.0)):
    """Where segments origins -> targets cross the plane z = height.

    returns: (N,) signed Chebyshev distance of the crossing to the square's edge in that plane
             (negative inside the square, +inf when the segment does not reach the plane) and
             (N,) distance from the target to the crossing
    """
    o = np.asarray(origins, np.float64)
    t_ = np.broadcast_to(np.asarray(targets, np.float64), o.shape)
    d = t_ - o
    with np.errstate(divide="ignore", invalid="ignore"):
        s = (height - o[:, 2]) / d[:, 2]
    q = o + s[:, None] * d
    cheb = np.maximum(np.abs(q[:, 0] - centre[0]), np.abs(q[:, 1] - centre[1])) - half
    cheb = np.where((s > 0) & (s < 1), cheb, np.inf)
    return cheb, np.linalg.norm(t_ - q, axis=1)


def segment_hits_box(origins, targets, lo, hi):
    """(N,) bool: the open segment origins -> targets passes through the box [lo, hi] (slabs)."""
    o = np.asarray(origins, np.float64)
    d = np.broadcast_to(np.asarray(targets, np.float64), o.shape) - o
    with np.errstate(divide="ignore", invalid="ignore"):
        t0 = (np.asarray(lo) - o) / d
        t1 = (np.asarray(hi) - o) / d
    enter = np.nanmax(np.minimum(t0, t1), axis=1)
    leave = np.nanmin(np.maximum(t0, t1), axis=1)
    return (enter < leave) & (leave > 1e-9) & (enter < 1.0)


def disc_samples(count=2000):
    """(count, 2) stratified points uniform over the unit disc (sunflower pattern)."""
    k = np.arange(count) + 0.5
    r, th = np.sqrt(k / count), k * np.pi * (3.0 - np.sqrt(5.0))
    return np.stack([r * np.cos(th), r * np.sin(th)], 1)


def frame(axis):
    """Two unit vectors perpendicular to unit ``axis``."""
    a = np.array([1.0, 0.0, 0.0]) if abs(axis[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    e1 = unit(np.cross(axis, a))
    return e1, np.cross(axis, e1)


def sphere_light_fraction(points, centre, radius, height, half):
    """(N,) visible fraction of a spherical light seen over a square occluder (ray casting)."""
    disc = disc_samples()
    out = np.empty(len(points))
    for i, p in enumerate(points):
        e1, e2 = frame(unit(centre - p))
        targets = centre + radius * (disc[:, :1] * e1 + disc[:, 1:] * e2)
        cheb, _ = square_crossing(np.broadcast_to(p, targets.shape), targets, height, half)
        out[i] = np.mean(cheb > 0)
    return out


def sun_fraction(points, direction, angle, height, half):
    """(N,) visible fraction of the sun's disc (angular diameter ``angle``) over a square."""
    axis = -unit(direction)
    e1, e2 = frame(axis)
    disc = disc_samples() * np.tan(angle / 2.0)
    dirs = axis + disc[:, :1] * e1 + disc[:, 1:] * e2
    out = np.empty(len(points))
    for i, p in enumerate(points):
        targets = p + 100.0 * dirs
        cheb, _ = square_crossing(np.broadcast_to(p, targets.shape), targets, height, half)
        out[i] = np.mean(cheb > 0)
    return out


def penumbra(xs, vis):
    """Width of the region 0.05 < vis < 0.95 and the 0.5 crossing of a rising profile."""
    lo = xs[np.argmax(vis > 0.05)]
    hi = xs[np.argmax(vis >= 0.95)]
    return hi - lo, xs[np.argmax(vis >= 0.5)]


# --------------------------------------------------------------------------------------------
# hard shadows of a square occluder: exact inside/outside away from a thin band

OCC_H, OCC_HALF = 1.0, 0.5
LIGHT_POS = np.array([1.3, 0.4, 2.2])  # the occluder spans the -Z and -X faces of the cube
CAMERA = look_at([0.0, -7.0, 5.0], [-0.5, 0.0, 0.0])


def occluder_scene():
    return np.concatenate([ground(), quad([0, 0, OCC_H], [OCC_HALF, 0, 0], [0, OCC_HALF, 0])])


def check_hard(vis, cheb, band):
    """vis is 0 where the crossing is band inside the square and 1 where band outside."""
    inside, outside = cheb < -band, cheb > band
    assert inside.sum() > 200 and outside.sum() > 2000  # both sides are really tested
    assert vis[inside].max() <= 1e-6, vis[inside].max()
    assert vis[outside].min() >= 1.0 - 1e-6, vis[outside].min()


@pytest.mark.parametrize("kind", ["POINT", "AREA"])
def test_point_and_area_hard_shadow(kind):
    res = 512
    light = Light(kind, np.ones(3), position=LIGHT_POS, radius=0.0, size=np.array([0.0, 0.0]))
    sm = shadows.build_shadow_map(light, occluder_scene(), CAMERA, resolution=res)
    p, n = ground_points((-4.0, -4.0), (4.0, 4.0), 161)
    vis = shadow_filter.shadow_visibility(sm, p, n)
    cheb, dist = square_crossing(p, LIGHT_POS, OCC_H, OCC_HALF)
    texel = 2.0 * dist / res  # a 90-degree face: at most 2/res radians per texel
    check_hard(vis, cheb, 3.0 * texel)


def test_spot_hard_shadow():
    res = 512
    size = np.radians(110.0)
    axis = unit([-0.8, -0.2, -1.0])
    light = Light("SPOT", np.ones(3), position=LIGHT_POS, direction=axis, spot_size=size)
    sm = shadows.build_shadow_map(light, occluder_scene(), CAMERA, resolution=res)
    p, n = ground_points((-4.0, -4.0), (4.0, 4.0), 161)
    to_p = p - LIGHT_POS
    in_cone = to_p @ axis > np.cos(size / 2 - np.radians(3.0)) * np.linalg.norm(to_p, axis=1)
    p, n = p[in_cone], n[in_cone]
    vis = shadow_filter.shadow_visibility(sm, p, n)
    cheb, dist = square_crossing(p, LIGHT_POS, OCC_H, OCC_HALF)
    texel = 2.0 * np.tan(0.6 * size) * dist / res  # a map a little wider than the cone
    check_hard(vis, cheb, 3.0 * texel)


def test_sun_hard_shadow_with_cascades():
    res = 512
    direction = unit([-0.4, -0.25, -1.0])
    light = Light("SUN", np.ones(3), direction=direction, radius=0.0)
    sm = shadows.build_shadow_map(light, occluder_scene(), CAMERA, resolution=res)
    p, n = ground_points((-4.0, -4.0), (4.0, 4.0), 161)
    seen = in_view(CAMERA, p)
    p, n = p[seen], n[seen]
    vis = shadow_filter.shadow_visibility(sm, p, n)
    cheb, _ = square_crossing(p, p - 50.0 * direction, OCC_H, OCC_HALF)
    texel = 15.0 / res  # every cascade is at most the scene's diagonal wide
    check_hard(vis, cheb, 3.0 * texel)


# --------------------------------------------------------------------------------------------
# soft shadows: penumbra width against the ray-cast fraction of the light's disc

SOFT_HALF = 1.0  # a large occluder, so that the umbra is wide


def soft_profile(light, xs, height, jitter=True, res=512):
    scene = np.concatenate(
        [ground(), quad([0, 0, height], [SOFT_HALF, 0, 0], [0, SOFT_HALF, 0])]
    )
    camera = look_at([0.0, -6.0, 6.0], [1.0, 0.0, 0.0])
    sm = shadows.build_shadow_map(light, scene, camera, resolution=res)
    p = np.stack([xs, np.zeros_like(xs), np.zeros_like(xs)], 1).astype(np.float32)
    n = np.tile(np.float32([0.0, 0.0, 1.0]), (len(p), 1))
    return shadow_filter.shadow_visibility(sm, p, n, jitter=jitter), p


def smooth(v, k=7):
    return np.convolve(np.pad(v, k // 2, mode="edge"), np.ones(k) / k, mode="valid")


@pytest.mark.parametrize("radius", [0.15, 0.3])
def test_point_penumbra_width(radius):
    centre = np.array([0.0, 0.0, 3.0])
    light = Light("POINT", np.ones(3), position=centre, radius=radius)
    edge = SOFT_HALF * 3.0 / 2.0  # hard shadow edge on the ground
    xs = np.linspace(edge - 0.4, edge + 0.4, 201)
    vis, p = soft_profile(light, xs, 1.0)
    ref = sphere_light_fraction(p.astype(np.float64), centre, radius, 1.0, SOFT_HALF)
    # geometric penumbra half-width R (d_r - d_b) / d_b, measured across the ray, on the ground
    d_r = np.hypot(edge, 3.0)
    d_b = d_r * 2.0 / 3.0
    half_width = radius * (d_r - d_b) / d_b / (3.0 / d_r)
    w_ref, mid_ref = penumbra(xs, ref)
    assert 1.2 * half_width < w_ref < 2.0 * half_width  # the reference is what we think it is
    assert vis[xs < edge - 1.5 * half_width].max() <= 0.02
    assert vis[xs > edge + 1.5 * half_width].min() >= 0.98
    w, mid = penumbra(xs, smooth(vis))
    assert w_ref / 1.5 < w < 1.5 * w_ref, (w, w_ref)
    assert abs(mid - mid_ref) < 0.2 * w_ref, (mid, mid_ref)
    assert np.all(np.diff(smooth(vis)) > -0.05)  # noisy but rising
    fixed, _ = soft_profile(light, xs, 1.0, jitter=False)
    assert np.all(np.diff(fixed) >= -0.02)  # one rotation: monotonic
    w_fixed, _ = penumbra(xs, fixed)
    assert w_ref / 1.5 < w_fixed < 1.5 * w_ref


def test_penumbra_grows_with_light_size():
    xs = np.linspace(1.1, 1.9, 161)
    widths = []
    for radius in (0.1, 0.3):
        light = Light("POINT", np.ones(3), position=np.array([0.0, 0.0, 3.0]), radius=radius)
        widths.append(penumbra(xs, smooth(soft_profile(light, xs, 1.0)[0]))[0])
    assert widths[1] > 2.0 * widths[0]
    xs = np.linspace(0.6, 1.4, 161)
    widths = []
    for angle in np.radians([3.0, 8.0]):
        light = Light("SUN", np.ones(3), direction=np.array([0.0, 0.0, -1.0]), radius=angle)
        widths.append(penumbra(xs, smooth(soft_profile(light, xs, 2.0)[0]))[0])
    assert widths[1] > 2.0 * widths[0]


@pytest.mark.parametrize("kind", ["POINT", "SUN"])
def test_the_pyramid_skips_blocker_searches_without_changing_a_bit(kind):
    """Soft-shadowed points whose whole search region the pyramid proves lit or dark skip
    the blocker search (``how``: HOW_PROVEN): much of an open ground and of a wide umbra;
    with the test off every such point searches, and the results are the same bits."""
    from bo2_lighting.addon.core.kernels import shadows as filter_kernel

    light = (Light("POINT", np.ones(3), position=np.array([0.0, 0.0, 3.0]), radius=0.2)
             if kind == "POINT" else
             Light("SUN", np.ones(3), direction=np.array([0.0, 0.0, -1.0]),
                   radius=np.radians(10.0)))
    scene = np.concatenate([ground(), quad([0, 0, 1.0], [SOFT_HALF, 0, 0], [0, SOFT_HALF, 0])])
    sm = shadows.build_shadow_map(light, scene, look_at([0.0, -6.0, 6.0], [1.0, 0.0, 0.0]),
                                  resolution=512)
    rng = np.random.default_rng(3)
    p = np.column_stack([rng.uniform(-2.5, 2.5, (4000, 2)), np.zeros(4000)]).astype(np.float32)
    n = np.tile(np.float32([0.0, 0.0, 1.0]), (len(p), 1))
    how = np.empty(len(p), np.uint8)
    vis = shadow_filter.shadow_visibility(sm, p, n, how=how)
    searched = shadow_filter.shadow_visibility(sm, p, n, skip=False)
    assert np.array_equal(vis.view(np.uint32), searched.view(np.uint32))
    proven = how == filter_kernel.HOW_PROVEN
    soft = proven | (how == filter_kernel.HOW_SEARCHED)
    assert proven.sum() > 0.2 * soft.sum() and (soft & ~proven).any()
    assert set(np.unique(vis[proven])) <= {0.0, 1.0} and (vis[proven] == 0.0).any()


@pytest.mark.parametrize("angle_deg", [4.0, 8.0])
def test_sun_penumbra_width(angle_deg):
    angle = np.radians(angle_deg)
    direction = unit([0.25, 0.0, -1.0])
    light = Light("SUN", np.ones(3), direction=direction, radius=angle)
    height = 2.0
    edge = SOFT_HALF + height * 0.25  # shadow edge of the occluder's +x side
    xs = np.linspace(edge - 0.4, edge + 0.4, 201)
    vis, p = soft_profile(light, xs, height)
    ref = sun_fraction(p.astype(np.float64), direction, angle, height, SOFT_HALF)
    half_width = np.tan(angle / 2) * height / np.cos(np.arctan(0.25)) ** 2  # on the ground
    w_ref, mid_ref = penumbra(xs, ref)
    assert 1.2 * half_width < w_ref < 2.0 * half_width
    w, mid = penumbra(xs, smooth(vis))
    assert w_ref / 1.5 < w < 1.5 * w_ref, (w, w_ref)
    assert abs(mid - mid_ref) < 0.2 * w_ref
    fixed, _ = soft_profile(light, xs, height, jitter=False)
    assert np.all(np.diff(fixed) >= -0.02)


# --------------------------------------------------------------------------------------------
# bias: no acne on grazing receivers, no light leaking under a box


def grazing_points(light_pos=None, direction=None):
    """Ground points lit from 10 to 20 degrees above the horizon."""
    p, n = ground_points((-4.5, -4.5), (4.5, 4.5), 121)
    if light_pos is not None:
        to_l = light_pos - p
        elev = np.degrees(np.arctan2(to_l[:, 2], np.hypot(to_l[:, 0], to_l[:, 1])))
    else:
        elev = np.full(len(p), np.degrees(np.arcsin(-direction[2])))
    keep = (elev >= 10.0) & (elev <= 20.0)
    return p[keep], n[keep]


@pytest.mark.parametrize("kind", ["POINT", "SPOT", "SUN"])
def test_no_acne_at_grazing_angles(kind):
    scene = ground(cells=16)
    pos = np.array([-9.0, 1.0, 2.5])
    if kind == "SUN":
        direction = unit([np.cos(np.radians(15.0)), 0.3, -np.sin(np.radians(15.0))])
        light = Light("SUN", np.ones(3), direction=direction, radius=np.radians(1.0))
        p, n = grazing_points(direction=direction)
    else:
        light = Light(kind, np.ones(3), position=pos, direction=unit([1.0, -0.1, -0.2]),
                      spot_size=np.radians(80.0), radius=0.05)
        p, n = grazing_points(light_pos=pos)
        if kind == "SPOT":
            to_p = p - pos
            cos_a = to_p @ light.direction / np.linalg.norm(to_p, axis=1)
            p, n = p[cos_a > np.cos(np.radians(38.0))], n[cos_a > np.cos(np.radians(38.0))]
    assert len(p) > 1000
    sm = shadows.build_shadow_map(light, scene, look_at([0, -8, 4], [0, 0, 0]), resolution=512)
    vis = shadow_filter.shadow_visibility(sm, p, n)
    assert vis.min() >= 0.99, (vis.min(), np.mean(vis < 0.99))


def test_no_acne_on_a_smooth_sphere():
    # a 32 x 16 UV sphere with interpolated (shading) normals, lit by the sun
    nu, nv, radius, centre = 32, 16, 1.0, np.array([0.0, 0.0, 1.0])
    u, v = np.meshgrid(np.linspace(0, 2 * np.pi, nu + 1), np.linspace(0, np.pi, nv + 1))
    s = np.stack([np.cos(u) * np.sin(v), np.sin(u) * np.sin(v), np.cos(v)], -1)
    a, b = s[:-1, :-1].reshape(-1, 3), s[:-1, 1:].reshape(-1, 3)
    c, d = s[1:, 1:].reshape(-1, 3), s[1:, :-1].reshape(-1, 3)
    unit_tris = np.concatenate([np.stack([a, b, c], 1), np.stack([a, c, d], 1)])
    area = np.linalg.norm(np.cross(unit_tris[:, 1] - unit_tris[:, 0],
                                   unit_tris[:, 2] - unit_tris[:, 0]), axis=1)
    unit_tris = unit_tris[area > 1e-9]
    tris = (unit_tris * radius + centre).astype(np.float32)
    direction = unit([0.5, 0.3, -0.8])
    light = Light("SUN", np.ones(3), direction=direction, radius=np.radians(0.5))
    sm = shadows.build_shadow_map(light, tris, look_at([0, -6, 3], [0, 0, 1]), resolution=512)
    rng = np.random.default_rng(3)
    bary = rng.dirichlet(np.ones(3), len(tris))
    pts = np.einsum("tk,tkc->tc", bary, tris).astype(np.float32)
    nrm = np.einsum("tk,tkc->tc", bary, unit_tris)
    nrm /= np.linalg.norm(nrm, axis=1, keepdims=True)
    geo = np.cross(tris[:, 1] - tris[:, 0], tris[:, 2] - tris[:, 0])
    geo /= np.linalg.norm(geo, axis=1, keepdims=True)
    geo *= np.sign(np.einsum("tc,tc->t", geo, unit_tris.mean(1)))[:, None]  # outwards
    lit = geo @ -direction > 0.2  # the facet faces the sun: a convex body cannot shadow it
    vis = shadow_filter.shadow_visibility(sm, pts, nrm.astype(np.float32))
    assert lit.sum() > 150
    assert vis[lit].min() >= 0.99, vis[lit].min()
    assert vis[(geo @ -direction < -0.2)].max() <= 0.01  # facing away: behind the sphere


@pytest.mark.parametrize("kind", ["POINT", "SPOT", "SUN"])
def test_no_peter_panning_behind_a_box(kind):
    lo, hi = np.array([-0.5, -0.5, 0.0]), np.array([0.5, 0.5, 1.0])
    scene = np.concatenate([ground(), box(lo, hi)])
    pos = np.array([-3.0, 0.3, 4.0])
    if kind == "SUN":
        direction = unit([np.cos(np.radians(50.0)), 0.0, -np.sin(np.radians(50.0))])
        light = Light("SUN", np.ones(3), direction=direction)
        far = -50.0 * direction
    else:
        light = Light(kind, np.ones(3), position=pos, direction=unit(-pos),
                      spot_size=np.radians(90.0))
        far = None
    sm = shadows.build_shadow_map(light, scene, look_at([2, -6, 4], [0, 0, 0]), resolution=1024)
    ys = np.linspace(-0.4, 0.4, 41)
    for gap in (0.01, 0.02, 0.03):  # metres beyond the box's far face x = 0.5
        p = np.stack([np.full_like(ys, 0.5 + gap), ys, np.zeros_like(ys)], 1).astype(np.float32)
        target = pos if far is None else p + far
        assert segment_hits_box(p, target, lo, hi).all()  # really in the box's shadow
        n = np.tile(np.float32([0.0, 0.0, 1.0]), (len(p), 1))
        vis = shadow_filter.shadow_visibility(sm, p, n)
        assert vis.max() < 0.5, (gap, vis.max())


@pytest.mark.parametrize("kind", ["POINT", "SPOT", "SUN"])
def test_no_peter_panning_under_a_thin_plate(kind):
    # a plate 4 cm above the ground: the depth gap is 4 cm / cos(theta), two texels at 512
    height, half = 0.04, 0.5
    scene = np.concatenate([ground(), quad([0, 0, height], [half, 0, 0], [0, half, 0])])
    pos = np.array([-2.0, 1.0, 4.0])
    if kind == "SUN":
        direction = unit([0.5, -0.25, -1.0])
        light = Light("SUN", np.ones(3), direction=direction)
    else:
        light = Light(kind, np.ones(3), position=pos, direction=unit(-pos),
                      spot_size=np.radians(60.0))
    sm = shadows.build_shadow_map(light, scene, look_at([2, -6, 4], [0, 0, 0]), resolution=512)
    p, n = ground_points((-0.7, -0.7), (0.7, 0.7), 71)
    target = p - 50.0 * direction if kind == "SUN" else pos
    cheb, _ = square_crossing(p, target, height, half)
    vis = shadow_filter.shadow_visibility(sm, p, n)
    assert vis[cheb < -0.05].max() <= 0.01  # 5 cm inside the plate's shadow: dark
    assert vis[cheb > 0.05].min() >= 0.99


# --------------------------------------------------------------------------------------------
# API contract


def test_no_shadow_returns_none():
    light = Light("POINT", np.ones(3), position=LIGHT_POS, shadow=False)
    assert shadows.build_shadow_map(light, occluder_scene(), CAMERA, resolution=64) is None


def test_points_outside_the_sun_cascades_are_lit():
    # a second occluder far outside the camera's view shadows ground that no cascade covers
    far_occ = quad([30.0, 0.0, 1.0], [1.0, 0, 0], [0, 1.0, 0])
    far_ground = quad([30.0, 0.0, 0.0], [3.0, 0, 0], [0, 3.0, 0])
    scene = np.concatenate([occluder_scene(), far_occ, far_ground])
    light = Light("SUN", np.ones(3), direction=np.array([0.0, 0.0, -1.0]))
    sm = shadows.build_shadow_map(light, scene, CAMERA, resolution=256)
    p = np.array([[30.0, 0.0, 0.0], [29.5, 0.5, 0.0], [0.0, 80.0, 0.0], [-60.0, 0.0, -5.0]])
    n = np.tile([0.0, 0.0, 1.0], (4, 1))
    assert np.all(shadow_filter.shadow_visibility(sm, p, n) == 1.0)
    seen = shadow_filter.shadow_visibility(sm, np.array([[0.0, 0.0, 0.0]]), n[:1])
    assert seen[0] == 0.0  # under the visible occluder


def test_outputs_are_finite_float32_and_deterministic():
    scene = occluder_scene()
    rng = np.random.default_rng(7)
    p = rng.uniform(-5, 5, (1_000_000, 3)).astype(np.float32) * np.float32([1, 1, 0.5])
    n = rng.normal(size=p.shape).astype(np.float32)
    p[:4] = [[np.nan, 0, 0], LIGHT_POS, [0, 0, np.inf], [0.2, 0.1, 0.0]]
    n[:5] = [[0, 0, 1], [0, 0, 1], [0, 0, 1], [0, 0, 0], [np.nan, 0, 0]]
    lights = [
        Light("POINT", np.ones(3), position=LIGHT_POS),
        Light("POINT", np.ones(3), position=LIGHT_POS, radius=0.2),
        Light("SPOT", np.ones(3), position=LIGHT_POS, direction=unit(-LIGHT_POS), radius=0.1),
        Light("SPOT", np.ones(3), position=LIGHT_POS, spot_size=np.radians(175.0)),
        Light("SUN", np.ones(3), direction=unit([-0.4, -0.25, -1.0]), radius=0.05),
        Light("AREA", np.ones(3), position=LIGHT_POS, size=np.array([0.5, 0.2])),
    ]
    for i, light in enumerate(lights):
        sm = shadows.build_shadow_map(light, scene, CAMERA, resolution=256)
        assert sm.depth.dtype == np.float32
        q = p if i == 0 else p[:20000]  # one 1e6-point query
        vis = shadow_filter.shadow_visibility(sm, q, n[: len(q)])
        assert vis.dtype == np.float32 and vis.shape == (len(q),)
        assert np.all(np.isfinite(vis)) and vis.min() >= 0.0 and vis.max() <= 1.0
        assert vis[0] == 1.0 and vis[2] == 1.0  # non-finite points are lit
        assert 0.0 < vis.mean() < 1.0
        again = shadow_filter.shadow_visibility(sm, q[:20000], n[:20000])
        np.testing.assert_array_equal(again, vis[:20000])


def test_wide_spot_uses_a_cube_and_empty_scene_is_lit():
    light = Light("SPOT", np.ones(3), position=LIGHT_POS, spot_size=np.radians(175.0))
    sm = shadows.build_shadow_map(light, occluder_scene(), CAMERA, resolution=64)
    assert sm.depth.shape == (6, 64, 64)
    empty = np.zeros((0, 3, 3), np.float32)
    for kind in ("POINT", "SUN"):
        sm = shadows.build_shadow_map(Light(kind, np.ones(3)), empty, CAMERA, resolution=64)
        vis = shadow_filter.shadow_visibility(sm, np.zeros((3, 3)), np.tile([0, 0, 1.0], (3, 1)))
        assert np.all(vis == 1.0)


def test_sun_without_camera_covers_every_caster():
    light = Light("SUN", np.ones(3), direction=unit([-0.4, -0.25, -1.0]))
    sm = shadows.build_shadow_map(light, occluder_scene(), None, resolution=256)
    assert sm.depth.shape == (1, 256, 256)
    p = np.array([[-0.4, -0.25, 0.0], [4.0, 4.0, 0.0], [-4.5, -4.5, 0.0]])  # shadow centre
    n = np.tile([0.0, 0.0, 1.0], (3, 1))
    np.testing.assert_array_equal(shadow_filter.shadow_visibility(sm, p, n), [0.0, 1.0, 1.0])


def test_a_point_does_not_depend_on_the_rest_of_its_query():
    # the renderer queries points in batches of any size and order (tiles, edge samples)
    scene = occluder_scene()
    rng = np.random.default_rng(11)
    p = rng.uniform(-3, 3, (30000, 3)).astype(np.float32) * np.float32([1, 1, 0.3])
    n = rng.normal(size=p.shape).astype(np.float32)
    lights = [
        Light("POINT", np.ones(3), position=LIGHT_POS, radius=0.3),
        Light("SPOT", np.ones(3), position=LIGHT_POS, direction=unit(-LIGHT_POS), radius=0.1,
              spot_size=np.radians(120.0)),
        Light("SUN", np.ones(3), direction=unit([-0.4, -0.25, -1.0]), radius=np.radians(3.0)),
    ]
    order = rng.permutation(len(p))
    for light in lights:
        sm = shadows.build_shadow_map(light, scene, CAMERA, resolution=256)
        whole = shadow_filter.shadow_visibility(sm, p, n)
        assert 0.0 < whole.mean() < 1.0
        shuffled = np.empty_like(whole)
        shuffled[order] = shadow_filter.shadow_visibility(sm, p[order], n[order])
        np.testing.assert_array_equal(shuffled, whole)
        pieces = np.concatenate([shadow_filter.shadow_visibility(sm, p[i : i + 7], n[i : i + 7])
                                 for i in range(0, 700, 7)])
        np.testing.assert_array_equal(pieces, whole[:700])
        some = rng.random(len(p)) < 0.3  # a query of some points: the others are lit
        np.testing.assert_array_equal(shadow_filter.shadow_visibility(sm, p, n, where=some),
                                      np.where(some, whole, 1.0))


def block_reduce(maps, size, reduce, fill):
    """(F, ceil(res / size), ceil(res / size)) reduction of (F, res, res) maps over blocks."""
    f, res, _ = maps.shape
    side = -(-res // size)
    padded = np.full((f, side * size, side * size), fill, maps.dtype)
    padded[:, :res, :res] = maps
    return reduce(padded.reshape(f, side, size, side, size), axis=(2, 4))


@pytest.mark.parametrize("kind", ["POINT", "SUN"])
def test_pyramid_holds_the_extremes_of_every_block(kind):
    # the blocks prove points fully lit or fully shadowed: they must bound the maps exactly
    light = Light(kind, np.ones(3), position=LIGHT_POS, direction=unit([-0.4, -0.25, -1.0]))
    res = 100  # odd sides along the way
    sm = shadows.build_shadow_map(light, occluder_scene(), CAMERA, resolution=res)
    depth = sm.depth.astype(np.float64)
    if kind == "POINT":  # distance from the light of the texel centres' rays, by hand
        x = (np.arange(res) + 0.5) / res * 2.0 - 1.0
        dist = depth * np.sqrt(1.0 + x[None, :, None] ** 2 + x[None, None, :] ** 2)
    else:
        dist = depth
    row, level = 0, 0
    side = res
    while side > 1:
        level += 1
        side = -(-side // 2)
        if level < shadows.MIP_FIRST_LEVEL:
            continue
        count = len(sm.depth) * side * side
        block = sm.mips[row : row + count].reshape(len(sm.depth), side, side, 3)
        row += count
        size = 2**level
        np.testing.assert_allclose(block[..., 0], block_reduce(dist, size, np.min, np.inf),
                                   rtol=1e-6)
        np.testing.assert_array_equal(block[..., 1], block_reduce(depth, size, np.min, np.inf))
        np.testing.assert_array_equal(block[..., 2],
                                      block_reduce(depth, size, np.max, -np.inf))
    assert row == len(sm.mips) and level > shadows.MIP_FIRST_LEVEL


def _nearest_hits(origin, direction, tris):
    """Moller-Trumbore: per ray (N,) the parameter of the nearest hit of ``tris`` (T, 3, 3),
    either side (inf: none), and whether a ray passes within 1e-6 of an edge (not judged)."""
    q = tris.astype(np.float64)
    e1, e2 = q[:, 1] - q[:, 0], q[:, 2] - q[:, 0]
    pvec = np.cross(direction[:, None], e2[None])  # (N, T, 3)
    det = np.einsum("tk,ntk->nt", e1, pvec)
    s = origin[:, None] - q[None, :, 0]
    u = np.einsum("ntk,ntk->nt", s, pvec) / det
    qvec = np.cross(s, e1[None])
    v = np.einsum("ntk,nk->nt", qvec, direction) / det
    t = np.einsum("ntk,tk->nt", qvec, e2) / det
    w = 1.0 - u - v
    inside = (u >= 0) & (v >= 0) & (w >= 0) & (t > 0)
    near_edge = (np.minimum(np.minimum(u, v), w) > -1e-6) & (
        np.abs(np.stack([u, v, w])) < 1e-6).any(0)
    return np.where(inside, t, np.inf).min(1), near_edge.any(1)


@pytest.mark.parametrize("kind", ["SUN", "POINT"])
def test_map_depths_are_the_nearest_hit_of_each_texel_ray(kind):
    """Each texel of a sun cascade holds the depth, along the sun, of the first caster its
    centre's ray meets; each texel of a point light's cube face the clip w (depth along the
    face axis) of that of its ray from the light (ray casts against every triangle, either
    side); +inf where the ray meets none. Rays within 1e-6 of an edge are not judged."""
    rng = np.random.default_rng(5)
    centres = rng.uniform(-2.0, 2.0, (40, 1, 3)) * [1.0, 1.0, 0.5]
    tris = (centres + rng.normal(0.0, 0.4, (40, 3, 3))).astype(np.float32)
    light = Light(kind, np.ones(3), position=np.array([0.3, -0.2, 0.1]),
                  direction=unit([-0.3, 0.2, -1.0]))
    res = 48
    sm = shadows.build_shadow_map(light, tris, None, resolution=res)
    ndc = (np.arange(res) + 0.5) / res * 2.0 - 1.0
    x, y = np.meshgrid(ndc, -ndc)  # row 0 at the top
    hits = 0
    for face in range(len(sm.depth)):
        inv = np.linalg.inv(sm.view_proj[face])
        ends = [np.einsum("ij,nj->ni", inv, np.column_stack(
            [x.ravel(), y.ravel(), np.full(x.size, z), np.ones(x.size)])) for z in (-1.0, 1.0)]
        a, b = (e[:, :3] / e[:, 3:] for e in ends)
        origin = a - 100.0 * (b - a) if kind == "SUN" else np.broadcast_to(light.position, a.shape)
        t, near_edge = _nearest_hits(origin, b - a, tris)
        hit_at = origin + np.where(np.isfinite(t), t, 0.0)[:, None] * (b - a)
        if kind == "SUN":
            expected = hit_at @ sm.basis[0][2]
        else:
            expected = np.column_stack([hit_at, np.ones(len(t))]) @ sm.view_proj[face][3]
        expected = np.where(np.isfinite(t), expected, np.inf)
        got = sm.depth[face].reshape(-1).astype(np.float64)
        judged = ~near_edge
        assert judged.mean() > 0.99
        np.testing.assert_array_equal(np.isinf(got[judged]), np.isinf(expected[judged]))
        hit = judged & np.isfinite(expected)
        np.testing.assert_allclose(got[hit], expected[hit], rtol=1e-5)
        hits += hit.sum()
    assert hits > 0.1 * sm.depth[0].size


@pytest.mark.parametrize("kind", ["SUN", "POINT"])
def test_map_of_a_mesh_has_no_cracks(kind):
    """A plane of many small quads, each split along a diagonal that passes through texel
    centres, seen straight on: every texel it spans holds its depth (an edge shared by two
    triangles covers the centres on it whatever the rounding)."""
    steps = np.linspace(-1.0, 1.0, 17)
    quads = []
    for x0, x1 in zip(steps[:-1], steps[1:], strict=True):
        for y0, y1 in zip(steps[:-1], steps[1:], strict=True):
            quads += [[[x0, y0, 0.0], [x1, y0, 0.0], [x1, y1, 0.0]],
                      [[x0, y0, 0.0], [x1, y1, 0.0], [x0, y1, 0.0]]]
    tris = np.array(quads, np.float32)
    light = Light(kind, np.ones(3), position=np.array([0.0, 0.0, 1.0]),
                  direction=np.array([0.0, 0.0, -1.0]))
    sm = shadows.build_shadow_map(light, tris, None, resolution=64)
    if kind == "SUN":  # texel centres over the plane see it
        cx, cy, half = sm.rects[0]
        g = 32 / half
        x = cx + (np.arange(64) + 0.5 - 32) / g
        y = cy - (np.arange(64) + 0.5 - 32) / g
        inside = (np.abs(y)[:, None] < 1.0) & (np.abs(x)[None, :] < 1.0)
        np.testing.assert_array_equal(sm.depth[0][inside], 0.0)
        assert np.isinf(sm.depth[0][~inside]).all() and inside.sum() > 3000
    else:  # the face looking down sees the plane 1 m away within 45 degrees: all of it
        np.testing.assert_allclose(sm.depth[5], 1.0, rtol=1e-6)
