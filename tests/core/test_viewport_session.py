"""The progressive viewport session: refinement, cancellation, kept work, look-dev views.

Images are checked against the closed-form radiance of ``test_pipeline`` (a Lambert floor under
a point light), not against another render path.
"""

import dataclasses
import threading

import numpy as np
import pytest
from test_pipeline import HALF_H, HALF_W, H, W, lambert_scene, pixel_centres

from bo2_lighting.addon.core.lighting.probes import Probes, ReflectionProbe
from bo2_lighting.addon.core.render import buffers, pipeline, viewport, visibility
from bo2_lighting.addon.core.render.job import RenderJob
from bo2_lighting.addon.core.scene import Light, Material, program

LIGHT = np.array([0.7, -0.4, 1.5])
POWER = 80.0


def expected(albedo=0.6, samples=4):
    """(H, W) red radiance of the floor under the point light (row 0 at the top), averaged
    over the viewport's sample positions in each pixel (``visibility.sample_offsets``)."""
    total = 0.0
    for ox, oy in visibility.sample_offsets(samples):
        p = pixel_centres() + [(ox - 0.5) * 2 * HALF_W / W, -(oy - 0.5) * 2 * HALF_H / H, 0.0]
        to_light = LIGHT - p
        d2 = np.sum(to_light**2, -1)
        total = total + POWER / (4 * np.pi * d2) * to_light[..., 2] / np.sqrt(d2)
    return albedo / np.pi * total / samples


def scene(albedo=0.6):
    return lambert_scene(Light("POINT", color=np.full(3, POWER), position=LIGHT), albedo)


@pytest.fixture
def session():
    s = viewport.Session(samples=4)
    yield s
    s.close()


