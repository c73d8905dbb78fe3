"""The world as a light that must be seen (``core.render.sky``): the fraction of a uniform world's
light that reaches a point, against the view factor of the opening it sees it through."""

import math

import numpy as np
import pytest
from test_volume_leaks import cube as box

from bo2_lighting.addon.core.bakes import bake
from bo2_lighting.addon.core.formulas import sh
from bo2_lighting.addon.core.render import buffers, pipeline, sky
from bo2_lighting.addon.core.render.job import RenderJob
from bo2_lighting.addon.core.scene import (
    Camera,
    Material,
    MeshBatch,
    RenderSettings,
    Scene,
    World,
)


def frame_of(slabs, directions=128, world_sh=None) -> buffers.Frame:
    tris = np.concatenate([box(lo, hi) for lo, hi in slabs])
    n = np.cross(tris[:, 1] - tris[:, 0], tris[:, 2] - tris[:, 0])
    n /= np.linalg.norm(n, axis=-1, keepdims=True)
    mesh = MeshBatch(tris, np.repeat(n[:, None], 3, 1).astype(np.float32),
                     np.zeros(len(tris), np.int32))
    world = World(color=np.full(3, 1.0, np.float32))
    scene = Scene(camera=Camera.look_at((0, -5, 1), (0, 0, 1), 1.0, 8, 8, 0.1, 100.0),
                  meshes=[mesh], materials=[Material()], world=world,
                  settings=RenderSettings(samples=1, sky_directions=directions,
                                          sky_resolution=256),
                  probes=bake.world_probes(world))
    if world_sh is not None:
        scene.probes.world_sh = np.asarray(world_sh, np.float32)
    return pipeline.prepare(RenderJob(scene))


def seen(frame, points, normals=((0.0, 0.0, 1.0),)) -> np.ndarray:
    p = np.asarray(points, np.float32)
    n = np.broadcast_to(np.asarray(normals, np.float32), p.shape).copy()
    return sky.visibility(frame.sky, frame.scene.probes.world_sh, p, n, n)


def view_factor_to_square(half: float, height: float) -> float:
    """The fraction of a uniform sky's irradiance that a point sees through a square opening of
    half side ``half`` centred ``height`` above it in an opaque ceiling: four times the form
    factor of a differential area to a parallel rectangle with a corner above it (Howell's
    catalogue, configuration B-3), X = Y = half / height."""
    x = y = half / height
    f = (x / math.sqrt(1 + x * x) * math.atan(y / math.sqrt(1 + x * x))
         + y / math.sqrt(1 + y * y) * math.atan(x / math.sqrt(1 + y * y))) / (2 * math.pi)
    return 4 * f


def room_with_skylight(half: float, height: float, size: float = 6.0):
    """A closed room (walls, floor and ceiling 0.2 m thick) of ``size`` m square, ``height``
    m high, with a square opening of half side ``half`` in the middle of its ceiling."""
    s, t, h = size / 2, 0.2, height
    slabs = [((-s - t, -s - t, -t), (s + t, s + t, 0.0)),  # floor
             ((-s - t, -s - t, 0.0), (-s, s + t, h)), ((s, -s - t, 0.0), (s + t, s + t, h)),
             ((-s, -s - t, 0.0), (s, -s, h)), ((-s, s, 0.0), (s, s + t, h))]
    # the ceiling: four slabs around the opening
    top = h + t
    slabs += [((-s - t, -s - t, h), (s + t, -half, top)), ((-s - t, half, h), (s + t, s + t, top)),
              ((-s - t, -half, h), (-half, half, top)), ((half, -half, h), (s + t, half, top))]
    return slabs


@pytest.mark.parametrize("half, height", [(1.0, 2.5), (0.6, 3.0)])
def test_a_skylight_lets_in_its_view_factor(half, height):
    frame = frame_of(room_with_skylight(half, height))
    got = seen(frame, [(0.0, 0.0, 0.0), (0.3, -0.2, 0.0)])
    expected = view_factor_to_square(half, height)
    assert expected < 0.25
    np.testing.assert_allclose(got[0], expected, atol=0.03)
    assert abs(got[1] - got[0]) < 0.05  # smooth: no patch of one direction's shadow


