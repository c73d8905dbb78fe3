"""Irradiance volumes without leaks, and bounces that converge, through the real captures.

Independent values:
- the surroundings of a point in a solid cube [-1, 1]^3 (outward faces): only back faces, the
  nearest one straight along an axis at the distance from the point to that face (to the
  texel centre's direction: 1 / cos of its angle to the axis); outside it, only front faces;
- dilation: the inverse-squared-distance mean of the valid neighbours, written out by hand;
- look-ups: the trilinear weights of a two-sample grid written out by hand; the facing weight
  max(0, dot(unit(sample - point), normal) + bias) of a sample straight behind the surface is 0;
- depth moments: the distance from the centre of a box to its walls along a direction d is
  1 / max|d_i| (half side 1), averaged over the lobe by a quadrature on a fine cube apart from
  the code's; a sample behind a wall sees it nearer than a point beyond it, so Chebyshev's
  bound leaves it out (its weight the cube of var / (var + (r - mean)^2), written out);
- bounces in a closed box of albedo rho and emission E (every wall sees the same radiance, and
  no reflection probe or world gives specular light): after n bounces the captured radiance is
  E (1 + rho + ... + rho^(n-1)), whose limit is E / (1 - rho).
"""

import dataclasses
import math

import numpy as np

from bo2_lighting.addon.core.bakes import bake, capture
from bo2_lighting.addon.core.lighting import probes as cp
from bo2_lighting.addon.core.render.job import RenderJob
from bo2_lighting.addon.core.scene import (
    Camera,
    Light,
    Material,
    MeshBatch,
    RenderSettings,
    Scene,
    World,
)

C00 = 2.0 * math.sqrt(math.pi)


def cube(lo=(-1.0, -1.0, -1.0), hi=(1.0, 1.0, 1.0), inward=False) -> np.ndarray:
    """(12, 3, 3) float32 triangles of an axis-aligned box, counter-clockwise seen from
    outside (from inside with ``inward``)."""
    lo, hi = np.asarray(lo, np.float64), np.asarray(hi, np.float64)
    c, h, e = (lo + hi) / 2, (hi - lo) / 2, np.eye(3)
    tris = []
    for ax in range(3):
        u, v = e[(ax + 1) % 3] * h[(ax + 1) % 3], e[(ax + 2) % 3] * h[(ax + 2) % 3]
        for s in (1.0, -1.0):
            f = c + s * e[ax] * h[ax]
            q = [f - u - v, f + u - v, f + u + v, f - u + v]  # normal u x v = +axis
            if (s < 0) != inward:
                q = q[::-1]
            tris += [[q[0], q[1], q[2]], [q[0], q[2], q[3]]]
    return np.array(tris, np.float32)


def scene_of(triangles, material: Material) -> Scene:
    n = np.cross(triangles[:, 1] - triangles[:, 0], triangles[:, 2] - triangles[:, 0])
    n /= np.linalg.norm(n, axis=-1, keepdims=True)
    normals = np.repeat(n[:, None], 3, 1).astype(np.float32)
    mesh = MeshBatch(triangles, normals, np.zeros(len(triangles), np.int32), name="box")
    cam = Camera.look_at((0, -5, 0), (0, 0, 0), 1.0, 16, 16, 0.1, 100.0)
    return Scene(camera=cam, meshes=[mesh], materials=[material],
                 settings=RenderSettings(samples=1, shadow_resolution=64))


def grey() -> Material:
    return Material.talk(albedo=(0.5, 0.5, 0.5), rf0=(0.0, 0.0, 0.0), gloss=0.0)


