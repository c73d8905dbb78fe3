"""One frame through the core pipeline, checked per pixel against closed-form radiance.

Independent values: the world position under each pixel centre is computed here from the
orthographic camera's definition, and the radiance from the light's closed-form irradiance
(E = P / (4 pi d^2) for a point light, E = S for a sun) times the Lambert BRDF albedo / pi.
"""

import threading

import numpy as np
import pytest

from bo2_lighting.addon.core.render import pipeline, projection, raster, visibility
from bo2_lighting.addon.core.render.job import Cancelled, RenderJob
from bo2_lighting.addon.core.scene import Camera, Light, Material, MeshBatch, RenderSettings, Scene

W, H = 40, 30
HALF_W, HALF_H = 2.0, 1.5  # orthographic half extents, metres (4:3 like the image)


def ortho_camera(height=5.0):
    """Looking straight down -Z from (0, 0, height); x right, y up in the image."""
    view = np.eye(4)
    view[2, 3] = -height
    near, far = 0.1, 100.0
    proj = np.diag([1 / HALF_W, 1 / HALF_H, -2 / (far - near), 1.0])
    proj[2, 3] = -(far + near) / (far - near)
    return Camera(world_to_camera=view, projection=proj, width=W, height=H, orthographic=True)


def floor(size=10.0):
    """A square in the z = 0 plane, two counter-clockwise triangles facing +Z."""
    s = size / 2
    quad = np.array([[-s, -s, 0], [s, -s, 0], [s, s, 0], [-s, s, 0]], np.float32)
    pos = quad[[[0, 1, 2], [0, 2, 3]]]
    nrm = np.broadcast_to(np.float32([0, 0, 1]), pos.shape).copy()
    return MeshBatch(pos, nrm, np.array([1, 1], np.int32), name="floor")


def pixel_centres():
    """(H, W, 3) world positions of the pixel centres on the floor, row 0 at the top."""
    x = (np.arange(W) + 0.5) / W * 2 * HALF_W - HALF_W
    y = HALF_H - (np.arange(H) + 0.5) / H * 2 * HALF_H
    xx, yy = np.meshgrid(x, y)
    return np.stack([xx, yy, np.zeros_like(xx)], -1)


def lambert_scene(light, albedo=0.6):
    mat = Material.talk(name="lambert", albedo=np.full(3, albedo, np.float32),
                        rf0=np.zeros(3, np.float32), gloss=0.0)
    return Scene(camera=ortho_camera(), meshes=[floor()], materials=[Material(), mat],
                 lights=[light], settings=RenderSettings(samples=1))


def test_point_light_matches_closed_form():
    light_pos = np.array([0.7, -0.4, 1.5])
    power = 80.0
    scene = lambert_scene(Light("POINT", color=np.full(3, power), position=light_pos))
    image = pipeline.render_frame(RenderJob(scene))["Combined"]
    p = pixel_centres()
    to_light = light_pos - p
    d2 = np.sum(to_light**2, -1)
    cos = to_light[..., 2] / np.sqrt(d2)
    expected = 0.6 / np.pi * power / (4 * np.pi * d2) * cos
    # rf0 = 0 leaves a Schlick Fresnel tail (1 - l.h)^5 that is < 1e-3 of the diffuse here.
    np.testing.assert_allclose(image[..., 0], expected, rtol=2e-3)
    assert (image[..., 3] == 1).all()


