"""Light groups: each group's pass is the light of its lights, its world and its meshes'
emission; together they make Combined.

Independent values: the same scene rendered with only the lights (and world, and emission) of
one group, whose Combined must equal that group's pass.
"""

import dataclasses

import numpy as np
from test_pipeline import floor, lambert_scene

from bo2_lighting.addon.core.render import pipeline
from bo2_lighting.addon.core.render.job import RenderJob
from bo2_lighting.addon.core.scene import Light, Material, RenderSettings

GROUPS = ("key", "fill", "env")


def scene_of(lights, world_color, glow=True, groups=GROUPS):
    """A floor and a card over it, the card emitting in group "key"; ``lights`` and a world
    of ``world_color`` in group "env" (seen at the frame's corners: the floor is 3 m)."""
    card = floor(size=1.0)
    card.positions = card.positions + np.float32([0.3, 0.0, 0.5])
    card.material = np.array([2, 2], np.int32)
    card.group = "key"
    scene = lambert_scene(lights[0] if lights else Light("SUN", color=np.zeros(3)))
    scene.lights = list(lights)
    scene.meshes = [floor(size=3.0), card]
    scene.materials.append(Material.talk(name="glow", albedo=np.full(3, 0.5, np.float32),
                                         emission=np.array([1.0, 0.5, 0.2], np.float32)
                                         if glow else np.zeros(3, np.float32)))
    scene.world.color = np.asarray(world_color, np.float32)
    scene.world.group = "env"
    scene.settings = RenderSettings(samples=4, light_groups=groups)
    return scene


KEY = Light("POINT", color=np.full(3, 60.0), position=np.array([0.5, 0.5, 2.0]), group="key")
FILL = Light("SUN", color=np.array([0.3, 0.4, 0.6]), direction=np.array([0.3, -0.2, -1.0]),
             group="fill")


def test_groups_add_up_to_combined_and_each_is_its_own_light():
    image = pipeline.render_frame(RenderJob(scene_of([KEY, FILL], (0.1, 0.2, 0.3))))
    total = sum(image[f"Combined_{g}"] for g in GROUPS)
    np.testing.assert_allclose(total, image["Combined"][..., :3], rtol=1e-5, atol=1e-6)
    alone = {
        "key": scene_of([KEY], (0.0, 0.0, 0.0)),
        "fill": scene_of([FILL], (0.0, 0.0, 0.0), glow=False),
        "env": scene_of([], (0.1, 0.2, 0.3), glow=False),
    }
    for g, scene in alone.items():
        expected = pipeline.render_frame(RenderJob(scene))["Combined"][..., :3]
        np.testing.assert_allclose(image[f"Combined_{g}"], expected, rtol=1e-5, atol=1e-6)
        assert image[f"Combined_{g}"].max() > 0.05, g


def test_lights_outside_the_groups_are_in_combined_alone():
    """A light whose group the view layer has not made, and no groups at all: Combined as
    without groups, the groups' passes without that light."""
    stray = dataclasses.replace(FILL, group="elsewhere")
    grouped = pipeline.render_frame(RenderJob(scene_of([KEY, stray], (0.1, 0.2, 0.3))))
    plain = pipeline.render_frame(RenderJob(scene_of([KEY, stray], (0.1, 0.2, 0.3),
                                                     groups=())))
    np.testing.assert_array_equal(grouped["Combined"], plain["Combined"])
    assert not any(name.startswith("Combined_") for name in plain)
    missing = plain["Combined"][..., :3] - sum(grouped[f"Combined_{g}"] for g in GROUPS)
    assert missing.min() > -1e-6 and missing.max() > 0.01  # the stray light's