def test_surfaces_of_a_solid_cube():
    grab = capture.Capture(RenderJob(scene_of(cube(), grey())))
    inside = grab.surfaces(np.array([0.0, 0.0, 0.0]), 16, 0.01, 100.0)
    assert inside.front_ratio == 0.0
    centre = 1.0 / 16  # the texel centres nearest an axis are at a = b = 1/16
    np.testing.assert_allclose(inside.back_distance, math.sqrt(1 + 2 * centre**2), rtol=1e-4)
    near_face = grab.surfaces(np.array([0.0, 0.0, 0.9]), 16, 0.01, 100.0)
    np.testing.assert_allclose(near_face.back_distance, 0.1 * math.sqrt(1 + 2 * centre**2),
                               rtol=1e-3)
    assert near_face.back_direction[2] > 0.99  # out through the top face
    outside = grab.surfaces(np.array([3.0, 0.5, 0.0]), 16, 0.01, 100.0)
    assert outside.front_ratio == 1.0 and outside.back_direction is None
    empty = grab.surfaces(np.array([50.0, 0.0, 0.0]), 16, 0.01, 10.0)  # nothing within 10 m
    assert empty.front_ratio == 1.0


def run_escape(spec, grab):
    steps, count = bake.escape(spec, grab.surfaces, 16, 0.01, 100.0), 0
    while True:
        try:
            next(steps)
            count += 1
        except StopIteration as end:
            assert count == len(spec.points)  # one step per sample
            return end.value


def test_escape_moves_samples_just_inside_geometry_out():
    # a 4 x 1 x 1 volume over x in [-4, 4]: samples at x = -3, -1, 1, 3, spacing 2, in a solid
    # box x in [-2, 2], y and z in [-1, 1]: the middle two are 1 m deep, beyond an escape of
    # 0.1 spacings (0.2 m)
    m = np.diag([4.0, 1.0, 1.0, 1.0])
    spec = bake.ProbeSpec("V", "irradiance", m, 0.0, resolution=(4, 1, 1))
    grab = capture.Capture(RenderJob(scene_of(cube((-2.0, -1.0, -1.0), (2.0, 1.0, 1.0)), grey())))
    points, ratios, moved, _ = run_escape(spec, grab)
    np.testing.assert_array_equal(ratios, [1.0, 0.0, 0.0, 1.0])
    assert moved == 0
    # a box x in [-1.1, 1.1], y and z in [-1.5, 1.5]: the middle samples are 0.1 m inside the x
    # faces (within 0.1 spacings) and escape through them
    grab = capture.Capture(RenderJob(scene_of(cube((-1.1, -1.5, -1.5), (1.1, 1.5, 1.5)), grey())))
    points, ratios, moved, _ = run_escape(spec, grab)
    assert (ratios >= 0.5).all() and moved == 2
    assert points[1, 0] < -1.1 and points[2, 0] > 1.1  # through the faces nearest to them
    np.testing.assert_allclose(points[[0, 3]], [[-3, 0, 0], [3, 0, 0]])


def test_dilation_takes_the_valid_neighbours_light():
    coeffs = np.zeros((4, 1, 1, 9, 3), np.float32)
    coeffs[:, 0, 0, 0, 0] = [1.0, 99.0, 3.0, 99.0]
    settings = bake.VolumeSettings(dilation_radius=1.0)  # thresholds 0.5 and 0.4
    ratios = np.array([1.0, 0.0, 0.8, 0.0]).reshape(4, 1, 1)
    out, validity = bake.dilate(coeffs, ratios, settings)
    assert out[1, 0, 0, 0, 0] == 2.0  # (1 + 3) / 2: both one step away
    assert out[3, 0, 0, 0, 0] == 3.0  # its one valid neighbour
    np.testing.assert_array_equal(validity.reshape(-1), [1, 1, 1, 1])
    ratios = np.array([1.0, 0.0, 0.3, 0.45]).reshape(4, 1, 1)
    out, validity = bake.dilate(coeffs, ratios, bake.VolumeSettings(dilation_radius=2.0))
    # sample 2 has sample 0 two steps away (weight 1/4); sample 3 has no valid one within 2:
    # its ratio 0.45 is above the validity threshold, so it keeps its own light
    assert out[2, 0, 0, 0, 0] == 1.0 and out[1, 0, 0, 0, 0] == 1.0
    np.testing.assert_array_equal(validity.reshape(-1), [1, 1, 1, 1])
    assert out[3, 0, 0, 0, 0] == 99.0
    ratios[3] = 0.2  # below it: left out
    _, validity = bake.dilate(coeffs, ratios, bake.VolumeSettings(dilation_radius=2.0))
    np.testing.assert_array_equal(validity.reshape(-1), [1, 1, 1, 0])