def test_sun_and_background_and_samples():
    sun = Light("SUN", color=np.array([2.0, 1.0, 0.5]), direction=np.array([0.0, 0.0, -1.0]))
    scene = lambert_scene(sun)
    scene.meshes[0] = floor(size=1.9)  # edges through pixel centres; background at the sides
    scene.world.color = np.array([0.1, 0.2, 0.3], np.float32)
    scene.settings.samples = 16
    image = pipeline.render_frame(RenderJob(scene))["Combined"]
    inside = np.abs(pixel_centres()[..., :2]).max(-1) < 0.9
    outside = np.abs(pixel_centres()[..., :2]).max(-1) > 1.1
    lit = 0.6 / np.pi * np.array([2.0, 1.0, 0.5])
    np.testing.assert_allclose(image[inside, :3], np.broadcast_to(lit, (inside.sum(), 3)),
                               rtol=1e-4)
    np.testing.assert_allclose(image[outside, :3],
                               np.broadcast_to([0.1, 0.2, 0.3], (outside.sum(), 3)), rtol=1e-6)
    # Pixels centred on the edge are half covered: about half of the filter's samples hit.
    edge = np.abs(np.abs(pixel_centres()[..., 0]) - 0.95) < 1e-6
    edge &= np.abs(pixel_centres()[..., 1]) < 0.8
    half = 0.5 * (0.1 + lit[0])
    np.testing.assert_allclose(image[edge, 0], half, atol=0.25 * (lit[0] - 0.1))


