"""Contact occlusion (``core.formulas.occlusion``): the AO pass of a frame against the brute-force
integral of the cosine-weighted hemisphere, rays blocked within the occlusion distance."""

import numpy as np
import pytest
from test_sky import box, brute_force

from bo2_lighting.addon.core.bakes import bake
from bo2_lighting.addon.core.formulas import occlusion
from bo2_lighting.addon.core.render import pipeline
from bo2_lighting.addon.core.render.job import RenderJob
from bo2_lighting.addon.core.scene import (
    Camera,
    Material,
    MeshBatch,
    RenderSettings,
    Scene,
    World,
)

RADIUS = 0.5


def scene_of(slabs, camera, **settings) -> Scene:
    tris = np.concatenate([box(lo, hi) for lo, hi in slabs])
    n = np.cross(tris[:, 1] - tris[:, 0], tris[:, 2] - tris[:, 0])
    n /= np.linalg.norm(n, axis=-1, keepdims=True)
    mesh = MeshBatch(tris, np.repeat(n[:, None], 3, 1).astype(np.float32),
                     np.zeros(len(tris), np.int32))
    world = World(color=np.full(3, 1.0, np.float32))
    options = {"samples": 1, "sky_directions": 0, "ao_distance": RADIUS, **settings}
    return Scene(camera=camera, meshes=[mesh],
                 materials=[Material.talk(albedo=(0.5,) * 3, rf0=(0.0,) * 3, gloss=0.0)],
                 world=world, settings=RenderSettings(**options),
                 probes=bake.world_probes(world))


def at(passes, point) -> tuple[float, float]:
    """The AO pass and the diffuse indirect pass at the pixel whose position is nearest."""
    pos = passes["Position"].reshape(-1, 3)
    k = int(np.argmin(np.linalg.norm(pos - np.asarray(point), axis=1)))
    assert np.linalg.norm(pos[k] - point) < 0.02
    return float(passes["AO"].reshape(-1, 3)[k, 0]), passes["DiffInd"].reshape(-1, 3)[k]


WALL = [((-10.0, -10.0, -0.1), (10.0, 10.0, 0.0)), ((-0.2, -3.0, 0.0), (0.0, 3.0, 3.0))]


def test_ao_beside_a_wall_is_the_visible_fraction_of_the_hemisphere():
    cam = Camera.look_at((2.2, -0.4, 1.6), (0.3, 0.0, 0.0), np.radians(50), 320, 240)
    passes = pipeline.render_frame(RenderJob(scene_of(WALL, cam)))
    for d in (0.03, 0.1, 0.25, 0.45, 0.8):
        point = np.array([d, 0.0, 0.0])
        got, _ = at(passes, point)
        expected = brute_force(point, WALL[1:], radius=RADIUS)
        assert got == pytest.approx(expected, abs=0.05), d
    open_floor, _ = at(passes, np.array([1.2, 0.6, 0.0]))
    assert open_floor > 0.99


def test_it_darkens_the_indirect_light_and_switches_off():
    cam = Camera.look_at((2.2, -0.4, 1.6), (0.3, 0.0, 0.0), np.radians(50), 160, 120)
    on = pipeline.render_frame(RenderJob(scene_of(WALL, cam)))
    off = pipeline.render_frame(RenderJob(scene_of(WALL, cam, ambient_occlusion=False)))
    near = np.array([0.05, 0.0, 0.0])
    ao, lit = at(on, near)
    ao_off, lit_off = at(off, near)
    assert ao_off == 1.0 and ao < 0.8
    # albedo 0.5: the multi-bounce fit puts some light back, never more than was occluded
    expected = occlusion.multi_bounce(np.array([ao], np.float32), np.full((1, 3), 0.5))[0]
    np.testing.assert_allclose(lit / lit_off, expected, rtol=0.03)
    assert (expected >= ao).all() and (expected <= 1.0).all()


def test_specular_occlusion_follows_lagarde():
    ao = np.array([1.0, 0.5, 0.5, 0.2], np.float32)
    nv = np.array([0.7, 1.0, 0.2, 0.5], np.float32)
    gloss = np.array([0.5, 0.0, 1.0, 0.8], np.float32)
    got = occlusion.specular(ao, nv, gloss)
    assert got[0] == pytest.approx(1.0)
    # by hand: r = (2 / (8192^g + 2))^(1/4), so = (n.v + ao)^(2^(-16 r - 1)) - 1 + ao
    for k in range(1, 4):
        r = (2.0 / (8192.0 ** float(gloss[k]) + 2.0)) ** 0.25
        so = (float(nv[k]) + float(ao[k])) ** (2.0 ** (-16.0 * r - 1.0)) - 1.0 + float(ao[k])
        assert got[k] == pytest.approx(min(max(so, 0.0), 1.0), abs=1e-5)


def test_without_indirect_light_it_is_searched_for_its_pass_alone():
    """A black world and no probe: no indirect light to occlude, so contact occlusion is
    searched only when its pass is wanted (``ao_pass``); the image is the same either way,
    and with the pass it is the brute-force hemisphere's."""
    import dataclasses

    from bo2_lighting.addon.core.lighting import probes
    from bo2_lighting.addon.core.scene import Light

    cam = Camera.look_at((2.2, -0.4, 1.6), (0.3, 0.0, 0.0), np.radians(50), 160, 120)
    sun = Light("SUN", np.full(3, 2.0, np.float32), direction=np.array([-0.3, 0.2, -1.0]))
    dark = dataclasses.replace(scene_of(WALL, cam), lights=[sun])
    dark.world = World(color=np.zeros(3, np.float32))
    dark.probes = bake.world_probes(dark.world)
    assert not probes.sends_light(dark.probes)
    assert probes.sends_light(scene_of(WALL, cam).probes)
    wanted = pipeline.render_frame(RenderJob(dark))
    unwanted = pipeline.render_frame(RenderJob(dataclasses.replace(
        dark, settings=dataclasses.replace(dark.settings, ao_pass=False))))
    np.testing.assert_array_equal(unwanted["Combined"], wanted["Combined"])
    assert (unwanted["AO"] == 1.0).all()
    point = np.array([0.1, 0.0, 0.0])
    got, indirect = at(wanted, point)
    assert got == pytest.approx(brute_force(point, WALL[1:], radius=RADIUS), abs=0.05)
    assert (indirect == 0.0).all() and wanted["Combined"][..., :3].max() > 0.1