def two_samples(left=10.0, right=0.0, **settings) -> cp.IrradianceVolume:
    """Samples at x = -1 (``left``) and x = +1 (``right``): the box x in [-2, 2]."""
    coeffs = np.zeros((2, 1, 1, 9, 3), np.float32)
    coeffs[0, 0, 0, 0], coeffs[1, 0, 0, 0] = left, right
    return cp.IrradianceVolume("V", np.diag([2.0, 1.0, 1.0, 1.0]), (2, 1, 1), coeffs,
                               **settings)


def test_look_up_does_not_pull_light_through_a_wall():
    """A wall at x = 0 between a bright sample (left) and a dark one: a point just right of
    the wall, facing right, gets the dark side's light alone."""
    point, normal = np.array([[0.05, 0.0, 0.0]]), np.array([[1.0, 0.0, 0.0]], np.float32)
    plain = two_samples().sample_sh(point)[0, 0, 0]
    np.testing.assert_allclose(plain, 10.0 * 0.475, rtol=1e-5)  # trilinear: t = 0.525
    facing = two_samples(facing_bias=0.5).sample_sh(point, normal)[0, 0, 0]
    assert facing == 0.0  # the left sample is straight behind: max(0, -1 + 0.5)
    # a sample left out (validity 0) is not blended either
    invalid = two_samples(validity=np.array([0.0, 1.0], np.float32).reshape(2, 1, 1))
    assert invalid.sample_sh(point)[0, 0, 0] == 0.0
    # where every weight is 0, the plain blend stands in
    none = two_samples(validity=np.zeros((2, 1, 1), np.float32))
    np.testing.assert_allclose(none.sample_sh(point)[0, 0, 0], plain, rtol=1e-6)
    # and where facing leaves nothing (a point facing away from both), the valid samples alone
    away = np.array([[0.0, 0.0, 1.0]], np.float32)
    only_right = two_samples(facing_bias=-0.5, validity=np.array([0.0, 1.0], np.float32)
                             .reshape(2, 1, 1))
    assert only_right.sample_sh(point, away)[0, 0, 0] == 0.0
    only_left = two_samples(facing_bias=-0.5, validity=np.array([1.0, 0.0], np.float32)
                            .reshape(2, 1, 1))
    assert only_left.sample_sh(point, away)[0, 0, 0] == 10.0


def test_depth_moments_of_the_centre_of_a_room():
    """The moments of the captured distances at the centre of a room [-1, 1]^3 (seen from
    inside) against the lobe average of 1 / max|d_i| on a 64-texel cube: within 1.5%, from a
    16-texel capture and from a 64-texel one (averaged down to ``CAPTURE_MAX`` first)."""
    from bo2_lighting.addon.core.formulas import cubemap
    from bo2_lighting.addon.core.lighting import sample_visibility as sv

    grab = capture.Capture(RenderJob(scene_of(cube(inward=True), grey())))
    fine = cubemap.texel_directions64(64).reshape(-1, 3)
    solid = np.broadcast_to(cubemap.texel_solid_angles(64), (6, 64, 64)).reshape(-1)
    dist = 1.0 / np.abs(fine).max(axis=1)
    out = cubemap.texel_directions64(sv.SIZE).reshape(-1, 3)
    lobe = np.maximum(out @ fine.T, 0.0) ** sv.LOBE_POWER * solid
    lobe /= lobe.sum(axis=1, keepdims=True)
    for size in (16, 64):
        seen = grab.surfaces(np.zeros(3), size, 0.01, 100.0)
        assert np.isfinite(seen.distances).all()
        m = sv.moments(seen.distances, far=10.0)
        assert m.shape == (6, sv.SIZE, sv.SIZE, 2)
        np.testing.assert_allclose(m[..., 0].reshape(-1), lobe @ dist, rtol=0.015)
        np.testing.assert_allclose(m[..., 1].reshape(-1), lobe @ dist ** 2, rtol=0.03)
    # the distances are clamped: beyond `far` the moments hold far and far squared
    np.testing.assert_allclose(sv.moments(seen.distances, far=0.5)[..., 0], 0.5, rtol=1e-6)