def brute_force(point, slabs, world_sh=None, n_theta=256, n_phi=512, radius=np.inf) -> float:
    """The fraction of the world's light (uniform, or of radiance SH ``world_sh``) reaching an
    upward-facing point among boxes: a midpoint quadrature of the cosine-weighted hemisphere
    with a ray-box test per direction (a box farther than ``radius`` along the ray hides
    nothing)."""
    t = (np.arange(n_theta) + 0.5) / n_theta * (np.pi / 2)
    f = (np.arange(n_phi) + 0.5) / n_phi * (2 * np.pi)
    t, f = np.meshgrid(t, f, indexing="ij")
    d = np.stack([np.sin(t) * np.cos(f), np.sin(t) * np.sin(f), np.cos(t)], -1).reshape(-1, 3)
    w = (np.cos(t) * np.sin(t)).reshape(-1)
    if world_sh is not None:
        w = w * np.maximum(sh.basis(d) @ np.asarray(world_sh, np.float64)[:, 0], 0.0)
    o = np.asarray(point, np.float64) + 1e-6 * np.array([0.0, 0.0, 1.0])
    hit = np.zeros(len(d), bool)
    with np.errstate(divide="ignore", invalid="ignore"):
        for lo, hi in slabs:
            a = (np.asarray(lo) - o) / d
            b = (np.asarray(hi) - o) / d
            near = np.nanmax(np.minimum(a, b), axis=1)
            far = np.nanmin(np.maximum(a, b), axis=1)
            hit |= (far >= np.maximum(near, 0.0)) & (np.maximum(near, 0.0) <= radius)
    return float((w * ~hit).sum() / w.sum())


def test_a_closed_room_sees_no_sky_and_open_ground_all_of_it():
    closed = frame_of(room_with_skylight(0.0, 2.5)[:5] + [((-3.2, -3.2, 2.5), (3.2, 3.2, 2.7))])
    inside = seen(closed, [(0.0, 0.0, 0.0), (2.9, 2.9, 0.0), (-1.0, 2.0, 0.0)])
    np.testing.assert_array_less(inside, 0.02)  # a corner 10 cm from two walls: 0.012
    slabs = [((-20.0, -20.0, -0.1), (20.0, 20.0, 0.0)), ((-0.5, -0.5, 0.0), (0.5, 0.5, 1.0))]
    ground = frame_of(slabs, directions=64)
    points = [(12.0, 12.0, 0.0), (0.6, 0.0, 0.0), (0.8, 0.3, 0.0), (1.5, -0.4, 0.0)]
    got = seen(ground, points)
    assert got[0] > 0.99
    # beside a 1 m cube, the sky it hides, against the brute-force integral
    expected = [brute_force(p, slabs[1:]) for p in points[1:]]
    np.testing.assert_allclose(got[1:], expected, atol=0.05)


def test_the_world_brighter_overhead_counts_for_more():
    """Under a roof open at the sides, a sky bright at the zenith and dark at the horizon
    reaches the point less than a uniform one: the brute-force integral of each."""
    slabs = [((-20.0, -20.0, -0.1), (20.0, 20.0, 0.0)), ((-1.5, -1.5, 1.0), (1.5, 1.5, 1.1))]
    frame = frame_of(slabs, directions=64)
    zenith = np.zeros((9, 3), np.float32)
    zenith[0] = 1.0
    zenith[2] = 1.5  # Y_1^0 ~ cos(theta): brighter overhead
    p = np.array([[0.0, 0.0, 0.0], [0.5, -0.5, 0.0]], np.float32)
    n = np.array([[0.0, 0.0, 1.0]] * 2, np.float32)
    uniform = sky.visibility(frame.sky, frame.scene.probes.world_sh, p, n, n)
    overhead = sky.visibility(frame.sky, zenith, p, n, n)
    for k in range(2):
        np.testing.assert_allclose(uniform[k], brute_force(p[k], slabs[1:]), atol=0.04)
        np.testing.assert_allclose(overhead[k], brute_force(p[k], slabs[1:], zenith),
                                   atol=0.04)
    assert (overhead < uniform - 0.02).all()


