"""Shadow catchers, as Cycles renders them: the catcher shows the world behind it times the
share of light its shadows let through (or, with a transparent film, black of the shadows'
opacity), and the Shadow Catcher pass is that share.

Independent values: a sun straight down and a card over the floor cast a hard shadow: the
share is 0 under the card and 1 beside it.
"""

import dataclasses

import numpy as np
import pytest
from test_pipeline import H, W, floor, lambert_scene

from bo2_lighting.addon.core.render import pipeline
from bo2_lighting.addon.core.render.job import RenderJob
from bo2_lighting.addon.core.scene import Light

SUN = Light("SUN", color=np.ones(3), direction=np.array([0.0, 0.0, -1.0]))


def scene_of(transparent):
    card = floor(size=1.0)
    card.positions = card.positions + np.float32([0, 0, 1])
    card.camera = False  # the floor is seen under it
    ground = floor(size=3.0)  # 3 m of the frame's 4: the world beside it
    ground.shadow_catcher = True
    scene = lambert_scene(SUN)
    scene.meshes = [ground, card]
    scene.world.color = np.array([0.2, 0.3, 0.4], np.float32)
    scene.settings = dataclasses.replace(scene.settings, samples=4,
                                         film_transparent=transparent)
    return scene


@pytest.mark.parametrize("transparent", [False, True])
def test_the_catcher_shows_its_shadow_alone(transparent):
    image = pipeline.render_frame(RenderJob(scene_of(transparent)))
    combined, share = image["Combined"], image["Shadow Catcher"]
    under, beside, world = (H // 2, W // 2), (H // 2, W // 2 + 9), (H // 2, 1)
    assert share[under] == pytest.approx([0, 0, 0], abs=1e-6)
    assert share[beside] == pytest.approx([1, 1, 1], abs=1e-6)
    assert share[world] == pytest.approx([1, 1, 1], abs=1e-6)  # no catcher there: 1
    if transparent:
        assert combined[under] == pytest.approx([0, 0, 0, 1], abs=1e-6)
        assert combined[beside] == pytest.approx([0, 0, 0, 0], abs=1e-6)
        assert combined[world][3] == 0.0
    else:  # the world behind the catcher, times the share
        assert combined[under] == pytest.approx([0, 0, 0, 1], abs=1e-6)
        assert combined[beside] == pytest.approx([0.2, 0.3, 0.4, 1], abs=1e-6)
        assert combined[world] == pytest.approx([0.2, 0.3, 0.4, 1], abs=1e-6)


def test_a_catcher_lit_by_no_light_catches_nothing():
    """Where no light reaches the catcher the share is 1: nothing is darkened."""
    scene = scene_of(False)
    scene.lights = []
    image = pipeline.render_frame(RenderJob(scene))
    np.testing.assert_allclose(image["Shadow Catcher"], 1.0)
    np.testing.assert_allclose(image["Combined"][H // 2, W // 2], [0.2, 0.3, 0.4, 1], atol=1e-6)


def test_with_the_pass_the_catcher_leaves_combined():
    """With the Shadow Catcher pass wanted the catcher is left out of Combined (alpha 0), its
    shadow in the pass alone, as Cycles does; the card over it is still drawn."""
    scene = scene_of(True)
    scene.settings = dataclasses.replace(scene.settings, shadow_catcher_pass=True)
    image = pipeline.render_frame(RenderJob(scene))
    assert image["Combined"][H // 2, W // 2] == pytest.approx([0, 0, 0, 0], abs=1e-6)
    assert image["Shadow Catcher"][H // 2, W // 2] == pytest.approx([0, 0, 0], abs=1e-6)
