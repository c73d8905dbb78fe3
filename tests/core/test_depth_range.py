"""Long depth ranges: a camera with a clip start of 1 mm and a clip end of 50 km, its projection
in float32 as Blender's is, renders the frame of a 0.1 m to 100 m camera.

Independent values: the same scene and camera pose with an ordinary depth range; camera rays
from the camera's position to the points it projects to (``Camera`` definition).
"""

import dataclasses

import numpy as np
from test_volume_leaks import cube, grey, scene_of

from bo2_lighting.addon.core.render import pipeline
from bo2_lighting.addon.core.render.job import RenderJob
from bo2_lighting.addon.core.scene import Camera, Light


def lit_cube(near: float, far: float):
    cam = Camera.look_at((3.0, -4.0, 2.0), (0.0, 0.0, 0.0), 0.8, 64, 48, near, far)
    cam = dataclasses.replace(cam, projection=np.asarray(cam.projection, np.float32))
    sun = Light(kind="SUN", color=np.full(3, 3.0, np.float32),
                direction=np.array([-0.3, 0.2, -1.0]) / np.linalg.norm([-0.3, 0.2, -1.0]),
                shadow=True, radius=0.02)
    spot = Light(kind="SPOT", color=np.full(3, 200.0, np.float32),
                 position=np.array([2.0, -2.0, 3.0]), direction=np.array([-0.5, 0.5, -0.7]),
                 shadow=True, spot_size=1.2)
    floor = cube((-4.0, -4.0, -1.3), (4.0, 4.0, -1.0))  # the cube's shadow falls on it
    scene = scene_of(np.concatenate([cube(), floor]), grey())
    return dataclasses.replace(scene, camera=cam, lights=[sun, spot])


def test_camera_rays_hold_with_a_far_plane_at_infinity():
    cam = lit_cube(0.001, 5.0e4).camera
    assert np.asarray(cam.projection)[2, 2] == -1.0  # far at infinity in float32
    x, y = np.array([0.5, 31.5, 63.5]), np.array([0.5, 23.5, 47.5])
    origins, directions = cam.rays(x, y)
    assert np.isfinite(origins).all() and np.isfinite(directions).all()
    eye = np.array([3.0, -4.0, 2.0])
    forward = -np.asarray(cam.world_to_camera, np.float64)[2, :3]
    np.testing.assert_allclose(np.linalg.norm(directions, axis=1), 1.0, rtol=1e-6)
    expected = eye + directions * (0.001 / (directions @ forward))[:, None]
    np.testing.assert_allclose(origins, expected, atol=1e-5)


def test_a_long_depth_range_renders_the_ordinary_frame():
    ordinary = pipeline.render_frame(RenderJob(lit_cube(0.1, 100.0)))
    long = pipeline.render_frame(RenderJob(lit_cube(0.001, 5.0e4)))
    for name, image in long.items():
        assert np.isfinite(image).all(), name
    for name in ("Depth", "Position", "Normal", "GlossDir"):
        np.testing.assert_allclose(long[name], ordinary[name], atol=1e-5)
    # the sun's cascades split the longer range otherwise: the shadows move by a texel or so
    diff = np.abs(long["Combined"] - ordinary["Combined"])
    assert diff.mean() < 5e-3 and np.mean(diff > 2e-3) < 0.05
    shadowed = long["DiffDir"][..., 0] < 0.5 * long["DiffDir"][..., 0].max()
    assert shadowed.mean() > 0.02  # the frame holds shadows, and they stayed


def test_a_negative_light_takes_light_away():
    """Cycles adds a light of negative power as it adds any other: the sum is linear."""
    scene = lit_cube(0.1, 100.0)
    sun, spot = scene.lights

    def diffuse(power):
        light = dataclasses.replace(spot, color=np.full(3, power, np.float32))
        return pipeline.render_frame(RenderJob(dataclasses.replace(scene, lights=[sun, light]))
                                     )["DiffDir"]

    plus, zero, minus = diffuse(200.0), diffuse(0.0), diffuse(-200.0)
    assert (plus - zero).max() > 0.05  # the spot lights part of the frame
    np.testing.assert_allclose(minus, 2.0 * zero - plus, atol=1e-5)