def test_preview_then_full_resolution_converges(session):
    seen = []
    session.on_image = lambda: seen.append(session.image())
    number = session.update(scene(), viewport.CHANGES)
    assert session.wait(60)
    shapes = [(i.pixels.shape, i.samples, i.final) for i in seen if i is not None]
    assert shapes[0] == ((H // 4, W // 4, 4), 0, False)  # the preview comes first
    assert [s for _, s, _ in shapes[1:]] == [1, 2, 3, 4]
    assert shapes[-1] == ((H, W, 4), 4, True)
    final = session.image()
    assert final.update == number and not final.data
    # rows bottom to top, as a texture takes them; within the closed form's tolerance
    np.testing.assert_allclose(final.pixels[::-1, :, 0], expected(), rtol=3e-3)


def test_material_tweak_keeps_geometry_and_shadows(session):
    session.update(scene(), viewport.CHANGES)
    assert session.wait(60)
    before = dict(session.stats)
    session.update(scene(albedo=0.3), {"materials"})
    assert session.wait(60)
    assert session.stats["prepares"] == before["prepares"]
    assert session.stats["material_tables"] == before["material_tables"] + 1
    np.testing.assert_allclose(session.image().pixels[::-1, :, 0], expected(0.3), rtol=3e-3)


def test_camera_move_projects_again_only(session):
    first = scene()
    session.update(first, viewport.CHANGES)
    assert session.wait(60)
    before = dict(session.stats)
    moved = dataclasses.replace(first, camera=dataclasses.replace(first.camera))
    moved.camera.world_to_camera = first.camera.world_to_camera.copy()
    moved.camera.world_to_camera[0, 3] = -1.0  # 1 m to the right: the image shifts by W / 4
    session.update(moved, {"camera"})
    assert session.wait(60)
    assert session.stats["prepares"] == before["prepares"]
    assert session.stats["projections"] == before["projections"] + 1
    shifted = np.roll(expected(), -W // 4, axis=1)[:, : W - W // 4]
    np.testing.assert_allclose(session.image().pixels[::-1, : W - W // 4, 0], shifted, rtol=3e-3)


def test_geometry_and_light_changes_prepare_again(session):
    session.update(scene(), viewport.CHANGES)
    assert session.wait(60)
    for change in ("geometry", "lights"):
        count = session.stats["prepares"]
        session.update(scene(), {change})
        assert session.wait(60)
        assert session.stats["prepares"] == count + 1


def test_a_drawer_gets_shadow_maps_to_draw_and_a_refusal_renders_here(session):
    """With a drawer (the GPU), the frame's shadow maps are left to it (``ShadowMap.on_gpu``);
    a frame it refuses, or one rendered after the drawer is gone, gets its maps built here."""
    session.drawer = lambda frame: None
    session.update(scene(), viewport.CHANGES)
    assert session.wait(60)
    frame, _ = session.frame()
    assert frame.shadow_maps and all(m.on_gpu for m in frame.shadow_maps if m is not None)
    assert session.image() is None  # nothing rendered here
    session.drawer = None  # the drawer gone: the maps of the frame kept are built here
    session.update(scene(albedo=0.3), {"materials"})
    assert session.wait(60)
    np.testing.assert_allclose(session.image().pixels[::-1, :, 0], expected(0.3), rtol=3e-3)
    session.drawer = lambda frame: None
    session.update(scene(), {"geometry"})
    assert session.wait(60) and session.frame() is not None
    session.drawer = lambda frame: "a refusal"  # refused: rendered here, its maps built here
    session.update(scene(), {"geometry"})
    assert session.wait(60) and session.refusal == "a refusal"
    np.testing.assert_allclose(session.image().pixels[::-1, :, 0], expected(), rtol=3e-3)


def test_a_world_lit_anew_keeps_the_dome(session):
    """The viewport's dome of shadow maps (``core.render.sky``) looks every way, so that a world
    turned, lit anew or darkened needs no new maps (an F12 of a black world builds none)."""
    from bo2_lighting.addon.core.lighting.world_probes import world_probes
    from bo2_lighting.addon.core.scene import World

    def lit(value):
        world = World(color=np.full(3, value, np.float32))
        return dataclasses.replace(scene(), world=world, probes=world_probes(world))

    session.update(lit(0.0), viewport.CHANGES)
    assert session.wait(60)
    assert session._frame.sky is not None
    assert pipeline.prepare(RenderJob(lit(0.0))).sky is None
    count = session.stats["prepares"]
    for value in (0.5, 0.8, 0.0):
        session.update(lit(value), {"world", "probes"})
        assert session.wait(60)
        assert session.stats["prepares"] == count and session._frame.sky is not None


def test_new_update_cancels_stale_work_within_a_tile(monkeypatch):
    started, release = threading.Event(), threading.Event()
    tiles_after = []
    real = pipeline.render_tile

    def slow_tile(frame, tile, offsets, tick, first_sample=0):
        if not started.is_set():
            started.set()
            release.wait(10)
        elif release.is_set() and frame.scene.materials[1].name == "stale":
            tiles_after.append(tile)
        return real(frame, tile, offsets, tick, first_sample)

    monkeypatch.setattr(pipeline, "render_tile", slow_tile)
    s = viewport.Session(samples=8)
    try:
        stale = scene()
        stale.materials[1].name = "stale"
        stale.settings.tile_size = 16  # several tiles per image
        stale.settings.threads = 1
        s.update(stale, viewport.CHANGES)
        assert started.wait(60)
        number = s.update(scene(albedo=0.3), viewport.CHANGES)
        release.set()
        assert s.wait(60)
        image = s.image()
        assert image.update == number and image.final
        assert len(tiles_after) == 0  # the stale render stopped at its next tile
        np.testing.assert_allclose(image.pixels[::-1, :, 0], expected(0.3, 8), rtol=3e-3)
    finally:
        s.close()


def test_views_switch_without_rendering(session):
    session.update(scene(), viewport.CHANGES)
    assert session.wait(60)
    renders = session.stats["renders"]
    session.set_view("ALBEDO")
    image = session.image()
    assert session.stats["renders"] == renders
    np.testing.assert_allclose(image.pixels[..., :3], 0.6, atol=1e-6)
    session.set_view("NORMAL")
    assert session.image().data
    np.testing.assert_allclose(session.image().pixels[..., :3],
                               np.broadcast_to([0.5, 0.5, 1.0], (H, W, 3)), atol=1e-5)
    session.set_view("GLOSS")
    np.testing.assert_allclose(session.image().pixels[..., :3], 0.0, atol=1e-6)
    with pytest.raises(ValueError, match="unknown view"):
        session.set_view("NOPE")


def test_probe_influence_colours_each_probe(session):
    s = scene()
    chains = {"bo1": [np.zeros((6, 1, 1, 3), np.float32)],
              "bo2": [np.zeros((6, 1, 1, 3), np.float32)]}
    probe = ReflectionProbe("left", np.array([-1.5, 0.0, 0.0]), 1.0, 0.0, chains,
                            np.zeros((9, 3), np.float32))
    s.probes = Probes(np.zeros((9, 3), np.float32), chains, np.zeros(3, np.float32),
                      reflection=[probe])
    session.set_view("REFLECTION_PROBES")
    session.update(s, viewport.CHANGES)
    assert session.wait(60)
    pixels = session.image().pixels[::-1]
    p = pixel_centres()
    inside = np.linalg.norm(p - probe.position, axis=-1) < 0.9
    outside = np.linalg.norm(p - probe.position, axis=-1) > 1.1
    np.testing.assert_allclose(pixels[inside, :3],
                               np.broadcast_to(viewport.PALETTE[0], (inside.sum(), 3)), atol=1e-6)
    np.testing.assert_allclose(pixels[outside, :3], viewport.WORLD_GREY, atol=1e-6)


def test_a_failed_update_shows_its_error_and_the_next_renders(session):
    broken = scene()
    broken.meshes[0].material = np.array([7, 7], np.int32)  # no such material
    session.update(broken, viewport.CHANGES)
    assert session.wait(60)
    assert "material index" in session.error
    session.update(scene(), viewport.CHANGES)
    assert session.wait(60)
    assert session.error is None and session.image().final


def test_unknown_change_is_refused(session):
    with pytest.raises(ValueError, match="unknown changes"):
        session.update(scene(), {"colour"})


def test_with_materials_refuses_transparent_surfaces():
    frame = pipeline.prepare(RenderJob(scene()))
    b = program.ProgramBuilder()
    surface = b.add("bo2", b.const(0.5, 0.5, 0.5), b.const(0.0, 0.0, 0.0), b.const(0.0), None,
                    b.const(0.0, 0.0, 0.0), b.const(1.0), b.const(0.5))  # alpha 0.5
    s = scene()
    s.materials = [Material(), Material("glass", b.build(surface))]
    assert buffers.with_materials(frame, s) is None
    s.materials = [Material(), Material.talk("opaque")]
    assert buffers.with_materials(frame, s) is not None


def test_a_cancelled_update_still_applies_its_changes(monkeypatch):
    """A camera move cancelled by a material tweak: the tweak's render has the new camera."""
    started, release = threading.Event(), threading.Event()
    real = pipeline.render_tile
    calls = []

    def gate(frame, tile, offsets, tick, first_sample=0):
        calls.append(frame.scene.camera.width)
        if len(calls) > 1 and not started.is_set():  # the second update's first tile
            started.set()
            release.wait(10)
        return real(frame, tile, offsets, tick, first_sample)

    s = viewport.Session(samples=2)
    try:
        first = scene()
        first.settings.threads = 1
        s.update(first, viewport.CHANGES)
        assert s.wait(60)
        monkeypatch.setattr(pipeline, "render_tile", gate)
        calls.clear()
        calls.append(0)
        moved = dataclasses.replace(first, camera=dataclasses.replace(first.camera))
        moved.camera.world_to_camera = first.camera.world_to_camera.copy()
        moved.camera.world_to_camera[0, 3] = -1.0
        s.update(moved, {"camera"})
        assert started.wait(60)
        tweaked = dataclasses.replace(moved, materials=scene(albedo=0.3).materials)
        s.update(tweaked, {"materials"})  # names the material only
        release.set()
        assert s.wait(60)
        shifted = np.roll(expected(0.3, 2), -W // 4, axis=1)[:, : W - W // 4]
        np.testing.assert_allclose(s.image().pixels[::-1, : W - W // 4, 0], shifted, rtol=3e-3)
    finally:
        release.set()
        s.close()


def test_wait_returns_after_close():
    s = viewport.Session(samples=1)
    s.close()
    s.update(scene(), viewport.CHANGES)
    assert s.wait(5) and s.wait_for(lambda image: image.final, 5)
