"""Light and shadow linking in frames, probe-style views and lightmap bakes.

Independent values: Blender's manual states the include/exclude rule; a Lambert floor under a
sun straight down has radiance albedo S / pi where lit and 0 in a hard shadow; a linked light's
image equals the image of the same scene without that light where the light is not linked,
and with it where it is.
"""

import numpy as np
import pytest
from test_pipeline import H, W, floor, lambert_scene

from bo2_lighting.addon.core.bakes import lightmap_bake
from bo2_lighting.addon.core.lighting import lightmap
from bo2_lighting.addon.core.render import pipeline, shadow_maps
from bo2_lighting.addon.core.render.job import RenderJob
from bo2_lighting.addon.core.scene import Light, Material, linking

ALBEDO = 0.6  # lambert_scene's


def test_membership_follows_blenders_rule():
    """Blender's manual: only included objects, those alone; only excluded, every object but
    those; both, the included less the excluded; no entries, every object."""
    assert linking.member("a", {"a"}, set()) and not linking.member("b", {"a"}, set())
    assert not linking.member("a", set(), {"a"}) and linking.member("b", set(), {"a"})
    assert linking.member("a", {"a", "b"}, {"b"}) and not linking.member("b", {"a", "b"}, {"b"})
    assert not linking.member("c", {"a", "b"}, {"b"})
    assert linking.member("a", set(), set())
    bits = linking.mask("a", [({"a"}, set()), ({"b"}, set()), (set(), {"a"})])
    assert bits & 0b1111 == 0b0011  # set 0 always, set 1 (a), not 2 (b) nor 3 (a excluded)
    assert bits >> 4 == linking.EVERY >> 4  # sets no collection holds: unused, every bit
    with pytest.raises(ValueError):
        Light("POINT", color=np.ones(3), receivers=linking.SETS)


def _card(z, x=0.0, size=1.0, name="card"):
    card = floor(size=size)
    card.positions = card.positions + np.float32([x, 0, z])
    card.name = name
    return card


def _scene(lights, meshes):
    scene = lambert_scene(lights[0])
    scene.lights = list(lights)
    scene.meshes = list(meshes)
    return scene


def _render(scene):
    return pipeline.render_frame(RenderJob(scene))["Combined"][..., :3]


