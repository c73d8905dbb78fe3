"""Shader AOVs: what a material's AOV Output nodes give, averaged over the samples as Cycles
averages them (0 where no surface writes it; a colour's alpha is the coverage).

Independent values: constant AOVs on a floor that covers the frame's middle; the expected
passes are those constants inside, 0 outside, and half of them on pixels the edge halves.
"""

import dataclasses

import numpy as np
from test_pipeline import floor, lambert_scene, pixel_centres

from bo2_lighting.addon.core.render import pipeline
from bo2_lighting.addon.core.render.job import RenderJob
from bo2_lighting.addon.core.scene import Light, Material
from bo2_lighting.addon.core.scene.program import ProgramBuilder

SUN = Light("SUN", color=np.ones(3), direction=np.array([0.0, 0.0, -1.0]))


def writer() -> Material:
    b = ProgramBuilder()
    surface = b.add("diffuse", b.const(0.5, 0.5, 0.5), None)
    aovs = (("tint", b.const(0.2, 0.4, 0.8), b.const(0.0)),
            ("mask", b.const(0.0, 0.0, 0.0), b.const(0.25)))
    return Material("writer", b.build(surface, aovs=aovs))


def test_aovs_are_the_nodes_values_where_the_material_is_seen():
    scene = lambert_scene(SUN)
    scene.materials[1] = writer()
    scene.meshes = [floor(size=1.9)]  # edges through pixel centres
    scene.settings = dataclasses.replace(scene.settings, samples=16,
                                         aovs=(("tint", "COLOR"), ("mask", "VALUE"),
                                               ("absent", "VALUE")))
    image = pipeline.render_frame(RenderJob(scene))
    centres = np.abs(pixel_centres()[..., :2]).max(-1)
    inside, outside = centres < 0.9, centres > 1.1
    np.testing.assert_allclose(image["tint"][inside], [[0.2, 0.4, 0.8, 1.0]] * inside.sum(),
                               rtol=1e-6)
    np.testing.assert_allclose(image["mask"][inside], 0.25, rtol=1e-6)
    assert not image["tint"][outside].any() and not image["mask"][outside].any()
    assert not image["absent"].any()
    edge = (np.abs(np.abs(pixel_centres()[..., 0]) - 0.95) < 1e-6) & (
        np.abs(pixel_centres()[..., 1]) < 0.8)
    coverage = image["tint"][edge, 3]
    np.testing.assert_allclose(image["mask"][edge, 0], 0.25 * coverage, rtol=1e-5)
    assert np.abs(coverage - 0.5).max() < 0.25
    # the AOVs are passes beside the others: Combined is unchanged by them
    plain = dataclasses.replace(scene, settings=dataclasses.replace(scene.settings, aovs=()))
    np.testing.assert_array_equal(pipeline.render_frame(RenderJob(plain))["Combined"],
                                  image["Combined"])
