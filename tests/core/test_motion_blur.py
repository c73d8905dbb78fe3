"""Motion blur: each sample sees the scene at its own time of the shutter.

Independent values: a card of width w that moves a distance d along x while the shutter is
open covers a point x for the share of the shutter its span [c(t) - w/2, c(t) + w/2] holds x,
c(t) = c0 + d t: the overlap of two intervals, written out below; a still card seen by a
camera that moves by -d is the same streak, and the card's shadow under a sun takes the
sun from a point of the floor for that same share of the shutter. The shutter curve's times
are checked against the curve's integral; normals carried over the shutter against a rotation
applied to them.
"""

import dataclasses

import numpy as np
import pytest
from test_pipeline import HALF_W, W, floor, lambert_scene, pixel_centres

from bo2_lighting.addon.core.render import motion_blur, pipeline
from bo2_lighting.addon.core.render.job import RenderJob
from bo2_lighting.addon.core.scene import Light

SUN = Light("SUN", color=np.ones(3), direction=np.array([0.0, 0.0, -1.0]))
CARD, TRAVEL = 0.6, 1.6  # the card's width and the distance it moves, metres


def coverage(x, width=CARD, travel=TRAVEL, start=-0.8):
    """Share of the shutter during which a card centred at start + travel t (t in [0, 1])
    covers x."""
    lo = np.clip((x - width / 2 - start) / travel, 0.0, 1.0)
    hi = np.clip((x + width / 2 - start) / travel, 0.0, 1.0)
    return hi - lo


def card_scene(samples=64):
    scene = lambert_scene(SUN)
    card = floor(size=CARD)
    card.positions = card.positions + np.float32([0.0, 0.0, 0.5])
    scene.meshes = [card]
    scene.world.color = np.zeros(3, np.float32)
    scene.settings = dataclasses.replace(scene.settings, samples=samples, film_transparent=True)
    return scene, card