def test_a_linked_light_lights_its_receivers_alone():
    """Two cards side by side on the floor's level lit by a point light and a sun; the point
    light linked to the left card: the left card as with the light, the right one and the
    floor as without it; the sun, unlinked, lights all three."""
    left, right = _card(0.5, -1.0, name="left"), _card(0.5, 1.0, name="right")
    left.light_sets = linking.mask("left", [({"left"}, set())])
    right.light_sets = linking.mask("right", [({"left"}, set())])
    ground = floor()
    ground.light_sets = linking.mask("floor", [({"left"}, set())])
    sun = Light("SUN", color=np.full(3, 0.5), direction=np.array([0.0, 0.0, -1.0]),
                shadow=False)
    point = Light("POINT", color=np.full(3, 60.0), position=np.array([0.0, 0.0, 2.0]),
                  shadow=False)
    linked = Light("POINT", color=np.full(3, 60.0), position=np.array([0.0, 0.0, 2.0]),
                   shadow=False, receivers=1)
    with_light = _render(_scene([sun, point], [ground, left, right]))
    without = _render(_scene([sun], [ground, left, right]))
    image = _render(_scene([sun, linked], [ground, left, right]))
    x = (np.arange(W) + 0.5) / W * 4.0 - 2.0
    on_left = np.abs(x + 1.0) < 0.45
    rows = slice(H // 2 - 5, H // 2 + 5)
    np.testing.assert_allclose(image[rows][:, on_left], with_light[rows][:, on_left],
                               rtol=1e-5)
    rest = ~on_left & (np.abs(x + 1.0) > 0.55)
    np.testing.assert_allclose(image[rows][:, rest], without[rows][:, rest], rtol=1e-5)
    assert (with_light[rows][:, rest] > 1.2 * without[rows][:, rest]).all()  # it lit them
    assert np.allclose(without[rows][:, rest], ALBEDO * 0.5 / np.pi, rtol=2e-3)


def test_a_shadow_linked_light_is_shadowed_by_its_blockers_alone():
    """Two cards above the floor under a sun straight down; the sun's blockers the left card
    alone: the floor under the left card is dark, under the right one fully lit (albedo S /
    pi); another sun without a blocker set is shadowed by both."""
    left, right = _card(1.0, -1.0, name="left"), _card(1.0, 1.0, name="right")
    collections = [({"left"}, set())]
    for m in (left, right):
        m.shadow_sets = linking.mask(m.name, collections)
        m.camera = False  # the floor is seen through them
    ground = floor()
    ground.shadow_sets = linking.mask("floor", collections)
    down = np.array([0.0, 0.0, -1.0])
    linked = Light("SUN", color=np.ones(3), direction=down, blockers=1)
    scene = _scene([linked], [ground, left, right])
    x = (np.arange(W) + 0.5) / W * 4.0 - 2.0
    rows = slice(H // 2 - 4, H // 2 + 4)
    image = _render(scene)[rows]
    under_left, under_right = np.abs(x + 1.0) < 0.35, np.abs(x - 1.0) < 0.35
    assert np.abs(image[:, under_left]).max() < 1e-3
    np.testing.assert_allclose(image[:, under_right], ALBEDO / np.pi, rtol=2e-3)
    plain = _render(_scene([Light("SUN", color=np.ones(3), direction=down)],
                           [ground, left, right]))[rows]
    assert np.abs(plain[:, under_left | under_right]).max() < 1e-3
    # the map of the linked light holds the left card alone
    frame = pipeline.prepare(RenderJob(scene), shadow_maps=[None])
    assert len(shadow_maps.casters(frame, 1)[0]) == 2
    assert len(shadow_maps.casters(frame, 0)[0]) == 6


def test_a_light_linked_to_nothing_but_the_rest_lights_every_other_mesh():
    """An excluded collection only: the light lights every mesh but the excluded one."""
    left, right = _card(0.5, -1.0, name="left"), _card(0.5, 1.0, name="right")
    collections = [(set(), {"left"})]
    ground = floor()
    for m in (ground, left, right):
        m.light_sets = linking.mask(m.name, collections)
    sun = Light("SUN", color=np.ones(3), direction=np.array([0.0, 0.0, -1.0]), shadow=False,
                receivers=1)
    image = _render(_scene([sun], [ground, left, right]))
    x = (np.arange(W) + 0.5) / W * 4.0 - 2.0
    row = image[H // 2]
    assert np.abs(row[np.abs(x + 1.0) < 0.45]).max() < 1e-6
    np.testing.assert_allclose(row[np.abs(x - 1.0) < 0.45], ALBEDO / np.pi, rtol=2e-3)


def _facing_walls(receivers_of_light):
    """The lightmaps of two walls 1 m apart facing each other (x = -0.5 facing +X, x = 0.5
    facing -X), lit by a point light between them, unshadowed, linked to the walls named in
    ``receivers_of_light`` (None: unlinked)."""
    def wall(x, facing, name):
        s = 0.5
        quad = np.array([[x, -s, 0], [x, s, 0], [x, s, 1], [x, -s, 1]], np.float32)
        tris = quad[[[0, 1, 2], [0, 2, 3]]] if facing > 0 else quad[[[0, 2, 1], [0, 3, 2]]]
        nrm = np.broadcast_to(np.float32([facing, 0, 0]), tris.shape).copy()
        uv = np.array([[0, 0], [1, 0], [1, 1], [0, 1]], np.float32)
        uvs = uv[[[0, 1, 2], [0, 2, 3]]] if facing > 0 else uv[[[0, 2, 1], [0, 3, 2]]]
        m = _card(0.0, name=name)
        m.positions, m.normals, m.uvs = tris, nrm, uvs
        m.material = np.array([1, 1], np.int32)
        return m

    a, b = wall(-0.5, 1.0, "a"), wall(0.5, -1.0, "b")
    collections = [] if receivers_of_light is None else [(set(receivers_of_light), set())]
    for m in (a, b):
        m.light_sets = linking.mask(m.name, collections)
    # a point light between them lights both faces
    light = Light("POINT", color=np.full(3, 20.0), position=np.array([0.0, 0.0, 0.5]),
                  shadow=False, receivers=0 if receivers_of_light is None else 1)
    scene = _scene([light], [a, b])
    scene.world.color = np.zeros(3, np.float32)
    scene.materials[1] = Material.talk(name="white", albedo=np.full(3, 0.8, np.float32),
                                       rf0=np.zeros(3, np.float32), gloss=0.0)
    targets = [lightmap.Target(m.name, k, m.uvs, 8, 8) for k, m in enumerate(scene.meshes)]
    return lightmap_bake.bake(RenderJob(scene), targets,
                              lightmap.Settings(rays=64, bounces=1, denoise=False))


def test_a_lightmap_bake_bounces_the_light_of_linked_receivers_alone():
    """Each wall's lightmap holds the light the other reflects: unlinked, both get it; the
    light linked to wall a alone, b still gets a's bounce and a gets none from the dark b."""
    both = [np.asarray(m.image)[..., :3].mean() for m in _facing_walls(None)]
    only_a = [np.asarray(m.image)[..., :3].mean() for m in _facing_walls({"a"})]
    assert min(both) > 0.0
    assert only_a[1] == pytest.approx(both[1], rel=0.05)  # b gets a's bounce as before
    assert only_a[0] < 0.02 * both[0]  # b, unlit, sends a nothing