def test_film_transparent_alpha():
    scene = lambert_scene(Light("SUN", color=np.ones(3)))
    scene.meshes[0] = floor(size=2.0)
    scene.settings.film_transparent = True
    image = pipeline.render_frame(RenderJob(scene))["Combined"]
    assert image[0, 0, 3] == 0 and image[H // 2, W // 2, 3] == 1


def test_cancel_and_progress():
    scene = lambert_scene(Light("SUN", color=np.ones(3)))
    scene.settings.samples = 8
    scene.settings.threads = 1
    seen = []
    with pytest.raises(Cancelled):
        pipeline.render_frame(RenderJob(scene, progress=seen.append,
                                        should_stop=lambda: len(seen) >= 3))
    assert seen == [1 / 9, 2 / 9, 3 / 9]  # 8 rasters and the shading of one tile


def test_views_render_as_frames_of_their_own():
    """render_views (probe captures) gives, view by view, what render_frame gives through
    that camera, with several views' tiles sharing the threads."""
    scene = lambert_scene(Light("POINT", color=np.full(3, 50.0), position=np.array([0.5, 0, 2])))
    scene.settings.samples = 4
    scene.settings.tile_size = 16
    scene.settings.threads = 2
    cameras = [ortho_camera(h) for h in (5.0, 3.0)]
    cameras.append(Camera.look_at([1.0, -2.0, 3.0], [0, 0, 0], 1.0, W, H))
    views = pipeline.render_views(RenderJob(scene), cameras)
    assert len(views) == 3
    for camera, view in zip(cameras, views, strict=True):
        scene.camera = camera
        alone = pipeline.render_frame(RenderJob(scene))
        assert view.keys() == alone.keys()
        for name in alone:
            np.testing.assert_array_equal(view[name], alone[name])
    assert not np.array_equal(views[0]["Combined"], views[2]["Combined"])


def test_threads_render_the_same_image_and_cancel():
    scene = lambert_scene(Light("SUN", color=np.ones(3)))
    scene.settings.samples = 4
    scene.settings.tile_size = 8  # many tiles, so that several threads share them
    scene.settings.threads = 1
    one = pipeline.render_frame(RenderJob(scene))
    scene.settings.threads = 3
    calls = []
    three = pipeline.render_frame(RenderJob(
        scene, progress=calls.append, should_stop=lambda: calls.append(threading.get_ident())))
    for name in one:
        np.testing.assert_array_equal(one[name], three[name])
    # The host's callbacks run on the calling thread only.
    assert {c for c in calls if isinstance(c, int)} == {threading.get_ident()}
    progress = [c for c in calls if isinstance(c, float)]
    assert progress == sorted(progress) and progress[-1] == 1.0
    # Cancelling stops every thread: the work stops short of the end (cancelled after the
    # first of 20 tiles reports; the whole frame takes some 0.15 s, the threads may run on
    # while the calling thread waits to be scheduled).
    scene.settings.samples = 256
    seen = []
    with pytest.raises(Cancelled):
        pipeline.render_frame(RenderJob(scene, progress=seen.append,
                                        should_stop=lambda: len(seen) >= 1))
    assert len(seen) == 1 and seen[0] < 1.0


def test_broken_triangles_are_skipped_and_reported_once():
    scene = lambert_scene(Light("SUN", color=np.ones(3)))
    bad = floor()
    bad.positions[0, 0, 0] = np.nan  # one NaN triangle
    bad.positions[1, :, :] = bad.positions[1, 0]  # one zero-area triangle
    scene.meshes.append(bad)
    job = RenderJob(scene)
    image = pipeline.render_frame(job)["Combined"]
    assert job.warnings.texts() == [
        "Skipped 1 triangles with NaN or infinite vertices and 1 with zero area"]
    assert np.isfinite(image).all()
    np.testing.assert_allclose(image[..., 0], 0.6 / np.pi, rtol=1e-4)


def test_sample_offsets_follow_the_blackman_harris_filter():
    """Filter importance sampling: the offsets are distributed as Cycles' Blackman-Harris
    window of width 1.5 px, which Cycles spreads over twice the width (3 px); its mean and
    variance come from a direct numerical integral of the published window."""
    offsets = visibility.sample_offsets(4096, filter_width=1.5)
    assert offsets.shape == (4096, 2)
    assert offsets.min() >= 0.5 - 1.5 and offsets.max() <= 0.5 + 1.5
    x = np.linspace(-1.5, 1.5, 200001)
    t = 2 * np.pi * (x / 3.0 + 0.5)
    w = 0.35875 - 0.48829 * np.cos(t) + 0.14128 * np.cos(2 * t) - 0.01168 * np.cos(3 * t)
    variance = np.sum(w * x * x) / np.sum(w)
    np.testing.assert_allclose(offsets.mean(0), 0.5, atol=2e-3)
    np.testing.assert_allclose(offsets.var(0), variance, rtol=0.02)
    assert (visibility.sample_offsets(1) == 0.5).all()


def test_orthographic_depth_is_the_view_axis_distance():
    """Depth of an orthographic camera 5 m above the floor: 5 m everywhere (clip w is 1 for
    orthographic cameras, so it cannot stand in for the distance)."""
    scene = lambert_scene(Light("SUN", color=np.ones(3)))
    depth = pipeline.render_frame(RenderJob(scene))["Depth"][..., 0]
    np.testing.assert_allclose(depth, 5.0, rtol=1e-5)


def test_hostile_geometry_in_a_corner_of_an_8k_frame_stays_finite():
    """Huge triangles (1e30 m), NaN and zero-area ones, a point light inside the geometry and
    a 7680x4320 frame rendered through a border: every tile's every pass is finite."""
    light = Light("POINT", color=np.full(3, 50.0), position=np.array([0.0, 0.0, 0.5]),
                  radius=0.1)
    scene = lambert_scene(light)
    huge = floor(2e30)
    bad = floor()
    bad.positions[0, 0, 0] = np.nan
    bad.positions[1, :, :] = bad.positions[1, 0]
    scene.meshes += [huge, bad]
    scene.camera = Camera.look_at([0.0, -3.0, 2.0], [0.0, 0.0, 0.0], np.radians(50.0), 7680,
                                  4320, 0.1, 100.0)
    scene.settings.border = (3800, 2100, 3864, 2164)
    scene.settings.samples = 2
    seen = 0
    for (x0, y0, x1, y1), passes in pipeline.render_tiles(RenderJob(scene)):
        seen += (x1 - x0) * (y1 - y0)
        for name, image in passes.items():
            finite = np.isfinite(image) if name != "Depth" else ~np.isnan(image)
            assert finite.all(), name
        assert (passes["Combined"][..., 3] == 1.0).all()  # the floors cover the border
        assert passes["Combined"][..., 0].max() > 0.0  # and the light reaches them
    assert seen == 64 * 64


def test_instanced_batches_and_the_memory_they_need():
    """A batch of I instances of one mesh (per-instance world_to_object): each triangle knows
    its instance's matrix; a frame with more triangles than a raster keeps at once draws
    from its projection a chunk at a time (the same image as one set-up); ``memory.
    frame_bytes`` is within 10% of what the prepared frame and its shadow maps hold."""
    from bo2_lighting.addon.core.render import memory

    cube = np.array([[[0, 0, 0], [1, 0, 0], [1, 1, 0]], [[0, 0, 0], [1, 1, 0], [0, 1, 0]]],
                    np.float32) * 0.4 - [0.2, 0.2, 0.0]
    count = 400
    shift = np.stack(np.meshgrid(np.arange(20), np.arange(20)), -1).reshape(-1, 2) * 0.45
    shift = np.column_stack([shift - 4.3, np.full(count, 0.01)]).astype(np.float32)
    positions = (cube[None] + shift[:, None, None]).reshape(-1, 3, 3)
    normals = np.broadcast_to(np.float32([0, 0, 1]), positions.shape).copy()
    inverse = np.tile(np.eye(4), (count, 1, 1))
    inverse[:, :3, 3] = -shift
    batch = MeshBatch(positions, normals, np.zeros(len(positions), np.int32),
                      world_to_object=inverse)
    scene = lambert_scene(Light("POINT", np.full(3, 2000.0, np.float32),
                                position=np.array([0.0, 0.0, 3.0])))
    scene.settings.shadow_resolution = 256
    scene.meshes.append(batch)
    frame = pipeline.prepare(RenderJob(scene))
    assert frame.world_to_object.shape == (count + 1, 4, 4)  # the floor's, then each instance
    assert (np.bincount(frame.obj) == [2] + [2] * count).all()
    held = sum(a.nbytes for a in (frame.positions, frame.normals, frame.uvs, frame.material,
                                  frame.obj, frame.has_uv, frame.holdout, frame.fades,
                                  frame.world_to_object, frame.texspace))
    held += sum(m.depth.nbytes + m.mips.nbytes for m in frame.shadow_maps if m is not None)
    assert memory.frame_bytes(scene) == pytest.approx(held, rel=0.1)
    whole = pipeline.render_frame(RenderJob(scene), frame=frame)["Combined"]
    saved = raster.SETUP_TRIANGLES, projection.CHUNK
    try:
        raster.SETUP_TRIANGLES, projection.CHUNK = 100, 150
        chunked = pipeline.render_frame(RenderJob(scene))["Combined"]
        assert isinstance(pipeline.prepare(RenderJob(scene)).clip, projection.Projection)
    finally:
        raster.SETUP_TRIANGLES, projection.CHUNK = saved
    assert np.abs(chunked - whole).mean() < 1e-3


@pytest.mark.parametrize("many", [False, True])
def test_camera_and_shadow_visibility(monkeypatch, many):
    """A card above the floor under a sun straight down: seen and casting, it covers the
    middle; unseen by the camera, the floor shows there and is in its shadow; casting no
    shadow, it is seen and the floor around it is fully lit. ``many``: the projection path of
    frames with very many triangles."""
    if many:
        monkeypatch.setattr(raster, "SETUP_TRIANGLES", 1)
    sun = Light("SUN", color=np.ones(3), direction=np.array([0.0, 0.0, -1.0]), shadow=True)
    card = floor(size=1.0)
    card.positions = card.positions + np.float32([0, 0, 1])
    card.material = np.array([2, 2], np.int32)
    bright = Material.talk(name="card", albedo=np.full(3, 0.9, np.float32),
                           rf0=np.zeros(3, np.float32), gloss=0.0)

    def render(camera, shadow):
        scene = lambert_scene(sun)
        scene.materials.append(bright)
        card.camera, card.shadow = camera, shadow
        scene.meshes.append(card)
        return pipeline.render_frame(RenderJob(scene))["Combined"][H // 2, W // 2, 0]

    lit_floor, lit_card = 0.6 / np.pi, 0.9 / np.pi
    assert render(True, True) == pytest.approx(lit_card, rel=1e-3)
    assert render(False, True) == pytest.approx(0.0, abs=1e-3)  # the floor, in shadow
    assert render(True, False) == pytest.approx(lit_card, rel=1e-3)
    assert render(False, False) == pytest.approx(lit_floor, rel=1e-3)