def row_alpha(scene):
    image = pipeline.render_frame(RenderJob(scene))["Combined"]
    x = pixel_centres()[0, :, 0]
    return x, image[image.shape[0] // 2, :, 3]


def test_a_moving_card_streaks_by_its_travel():
    scene, card = card_scene()
    steps = np.stack([card.positions + np.float32([dx, 0.0, 0.0])
                      for dx in (-TRAVEL / 2, 0.0, TRAVEL / 2)])
    card.motion = steps
    x, alpha = row_alpha(scene)
    expected = coverage(x)
    print(np.round(alpha, 2), np.round(expected, 2))
    # 64 samples: the streak in steps of 1/64; the pixel filter smooths its corners
    assert np.abs(alpha - expected).max() < 0.1
    assert np.abs(alpha - expected).mean() < 0.02
    still, _ = card_scene()
    _, sharp = row_alpha(still)
    assert (sharp > 0.5).sum() < (alpha > 0.05).sum() - 0.8 * TRAVEL / (2 * HALF_W) * W


def test_a_moving_camera_streaks_a_still_card():
    scene, _ = card_scene()
    cam = scene.camera
    steps = []
    for dx in (TRAVEL / 2, 0.0, -TRAVEL / 2):  # the camera moves the other way
        view = np.array(cam.world_to_camera, np.float64)
        view[0, 3] -= dx
        steps.append(view)
    scene.camera = dataclasses.replace(cam, motion=np.stack(steps))
    x, alpha = row_alpha(scene)
    assert np.abs(alpha - coverage(x)).mean() < 0.02


def test_without_motion_nothing_changes():
    scene, card = card_scene(samples=8)
    _, plain = row_alpha(scene)
    card.motion = np.stack([card.positions] * 3)  # steps that stand still
    _, held = row_alpha(scene)
    np.testing.assert_allclose(held, plain, atol=1e-6)


@pytest.mark.parametrize("curve", [(1.0, 1.0), (0.0, 1.0), (0.0, 1.0, 1.0, 0.0)])
def test_shutter_times_follow_the_curve(curve):
    """The times' distribution is the curve's normalized integral (piecewise linear)."""
    t = motion_blur.shutter_times(np.arange(4096), curve)
    x = np.linspace(0.0, 1.0, 201)
    knots = np.linspace(0.0, 1.0, len(curve))
    fine = np.linspace(0.0, 1.0, 20001)
    density = np.interp(fine, knots, curve)
    cdf = np.concatenate([[0.0], np.cumsum((density[1:] + density[:-1]) / 2)])
    cdf /= cdf[-1]
    empirical = (t[None, :] <= x[:, None]).mean(1)
    np.testing.assert_allclose(empirical, np.interp(x, fine, cdf), atol=0.01)


def test_with_depth_of_field_the_focus_plane_streaks_as_through_a_pinhole():
    """A moving card in the focus plane: the lens changes nothing of its streak."""
    from test_depth_of_field import edge_scene

    from bo2_lighting.addon.core.scene import Aperture

    rows = []
    for aperture in (None, Aperture(radius=0.3, focus=2.0)):
        scene = edge_scene(2.0, aperture, samples=32)
        card = scene.meshes[0]
        card.motion = np.stack([card.positions + np.float32([dx, 0.0, 0.0])
                                for dx in (-0.2, 0.0, 0.2)])
        image = pipeline.render_frame(RenderJob(scene))["Combined"]
        rows.append(image[image.shape[0] // 2, :, 0])
    np.testing.assert_allclose(rows[1], rows[0], atol=1e-4)
    assert ((rows[0] > 0.02) & (rows[0] < 0.98)).sum() > 5  # a streak, not an edge


def test_a_moving_cards_shadow_streaks_and_never_falls_on_the_card():
    """A card 0.5 m above the floor under a sun tilted towards +y: along a row that sees the
    floor in its shadow alone, the share of the sun taken is the card's coverage of its travel
    (within 1/16 plus the filter: the shutter is shaded in ``SHUTTER_TIMES`` shares); along
    the card's row, card and floor as lit as a still card and the floor (the card's shadow
    maps are those of its own time: no shadow from another time falls on it)."""
    d = np.array([0.0, 0.6, -0.8])
    sun = Light("SUN", color=np.ones(3), direction=d)
    scene = lambert_scene(sun)
    card = floor(size=CARD)
    card.positions = card.positions + np.float32([0.0, 0.0, 0.5])
    scene.meshes = [floor(), card]
    scene.settings = dataclasses.replace(scene.settings, samples=64)
    lit = 0.6 / np.pi * 0.8  # a lambert floor under a unit sun at cos 0.8
    still = pipeline.render_frame(RenderJob(scene))["Combined"]
    card.motion = np.stack([card.positions + np.float32([dx, 0.0, 0.0])
                            for dx in (-TRAVEL / 2, 0.0, TRAVEL / 2)])
    image = pipeline.render_frame(RenderJob(scene))["Combined"]
    centres = pixel_centres()
    x, y = centres[0, :, 0], centres[:, 0, 1]
    row = int(np.argmin(np.abs(y - 0.5)))  # the shadow spans y in [0.075, 0.675]
    taken = 1.0 - image[row, :, 0] / lit
    expected = coverage(x)
    print(np.round(taken, 2), np.round(expected, 2))
    assert np.abs(taken - expected).max() < 0.2
    assert np.abs(taken - expected).mean() < 0.03
    card_row = int(np.argmin(np.abs(y + 0.15)))  # (away from the shadow's filtered edge)
    assert (image[card_row, :, 3] == 1.0).all()
    np.testing.assert_allclose(image[card_row, :, 0], lit, rtol=0.01)
    np.testing.assert_allclose(still[card_row, :, 0], lit, rtol=0.01)


def test_normals_turn_with_their_triangles():
    """Corner normals carried to each step by the triangle's motion: those a rotation and
    a uniform scale give them (computed by applying the rotation), unit length."""
    rng = np.random.default_rng(3)
    corners = rng.normal(size=(20, 3, 3))
    normals = rng.normal(size=(20, 3, 3))
    normals /= np.linalg.norm(normals, axis=-1, keepdims=True)
    a = 1.1
    turn = np.array([[1.0, 0.0, 0.0], [0.0, np.cos(a), -np.sin(a)], [0.0, np.sin(a), np.cos(a)]])
    steps = np.stack([corners, 2.5 * corners @ turn.T + np.array([1.0, -2.0, 0.5])])
    moved = motion_blur.moved_normals(corners, normals, steps)
    np.testing.assert_allclose(moved[0], normals, atol=1e-6)
    np.testing.assert_allclose(moved[1], normals @ turn.T, atol=1e-5)


def tall_card_scene(duration):
    """The card 3.2 m tall (past the frame's top and bottom), moving TRAVEL along x, seen
    through a rolling shutter of ``duration``."""
    scene, card = card_scene()
    card.positions = card.positions * np.float32([1.0, 3.2 / CARD, 1.0])
    card.motion = np.stack([card.positions + np.float32([dx, 0.0, 0.0])
                            for dx in (-TRAVEL / 2, 0.0, TRAVEL / 2)])
    scene.settings = dataclasses.replace(scene.settings, rolling_shutter=duration)
    return scene


@pytest.mark.parametrize("duration", [0.0, 0.25, 1.0])
def test_a_rolling_shutter_slants_the_streak_row_by_row(duration):
    """Row r (top first) is read at the time (r + 1) / H blended with the sample's time by
    the duration (Cycles' rolling shutter): the card covers x for the share of that row's
    window [t_r - d/2, t_r + d/2] in which its span holds x. Duration 1 is the global
    shutter."""
    scene = tall_card_scene(duration)
    alpha = pipeline.render_frame(RenderJob(scene))["Combined"][..., 3]
    x = pixel_centres()[0, :, 0]
    expected = np.empty_like(alpha)
    for r in range(alpha.shape[0]):
        t_row = ((r + 1) / alpha.shape[0] - 0.5) * (1.0 - duration) + 0.5
        opens = t_row - duration / 2
        if duration > 0.0:
            expected[r] = coverage(x, travel=TRAVEL * duration, start=-0.8 + TRAVEL * opens)
        else:
            centre = -0.8 + TRAVEL * t_row
            expected[r] = np.clip((CARD / 2 - np.abs(x - centre)) / (2 * HALF_W / W) + 0.5,
                                  0.0, 1.0)  # the edge across its pixel
    error = np.abs(alpha - expected)
    print(duration, error.max(), error.mean())
    assert error.max() < 0.2 if duration == 0.0 else error.max() < 0.1
    assert error.mean() < 0.02
    if duration == 1.0:
        steps = tall_card_scene(None)
        plain = pipeline.render_frame(RenderJob(steps))["Combined"][..., 3]
        assert np.allclose(alpha, plain, atol=1e-6)


def test_a_rolling_shutter_without_motion_changes_nothing():
    scene = tall_card_scene(0.1)
    scene.meshes[0].motion = None
    rolled = pipeline.render_frame(RenderJob(scene))["Combined"]
    scene.settings = dataclasses.replace(scene.settings, rolling_shutter=None)
    assert np.array_equal(rolled, pipeline.render_frame(RenderJob(scene))["Combined"])


def test_a_rolling_shutters_bands_keep_a_rows_time_within_a_quarter_pixel():
    for reach, height, duration in ((17, 30, 0.25), (3, 1080, 0.1), (400, 2160, 0.0)):
        rows = motion_blur.band_rows(reach, height, duration)
        assert rows >= 1
        drift = 2 * reach * (rows - 1) / 2 * (1.0 - duration) / height  # middle row to an end
        assert drift <= 0.25 or rows == 1
