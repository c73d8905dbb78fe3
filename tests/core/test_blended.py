"""Blended transparency (Blender's Render Method: Blended): the surfaces of a pixel composited
"over" one another, front to back.

Independent values: emitting planes stacked under an orthographic camera; the composite of
Porter and Duff's "over", C = a1 e1 + (1 - a1) (a2 e2 + (1 - a2) (... + e_behind)), written out
by hand for each case.
"""

import dataclasses

import numpy as np
import pytest
from test_pipeline import H, W, floor, ortho_camera

from bo2_lighting.addon.core.render import pipeline, transparency
from bo2_lighting.addon.core.render.job import RenderJob
from bo2_lighting.addon.core.scene import Material, RenderSettings, Scene
from bo2_lighting.addon.core.scene.program import ProgramBuilder

CENTRE = (H // 2, W // 2)
BACK = np.array([0.2, 0.3, 0.4])


def glow(color, alpha, **settings) -> Material:
    """Emission ``color`` mixed with a Transparent BSDF: coverage ``alpha``."""
    b = ProgramBuilder()
    shine = b.add("emission", b.const(*color), b.const(1.0))
    clear = b.add("transparent", b.const(1.0, 1.0, 1.0))
    return Material(f"glow {color} {alpha}", b.build(b.add("mix_shader", b.const(1.0 - alpha),
                                                           shine, clear)), **settings)


def plane(z, material, size=3.0, origin_z=None):
    mesh = floor(size)
    mesh.positions = mesh.positions + np.float32([0, 0, z])
    mesh.material = np.full(2, material, np.int32)
    if origin_z is not None:  # the object's origin, for EEVEE's order
        mesh.world_to_object = np.eye(4)
        mesh.world_to_object[2, 3] = -origin_z
    return mesh


def render(materials, meshes, samples=1, **settings):
    scene = Scene(camera=ortho_camera(), meshes=meshes, materials=materials, lights=[],
                  settings=RenderSettings(samples=samples, **settings))
    scene.world.color = np.zeros(3, np.float32)
    job = RenderJob(scene)
    return pipeline.render_frame(job)["Combined"], job.warnings


def over(layers, behind):
    """Front to back: [(alpha, colour)] over ``behind``."""
    out, through = np.zeros(3), 1.0
    for a, e in layers:
        out += through * a * np.asarray(e)
        through *= 1.0 - a
    return out + through * np.asarray(behind)


RED, GREEN = (1.0, 0.1, 0.0), (0.0, 0.8, 0.2)


def test_two_blended_planes_over_an_opaque_floor():
    mats = [glow(BACK, 1.0), glow(RED, 0.3, blended=True), glow(GREEN, 0.6, blended=True)]
    image, _ = render(mats, [plane(0, 0, 10), plane(2, 1), plane(1, 2)])
    expected = over([(0.3, RED), (0.6, GREEN)], BACK)
    np.testing.assert_allclose(image[CENTRE][:3], expected, rtol=1e-5)
    assert image[CENTRE][3] == pytest.approx(1.0)


def test_over_the_background_the_alpha_is_the_coverage():
    mats = [glow(BACK, 1.0), glow(RED, 0.3, blended=True), glow(GREEN, 0.6, blended=True)]
    image, _ = render(mats, [plane(2, 1), plane(1, 2)], film_transparent=True)
    np.testing.assert_allclose(image[CENTRE][:3], over([(0.3, RED), (0.6, GREEN)], 0.0),
                               rtol=1e-5)
    assert image[CENTRE][3] == pytest.approx(1.0 - 0.7 * 0.4, rel=1e-5)


def test_the_order_of_the_meshes_does_not_matter():
    mats = [glow(BACK, 1.0), glow(RED, 0.3, blended=True), glow(GREEN, 0.6, blended=True)]
    a, _ = render(mats, [plane(0, 0, 10), plane(2, 1), plane(1, 2)])
    b, _ = render(mats, [plane(1, 2), plane(0, 0, 10), plane(2, 1)])
    np.testing.assert_allclose(a, b, atol=1e-6)


def test_blending_needs_no_samples_where_dithering_needs_many():
    """One sample blends exactly; dithering the same materials converges to it."""
    blended = [glow(BACK, 1.0), glow(RED, 0.3, blended=True), glow(GREEN, 0.6, blended=True)]
    dithered = [glow(BACK, 1.0), glow(RED, 0.3), glow(GREEN, 0.6)]
    meshes = [plane(0, 0, 10), plane(2, 1), plane(1, 2)]
    exact, _ = render(blended, meshes)
    noisy, _ = render(dithered, meshes, samples=64)
    inner = (slice(5, H - 5), slice(5, W - 5))
    assert np.abs(exact[inner] - exact[CENTRE]).max() < 1e-5  # flat: no noise
    np.testing.assert_allclose(noisy[inner][..., :3].mean((0, 1)), exact[CENTRE][:3], atol=0.01)


def test_a_dithered_surface_inside_a_blended_stack():
    mats = [glow(BACK, 1.0), glow(RED, 0.3, blended=True), glow(GREEN, 0.5)]
    image, _ = render(mats, [plane(0, 0, 10), plane(2, 1), plane(1, 2)], samples=64)
    inner = (slice(5, H - 5), slice(5, W - 5))
    expected = over([(0.3, RED), (0.5, GREEN)], BACK)
    np.testing.assert_allclose(image[inner][..., :3].mean((0, 1)), expected, atol=0.01)


def test_transparency_overlap_off_shows_an_objects_nearest_layer():
    """EEVEE's Transparency Overlap off: of one object only the nearest surface shows."""
    for overlap in (True, False):
        mats = [glow(BACK, 1.0), glow(RED, 0.5, blended=True, transparency_overlap=overlap)]
        both = plane(2, 1)
        lower = plane(1, 1)
        both.positions = np.concatenate([both.positions, lower.positions])
        both.normals = np.concatenate([both.normals, lower.normals])
        both.material = np.ones(4, np.int32)
        image, _ = render(mats, [plane(0, 0, 10), both])
        layers = [(0.5, RED), (0.5, RED)] if overlap else [(0.5, RED)]
        np.testing.assert_allclose(image[CENTRE][:3], over(layers, BACK), rtol=1e-5)


def test_object_origin_order_is_eevees():
    """Sorted by object origin, the plane whose origin is nearer is composited in front, even
    where its surface lies behind; per pixel, the surfaces' order."""
    mats = [glow(BACK, 1.0), glow(RED, 0.3, blended=True), glow(GREEN, 0.6, blended=True)]
    meshes = [plane(0, 0, 10), plane(2, 1, origin_z=-20.0), plane(1, 2, origin_z=4.0)]
    exact, _ = render(mats, meshes)
    eevee, _ = render(mats, meshes, blend_sort="object")
    np.testing.assert_allclose(exact[CENTRE][:3], over([(0.3, RED), (0.6, GREEN)], BACK),
                               rtol=1e-5)
    np.testing.assert_allclose(eevee[CENTRE][:3], over([(0.6, GREEN), (0.3, RED)], BACK),
                               rtol=1e-5)


def test_a_stack_deeper_than_the_layers_kept_warns_once():
    n = transparency.BLEND_LAYERS + 2
    colors = [(k / n, 1.0 - k / n, 0.5) for k in range(n)]
    mats = [glow(BACK, 1.0)] + [glow(c, 0.5, blended=True) for c in colors]
    meshes = [plane(0, 0, 10)] + [plane(3.0 - k * 0.25, k + 1) for k in range(n)]
    image, warnings = render(mats, meshes)
    kept = transparency.BLEND_LAYERS
    expected = over([(0.5, c) for c in colors[:kept]], colors[kept])  # the next drawn opaque
    np.testing.assert_allclose(image[CENTRE][:3], expected, rtol=1e-5)
    text = [w for w in warnings.texts() if "blended" in w]
    assert len(text) == 1 and f"more than {kept}" in text[0]


def test_blended_passes_sum_to_combined():
    """The light passes of a blended stack are composited as Combined is."""
    mats = [glow(BACK, 1.0), glow(RED, 0.3, blended=True), glow(GREEN, 0.6, blended=True)]
    scene = Scene(camera=ortho_camera(), meshes=[plane(0, 0, 10), plane(2, 1), plane(1, 2)],
                  materials=mats, lights=[], settings=RenderSettings(samples=2))
    image = pipeline.render_frame(RenderJob(dataclasses.replace(scene)))
    np.testing.assert_allclose(image["Emit"][CENTRE], image["Combined"][CENTRE][:3], rtol=1e-5)


def test_a_holdout_behind_a_stack_cuts_its_hole():
    """Behind a blended card, a holdout object: the card over nothing (alpha a), as over a
    transparent film."""
    mats = [glow(BACK, 1.0), glow(RED, 0.3, blended=True)]
    hole = plane(1, 0, 4)
    hole.holdout = True
    image, _ = render(mats, [plane(0, 0, 10), hole, plane(2, 1)])
    np.testing.assert_allclose(image[CENTRE], [*over([(0.3, RED)], 0.0), 0.3], rtol=1e-5)


@pytest.mark.parametrize("kind", ["transparent", "see_through"])
def test_glass_casts_a_shadow_a_transparent_surface_does_not(kind):
    """A pane 96% see-through over a floor under a sun straight down: through a Transparent
    BSDF 96% of the light reaches the floor, through a transmission (Glass, as Cycles and
    EEVEE cast it without caustics) none; the camera sees through both alike."""
    from test_pipeline import lambert_scene

    from bo2_lighting.addon.core.scene import Light

    b = ProgramBuilder()
    pane = b.add(kind, b.const(0.96, 0.96, 0.96))
    mirror = b.add("glossy", b.const(0.04, 0.04, 0.04), b.const(0.0), None)
    glass = Material("pane", b.build(b.add("add_shader", mirror, pane)), blended=True)
    scene = lambert_scene(Light("SUN", color=np.ones(3), direction=np.array([0.0, 0.0, -1.0])))
    card = plane(1.0, 2, size=1.0)
    card.camera = False  # the floor under it is seen
    scene.meshes = [scene.meshes[0], card]
    scene.materials = [*scene.materials, glass]
    scene.settings = dataclasses.replace(scene.settings, samples=16)
    under = pipeline.render_frame(RenderJob(scene))["Combined"][CENTRE][0]
    lit = 0.6 / np.pi
    assert under == pytest.approx(0.96 * lit if kind == "transparent" else 0.0, abs=0.03)


def test_the_shadow_catcher_pass_is_1_through_a_stack_over_the_world():
    """Where no shadow catcher is, the Shadow Catcher pass is 1, blended stack or not."""
    mats = [glow(BACK, 1.0), glow(RED, 0.3, blended=True)]
    scene = Scene(camera=ortho_camera(), meshes=[plane(2, 1)], materials=mats, lights=[],
                  settings=RenderSettings(samples=2))
    image = pipeline.render_frame(RenderJob(scene))
    np.testing.assert_allclose(image["Shadow Catcher"], 1.0, rtol=1e-6)