def test_a_sun_of_180_degrees_is_the_softest_not_the_hardest():
    scene = lit_cube(0.1, 100.0)
    sun = scene.lights[0]

    def shade(degrees):  # Blender stores the angle in float32: 180 degrees is a little over pi
        light = dataclasses.replace(sun, radius=float(np.float32(np.radians(degrees))))
        return pipeline.render_frame(RenderJob(dataclasses.replace(scene, lights=[light]))
                                     )["DiffDir"]

    hard, wide, widest = shade(0.0), shade(179.0), shade(180.0)
    assert np.abs(hard - wide).max() > 0.15  # a wide sun's shadow is another
    assert np.abs(widest - wide).max() < 0.03 and np.abs(widest - wide).mean() < 1e-4


def test_blenders_smallest_clip_start_keeps_the_nearest_surface():
    """At a clip start of 1 micrometre the float32 z/w of the cube's front and back faces are
    a few ulps apart; the depth test from 1 / w still sees the front ones."""
    ordinary = pipeline.render_frame(RenderJob(lit_cube(0.1, 100.0)))
    tiny = pipeline.render_frame(RenderJob(lit_cube(1e-6, 1e5)))
    np.testing.assert_allclose(tiny["Depth"], ordinary["Depth"], rtol=1e-5)
    np.testing.assert_allclose(tiny["Normal"], ordinary["Normal"], atol=1e-6)
    np.testing.assert_allclose(tiny["GlossDir"], ordinary["GlossDir"], atol=1e-5)


def test_a_huge_ground_keeps_point_and_spot_shadows():
    """A 2000 km ground under a cube: the shadows of a point light and a spot on the part of
    the ground a 8 m one covers are those of the 8 m one."""
    base = lit_cube(0.1, 100.0)
    point = Light(kind="POINT", color=np.full(3, 200.0, np.float32),
                  position=np.array([2.0, -2.0, 3.0]), shadow=True, radius=0.05)
    for light in (base.lights[1], point):
        frames = []
        for half in (4.0, 1e6):
            tris = np.concatenate([cube(), cube((-half, -half, -1.3), (half, half, -1.0))])
            scene = dataclasses.replace(scene_of(tris, grey()), camera=base.camera,
                                        lights=[light])
            frames.append(pipeline.render_frame(RenderJob(scene)))
        small, huge = frames
        on_small = small["Depth"][..., 0] < 1e9
        dark = small["DiffDir"][..., 0] < 0.3 * small["DiffDir"][..., 0].max()
        assert (dark & on_small).mean() > 0.05  # the small ground holds the shadow
        diff = np.abs(huge["DiffDir"] - small["DiffDir"])[on_small]
        assert np.mean(diff.max(-1) > 0.02) < 0.01, light.kind


def test_a_huge_ground_keeps_the_suns_shadow():
    """A low sun casts the cube's shadow towards the camera on a 8 m and on a 2000 km ground,
    with the far plane at 100 m and at 50 km: the cascades cover what the camera sees of the
    ground (not its whole extent) and their depth ranges and biases the casters in each
    square, so the shadow stays where the 8 m ground has it. (The huge ground's receivers are
    placed to float32 barycentric precision, about 1e-7 of its size: its shadow edge is
    noisier.)"""
    direction = np.array([0.5, -0.7, -0.6]) / np.linalg.norm([0.5, -0.7, -0.6])
    sun = Light(kind="SUN", color=np.full(3, 3.0, np.float32), direction=direction,
                shadow=True, radius=0.02)
    for far in (100.0, 5.0e4):
        camera = lit_cube(0.1, far).camera
        frames = []
        for half in (4.0, 1e6):
            tris = np.concatenate([cube(), cube((-half, -half, -1.3), (half, half, -1.0))])
            scene = dataclasses.replace(scene_of(tris, grey()), camera=camera, lights=[sun])
            frames.append(pipeline.render_frame(RenderJob(scene)))
        small, huge = frames
        ground = ((small["Depth"][..., 0] < 1e9) & (small["Normal"][..., 2] > 0.99)
                  & (small["Position"][..., 2] < -0.99))
        lit = small["DiffDir"][..., 0][ground].max()
        in_small = (small["DiffDir"][..., 0] < 0.5 * lit) & ground
        in_huge = (huge["DiffDir"][..., 0] < 0.5 * lit) & ground
        assert in_small.sum() > 0.25 * ground.sum()  # the shadow covers a third of the ground
        assert abs(int(in_huge.sum()) - int(in_small.sum())) < 0.1 * in_small.sum(), far
        assert np.mean((in_small == in_huge)[ground]) > 0.93, far
