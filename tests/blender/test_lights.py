"""A light's Temperature, Exposure and Normalize change its light as they change Cycles': the
ratio of a lit floor's brightness with each setting to without it, for every light type,
measured in both engines (Cycles is the reference; nothing here restates the formula)."""

import bpy
import numpy as np
import pytest
from util import add_ortho_camera, render_pixels, set_world_color

SHAPES = {
    "POINT": {"shadow_soft_size": 0.5},
    "POINT_NO_RADIUS": {"shadow_soft_size": 0.0},
    "SPOT": {"shadow_soft_size": 0.25, "spot_size": 2.0},
    "SUN": {"angle": 0.6},
    "AREA_RECTANGLE": {"shape": "RECTANGLE", "size": 2.0, "size_y": 0.75},
    "AREA_DISK": {"shape": "DISK", "size": 1.5},
}
SCALES = {"AREA_RECTANGLE": (1.5, 0.8, 1.0)}  # Cycles sizes an area light by its object too


def brightness(scene, engine: str) -> float:
    px = render_pixels(scene, engine, samples=64 if engine == "CYCLES" else 4)
    return float(px[6:10, 6:10, :3].mean())


@pytest.mark.parametrize("kind", list(SHAPES))
def test_temperature_exposure_and_normalize_as_cycles(addon, kind):
    scene = bpy.context.scene
    scene.render.resolution_x = scene.render.resolution_y = 16
    set_world_color(scene)
    bpy.ops.mesh.primitive_plane_add(size=20.0)
    add_ortho_camera(scene, 2.0, height=5.0)
    data = bpy.data.lights.new("Light", kind.split("_")[0])  # POINT_NO_RADIUS: a point
    for name, value in SHAPES[kind].items():
        setattr(data, name, value)
    data.energy = 2.0 if data.type == "SUN" else 100.0
    light = bpy.data.objects.new("Light", data)
    light.location = (0.0, 0.0, 3.0)
    light.scale = SCALES.get(kind, (1.0, 1.0, 1.0))
    scene.collection.objects.link(light)

    ratios = {}
    for engine in ("CYCLES", "BO2_LIGHTING"):
        base = brightness(scene, engine)
        data.normalize = False
        off = brightness(scene, engine)
        data.normalize, data.exposure = True, 1.5
        exposed = brightness(scene, engine)
        data.exposure, data.use_temperature, data.temperature = 0.0, True, 2500.0
        warm = brightness(scene, engine)
        data.use_temperature = False
        ratios[engine] = np.array([off, exposed, warm]) / base
    np.testing.assert_allclose(ratios["BO2_LIGHTING"], ratios["CYCLES"], rtol=0.03)
    assert abs(ratios["CYCLES"][0] - 1.0) > 0.1  # Normalize matters for these sizes