def test_visibility_test_leaves_out_a_sample_behind_a_wall():
    """Two samples at x = -1 (bright) and x = +1 (dark) with a wall x in [-0.1, 0] between
    them, their moments captured: a point right of the wall gets the dark sample's light
    alone (the bright one sees the wall 0.9 m away, the point 1.15 m away), a point left of
    it the bright one's alone; without the test, the trilinear blend."""
    from bo2_lighting.addon.core.lighting import sample_visibility as sv

    wall = cube((-0.1, -4.0, -4.0), (0.0, 4.0, 4.0))
    grab = capture.Capture(RenderJob(scene_of(wall, grey())))
    vol = two_samples()
    far = sv.max_distance(vol.local_to_world, vol.resolution)
    moments = np.stack([sv.moments(grab.surfaces(p, 16, 0.01, 100.0).distances, far)
                        for p in cp.volume_sample_positions(vol.local_to_world, vol.resolution)
                        .reshape(-1, 3)])
    vol = two_samples(moments=moments.reshape(2, 1, 1, *moments.shape[1:]))
    points = np.array([[0.15, 0.0, 0.0], [-0.5, 0.0, 0.0]])
    normal = np.array([[1.0, 0.0, 0.0], [-1.0, 0.0, 0.0]], np.float32)
    plain = vol.sample_sh(points, normal)[:, 0, 0]
    np.testing.assert_allclose(plain, [10.0 * 0.425, 10.0 * 0.75], rtol=1e-5)
    tested = vol.sample_sh(points, normal, visibility=True)[:, 0, 0]
    # the bright sample's weight for the first point, from its moments towards it
    mean, square = moments[0, 0, sv.SIZE // 2, sv.SIZE // 2]  # +X, at the face's centre
    assert 0.88 < mean < 0.95
    left = 0.425 * sv.chebyshev(1.15, mean, square, vol.variance_floor())
    assert left < 1e-3
    np.testing.assert_allclose(tested, [10.0 * left / (left + 0.575), 10.0], atol=0.02)


def test_normal_and_view_bias_move_the_look_up():
    point = np.array([[-1.0, 0.0, 0.0]])
    normal = np.array([[1.0, 0.0, 0.0]], np.float32)
    view = np.array([[0.0, 1.0, 0.0]], np.float32)
    vol = two_samples(left=0.0, right=1.0, normal_bias=0.25, view_bias=0.5)
    # a quarter spacing (0.5 m of 2) along the normal: x = -0.5, a quarter of the way to the
    # right one; the view bias is across the grid (y), which it does not vary along
    np.testing.assert_allclose(vol.sample_sh(point, normal, view)[0, 0, 0], 0.25, rtol=1e-6)
    view = np.array([[1.0, 0.0, 0.0]], np.float32)  # half a spacing (1 m) more along x
    np.testing.assert_allclose(vol.sample_sh(point, normal, view)[0, 0, 0], 0.75, rtol=1e-6)


def test_bounces_in_a_closed_white_box_converge_to_the_geometric_series():
    emission, rho = 1.0, 0.5
    box = Material.talk(albedo=(rho,) * 3, rf0=(0.0, 0.0, 0.0), gloss=0.0,
                        emission=(emission,) * 3)
    grab = capture.Capture(RenderJob(scene_of(cube(inward=True), box)))
    spec = bake.ProbeSpec("Box", "irradiance", np.eye(4), 0.0, resolution=(1, 1, 1),
                          clip_start=0.01, clip_end=10.0)
    values = []
    for bounces in range(1, 6):
        job = bake.Bake([spec], World(color=np.zeros(3, np.float32)), grab.cube,
                        bounces=bounces, volume_face_size=8, surfaces=grab.surfaces)
        for _ in job.steps():
            pass
        (result,) = job.results
        assert result.validity.all() and result.escaped == 0  # a room: front faces
        values.append(float(result.coeffs[0, 0, 0]) / C00)
    expected = [emission * sum(rho**k for k in range(n)) for n in range(1, 6)]
    np.testing.assert_allclose(values, expected, rtol=2e-3)
    added = np.diff(values)
    assert (added[1:] < added[:-1]).all()  # each bounce adds less than the one before
    limit = emission / (1 - rho)
    gaps = limit - np.array(values)
    assert (gaps > 0).all() and (gaps[1:] < gaps[:-1]).all()


def test_converged_bounces_match_many_explicit_ones_in_a_lit_room():
    """A closed room of albedo 0.7 lit by a small emissive panel under its ceiling (so the
    light is uneven and each bounce's ratio varies over the room): three bounces with the
    rest estimated (``series``) are within 3% of 24 explicit bounces (0.7^24 < 2e-4 of the
    light left out) at every volume sample, five within 1%; three alone fall a third short
    on average."""
    walls = cube((-2.0, -1.5, 0.0), (2.0, 1.5, 2.5), inward=True)
    panel = cube((-0.3, -0.3, 2.3), (0.3, 0.3, 2.35))
    tris = np.concatenate([walls, panel])
    scene = scene_of(tris, Material.talk(albedo=(0.7, 0.7, 0.7), rf0=(0.0, 0.0, 0.0),
                                         gloss=0.0))
    glow = Material.talk(albedo=(0.0, 0.0, 0.0), rf0=(0.0, 0.0, 0.0), gloss=0.0,
                         emission=(20.0, 20.0, 20.0))
    mesh = dataclasses.replace(scene.meshes[0], material=np.repeat(
        np.array([0, 1], np.int32), [len(walls), len(panel)]))
    scene = dataclasses.replace(scene, meshes=[mesh], materials=[scene.materials[0], glow])
    grab = capture.Capture(RenderJob(scene))
    room = np.diag([1.8, 1.3, 1.0, 1.0])
    room[2, 3] = 1.1
    spec = bake.ProbeSpec("Room", "irradiance", room, 1.0, resolution=(3, 3, 3),
                          clip_start=0.01, clip_end=10.0)

    def baked(bounces, converge):
        job = bake.Bake([spec], World(color=np.zeros(3, np.float32)), grab.cube,
                        bounces=bounces, converge=converge, volume_face_size=8)
        for _ in job.steps():
            pass
        return job.results[0].coeffs[:, 0, 0]

    many, three = baked(24, False), baked(3, False)
    np.testing.assert_allclose(baked(3, True), many, rtol=0.03)
    np.testing.assert_allclose(baked(5, True), many, rtol=0.01)
    assert (three < 0.9 * many).all() and three.mean() < 0.7 * many.mean()


def test_surfaces_build_no_shadow_maps():
    """The validity rays need the geometry only: a Capture asked for surfaces builds no shadow
    map (a Cycles bake renders its own light), and a cube map rendered afterwards has its
    shadows, equal to a fresh Capture's."""
    floor = cube((-3.0, -3.0, -1.3), (3.0, 3.0, -1.0))
    tris = np.concatenate([cube((-0.3, -0.3, -1.0), (0.3, 0.3, -0.4)), floor])
    light = Light(kind="POINT", color=np.full(3, 50.0, np.float32),
                  position=np.array([0.2, 0.1, 1.0]), shadow=True, radius=0.05)
    scene = dataclasses.replace(scene_of(tris, grey()), lights=[light])
    grab = capture.Capture(RenderJob(scene))
    grab.surfaces(np.array([1.5, 0.0, -0.5]), 16, 0.01, 100.0)
    assert not any(grab._frame.shadow_maps)  # the light's and the sky's: none built
    later = grab.cube(np.array([1.5, 0.0, -0.5]), 16, 0.01, 100.0)
    assert grab._frame.shadow_maps[0] is not None
    fresh = capture.Capture(RenderJob(scene)).cube(np.array([1.5, 0.0, -0.5]), 16, 0.01, 100.0)
    np.testing.assert_array_equal(later, fresh)


def test_captures_see_objects_the_camera_does_not():
    """A probe gathers the light of objects hidden from the camera (Camera ray visibility off),
    as Cycles' indirect light does: the capture inside a camera-invisible box sees its walls."""
    scene = scene_of(cube(inward=True), grey())
    scene.world.color = np.full(3, 1.0, np.float32)
    seen = capture.Capture(RenderJob(scene)).cube(np.zeros(3), 8, 0.01, 100.0)
    scene.meshes[0].camera = False
    hidden = capture.Capture(RenderJob(scene)).cube(np.zeros(3), 8, 0.01, 100.0)
    np.testing.assert_array_equal(hidden, seen)
    assert seen.max() < 0.5  # the walls, not the bright world


def test_objects_hidden_from_a_kind_of_probe():
    """Object > Visibility > Light Probes: a block hidden from Sphere probes is not in their
    captures (the floor under it shows there) yet still shades the floor it stands on; the
    Volume captures and the volumes' surfaces see it."""
    floor = cube((-3.0, -3.0, -1.3), (3.0, 3.0, -1.0))
    block = cube((-0.5, -0.5, -0.9), (0.5, 0.5, 0.0))
    normals = [np.repeat(np.cross(t[:, 1] - t[:, 0], t[:, 2] - t[:, 0])[:, None], 3, 1)
               for t in (floor, block)]
    meshes = [MeshBatch(t, (n / np.linalg.norm(n, axis=-1, keepdims=True)).astype(np.float32),
                        np.zeros(len(t), np.int32), name=name, sphere_probes=name != "block")
              for t, n, name in zip((floor, block), normals, ("floor", "block"), strict=True)]
    light = Light(kind="SUN", color=np.full(3, 3.0, np.float32),
                  direction=np.array([0.0, 0.0, -1.0]), shadow=True)
    scene = dataclasses.replace(scene_of(floor, grey()), meshes=meshes, lights=[light])
    scene.world.color = np.zeros(3, np.float32)
    grab = capture.Capture(RenderJob(scene))
    above = np.array([0.0, 0.0, 1.0])
    down = 5  # the face looking along -Z (``cubemap.FACES``)
    sphere = grab.cube(above, 16, 0.01, 100.0)[down]
    volume = grab.cube(above, 16, 0.01, 100.0, kind="irradiance")[down]
    centre = (slice(6, 10), slice(6, 10))  # straight down: the block's top, 1 m away
    lit = 0.5 / math.pi * 3.0  # a lit floor or top: albedo / pi x irradiance
    np.testing.assert_allclose(volume[centre].mean(), lit, rtol=0.05)  # the block's top
    assert sphere[centre].max() < 0.05 * lit  # the floor beneath it, in its shadow
    assert sphere[0, 0].mean() > 0.5 * lit  # the floor beyond the shadow is lit
    assert grab.surfaces(np.array([0.0, 0.0, -0.5]), 16, 0.01, 100.0).front_ratio == 0.0
