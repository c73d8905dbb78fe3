"""The world's sun (``core.lighting.world_sun``) against analytic values: a cap of known radiance
and half-angle a holds the irradiance L 2 pi (1 - cos a) towards its axis; one texel of an equirect
spans (2 pi / W) (cos theta_0 - cos theta_1) steradians."""

import math

import numpy as np
import pytest

from bo2_lighting.addon.core.formulas import sh, texture
from bo2_lighting.addon.core.lighting import world_sun
from bo2_lighting.addon.core.scene import World


def _cap_world(axis, half_angle, radiance, sky=0.5, height=1024):
    dirs = sh.equirect_directions(height, 2 * height)
    px = np.full((height, 2 * height, 3), sky, np.float32)
    px[dirs @ axis >= math.cos(half_angle)] = radiance
    return px


def _unit(v):
    v = np.asarray(v, np.float64)
    return v / np.linalg.norm(v)


def test_a_cap_gives_its_analytic_irradiance_and_direction():
    axis = _unit([0.3, -0.5, 0.6])
    half = math.radians(3.0)
    radiance, threshold = 2000.0, 10.0
    sun, clamped = world_sun.find(_cap_world(axis, half, radiance), threshold)
    expected = (radiance - threshold) * 2.0 * math.pi * (1.0 - math.cos(half))
    np.testing.assert_allclose(sun.irradiance, expected, rtol=0.03)
    assert math.degrees(math.acos(min(1.0, float(sun.direction @ axis)))) < 0.1
    lum = clamped @ np.array([0.2126, 0.7152, 0.0722], np.float32)
    assert lum.max() <= threshold * (1 + 1e-5)
    assert sun.others == 0.0


def test_a_single_texel_sun_is_finite_and_holds_its_texel():
    px = np.full((64, 128, 3), 0.2, np.float32)
    px[20, 37] = 1e6
    sun, clamped = world_sun.find(px, 10.0)
    theta0, theta1 = 20 * math.pi / 64, 21 * math.pi / 64
    omega = 2 * math.pi / 128 * (math.cos(theta0) - math.cos(theta1))
    np.testing.assert_allclose(sun.irradiance, (1e6 - 10.0) * omega, rtol=1e-4)
    assert sun.texels == 1 and np.isfinite(clamped).all()
    np.testing.assert_allclose(sun.direction, sh.equirect_directions(64, 128)[20, 37],
                               atol=1e-6)


def test_a_sun_across_the_seam_is_one_region():
    axis = _unit([-1.0, 0.001, 0.3])  # azimuth pi: the equirect's left and right edges
    sun, _ = world_sun.find(_cap_world(axis, math.radians(2.0), 500.0, height=256), 10.0)
    assert sun.others == 0.0
    assert float(sun.direction @ axis) > math.cos(math.radians(0.3))


def test_nan_texels_and_no_sun():
    px = np.full((32, 64, 3), 0.5, np.float32)
    px[3, 4] = np.nan
    px[5, 6] = np.inf
    sun, clamped = world_sun.find(px, 10.0)
    assert sun is None and np.isfinite(clamped).all()
    assert world_sun.find(px, 0.0)[0] is None


def _world(px, rotation=None, strength=1.0):
    tex = texture.make_texture(px, srgb=False, name="test")
    return World(texture=tex, strength=strength,
                 rotation=np.eye(3) if rotation is None else rotation)


def test_split_takes_the_brightest_of_two_suns_and_leaves_the_other():
    a, b = _unit([0.0, 1.0, 1.0]), _unit([1.0, 0.0, 0.3])
    px = _cap_world(a, math.radians(2.0), 3000.0, height=256)
    px[sh.equirect_directions(256, 512) @ b >= math.cos(math.radians(2.0))] = 1500.0
    world = world_sun.split(_world(px), 10.0, math.radians(0.5), True)
    sun = world.sun
    assert sun.kind == "SUN" and sun.radius == pytest.approx(math.radians(0.5))
    assert float(-sun.direction @ a) > math.cos(math.radians(0.3))
    lum = world.texture.linear(0)[..., :3] @ np.array([0.2126, 0.7152, 0.0722], np.float32)
    assert lum.max() == pytest.approx(1500.0, rel=1e-5)  # the second sun stays in the world


def test_split_follows_the_rotation_and_strength():
    rot = np.array([[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]])  # world -> texture
    axis_tex = _unit([1.0, 0.0, 0.5])
    px = _cap_world(axis_tex, math.radians(2.0), 400.0, height=256)
    plain = world_sun.split(_world(px), 20.0, 0.01)
    world = world_sun.split(_world(px, rot, strength=2.0), 20.0, 0.01)
    towards = -world.sun.direction
    np.testing.assert_allclose(rot @ towards, axis_tex, atol=2e-3)
    # the threshold is on the world's radiance: strength 2 halves it in texture units
    expected = (800.0 - 20.0) / (400.0 - 20.0) * plain.sun.color
    np.testing.assert_allclose(world.sun.color, expected, rtol=0.03)


def test_the_disc_seen_by_the_camera_holds_the_sun_irradiance():
    axis = _unit([0.2, 0.4, 0.9])
    px = _cap_world(axis, math.radians(3.0), 100.0, height=128)
    world = world_sun.split(_world(px), 5.0, math.radians(2.0))
    dirs = sh.equirect_directions(4096, 8192).reshape(-1, 3)
    omega = np.repeat(sh.equirect_solid_angles(4096, 8192), 8192)
    seen = world_sun.disc_radiance(world, dirs)
    np.testing.assert_allclose((seen * omega[:, None]).sum(0), world.sun.color, rtol=0.02)