def test_no_dome_without_directions_or_geometry():
    assert sky.dome_lights(0) == []
    frame = frame_of([((-1.0, -1.0, -0.1), (1.0, 1.0, 0.0))], directions=0)
    assert frame.sky is None
    assert len(sky.dome(32)) == 32
    np.testing.assert_allclose(np.linalg.norm(sky.dome(32), axis=1), 1.0)
    # equal cells: the mean of the directions is the centre of the sphere
    np.testing.assert_allclose(sky.dome(256).mean(0), 0.0, atol=0.01)


def test_no_maps_towards_directions_that_send_no_light():
    """A direction the world sends no light from needs no shadow map: a black world has no
    dome at all, and a world lit from above only none below the horizon where its radiance,
    0.282 + 0.732 cos(theta) (SH Y00 and Y10), is 0 (cos(theta) < -0.385)."""
    slabs = [((-20.0, -20.0, -0.1), (20.0, 20.0, 0.0)), ((-1.5, -1.5, 1.0), (1.5, 1.5, 1.1))]
    black = frame_of(slabs, directions=64, world_sh=np.zeros((9, 3)))
    assert black.sky is None and black.shadow_maps == [None] * 64
    zenith = np.zeros((9, 3), np.float32)
    zenith[0], zenith[2] = 1.0, 1.5
    frame = frame_of(slabs, directions=64, world_sh=zenith)
    z = sky.dome(64)[:, 2]
    built = np.array([m is not None for m in frame.sky.maps])
    np.testing.assert_array_equal(built, 0.282095 + 1.5 * 0.488603 * z > 0.0)
    assert 0 < (~built).sum() < 64
    p = np.array([[0.0, 0.0, 0.0], [0.5, -0.5, 0.0]], np.float32)
    n = np.array([[0.0, 0.0, 1.0]] * 2, np.float32)
    got = sky.visibility(frame.sky, zenith, p, n, n)
    for k in range(2):
        np.testing.assert_allclose(got[k], brute_force(p[k], slabs[1:], zenith), atol=0.04)


def _grid(width, height):
    y, x = np.mgrid[0:height, 0:width].astype(np.float64) + 0.5
    return x.ravel(), y.ravel()


def test_upsampling_reproduces_a_smooth_value_and_looks_up_a_sixteenth():
    """On one plane a linear function of position is blended exactly (bilinear weights
    reproduce it) between the points where it is looked up, one in stride^2."""
    x, y = _grid(64, 48)
    points = np.stack([x * 0.01, y * 0.01, np.zeros_like(x)], 1)
    normals = np.broadcast_to(np.float32([0, 0, 1]), points.shape).copy()
    f = (0.2 + 0.5 * points[:, 0] + 0.3 * points[:, 1]).astype(np.float32)
    asked = []

    def evaluate(k):
        asked.append(len(k))
        return f[k]

    out = sky.upsampled(evaluate, x, y, points, normals, 4)
    inner = (x > 2) & (x < 62) & (y > 2) & (y < 46)  # between the looked-up points
    np.testing.assert_allclose(out[inner], f[inner], atol=1e-5)
    np.testing.assert_allclose(out, f, atol=0.011)  # beyond: the nearest ones' value
    assert sum(asked) < 0.2 * len(x)


def test_upsampling_never_blends_across_an_edge():
    """Two planes at right angles (a wall on a floor) with values that jump: every point gets
    its own side's value exactly as a direct look-up gives it."""
    x, y = _grid(40, 40)
    wall = x < 17.0
    points = np.where(wall[:, None], np.stack([np.zeros_like(x), x, y], 1) * 0.01,
                      np.stack([x, np.zeros_like(x), y], 1) * 0.01)
    normals = np.where(wall[:, None], np.float32([1, 0, 0]), np.float32([0, 1, 0]))
    f = np.where(wall, 0.1, 0.9).astype(np.float32)
    out = sky.upsampled(lambda k: f[k], x, y, points, normals, 4)
    np.testing.assert_allclose(out, f, rtol=1e-6)


def test_stride_follows_the_frame_height():
    assert sky.stride(540) == 4 and sky.stride(1080) == 8 and sky.stride(64) == 1
