"""The implicit bounce (``core.bakes.bounce``) against the analytic bounce of a ground under a
uniform sky: a Lambert ground of albedo a lit by a sky of radiance L everywhere above it has
radiance a L, so a point over a wide ground facing down receives pi a L from it (the bounce,
times the share of its lower hemisphere the ground fills)."""

import math
import os

import numpy as np
from test_volume_leaks import cube as box

from bo2_lighting.addon.core.bakes import bake, bounce
from bo2_lighting.addon.core.formulas import sh
from bo2_lighting.addon.core.lighting import probes
from bo2_lighting.addon.core.scene import (
    Camera,
    Material,
    MeshBatch,
    RenderSettings,
    Scene,
    World,
)


def ground_scene(albedo=0.5, half=20.0, directions=32):
    tris = np.concatenate([box((-half, -half, -0.1), (half, half, 0.0)),
                           box((-0.5, -0.5, 0.0), (0.5, 0.5, 1.0))])
    n = np.cross(tris[:, 1] - tris[:, 0], tris[:, 2] - tris[:, 0])
    n /= np.linalg.norm(n, axis=-1, keepdims=True)
    mesh = MeshBatch(tris, np.repeat(n[:, None], 3, 1).astype(np.float32),
                     np.zeros(len(tris), np.int32))
    world = World(color=np.full(3, 1.0, np.float32))
    return Scene(camera=Camera.look_at((0, -5, 1), (0, 0, 1), 1.0, 8, 8, 0.1, 100.0),
                 meshes=[mesh], materials=[Material.talk(albedo=(albedo,) * 3,
                                                         rf0=(0.0, 0.0, 0.0))],
                 world=world, probes=bake.world_probes(world),
                 settings=RenderSettings(samples=1, sky_directions=directions))


def irradiance_of(probes_, point, normal):
    p = np.asarray([point], np.float32)
    n = np.asarray([normal], np.float32)
    coeffs = probes._pixel_sh(probes_, p, n, -n)
    return sh.irradiance(np.asarray(coeffs).reshape(-1, 9, 3)[0], n)[0]


def test_a_wide_ground_bounces_pi_a_l_upwards():
    scene = bounce.attach(ground_scene())
    vol = scene.probes.bounce
    assert vol is not None and np.prod(vol.resolution) <= bounce.MAX_SAMPLES
    point = (1.2, -1.0, 0.4)  # beside the box, over the ground
    down = irradiance_of(scene.probes, point, (0.0, 0.0, -1.0))
    world_only = irradiance_of(bake.world_probes(scene.world).__class__(
        scene.probes.world_sh, scene.probes.world_mips), point, (0.0, 0.0, -1.0))
    # the world's colour world alone gives the lower hemisphere pi L (a uniform sphere);
    # the bounce adds the ground's a L over the hemisphere the ground fills: pi a L
    np.testing.assert_allclose(down - world_only, math.pi * 0.5, rtol=0.15)
    up = irradiance_of(scene.probes, point, (0.0, 0.0, 1.0))
    assert (up - irradiance_of(bake.world_probes(scene.world), point, (0, 0, 1)) < 0.25).all()


def test_it_is_kept_per_content_and_left_out_with_volumes():
    scene = ground_scene()
    first = bounce.attach(scene).probes.bounce
    assert bounce.attach(scene).probes.bounce is first  # the same content: no bake
    darker = ground_scene(albedo=0.2)
    assert bounce.key(darker) != bounce.key(scene)
    assert bounce.attach(darker, bake_missing=False).probes.bounce is None
    off = ground_scene()
    off.settings.implicit_bounce = False
    assert bounce.attach(off).probes.bounce is None


def test_the_next_session_reuses_the_bake_from_disk(tmp_path, monkeypatch):
    """A baked volume is kept on disk under its content and the engine's code: a new session
    (the memory cache emptied) loads it bit for bit instead of baking; a damaged file is baked
    anew and replaced; only the last ``KEPT_ON_DISK`` files stay."""
    monkeypatch.setattr(bounce.kernels, "user_cache", lambda name: tmp_path / name)
    scene = ground_scene(albedo=0.4)
    baked = bounce.attach(scene).probes.bounce
    files = list((tmp_path / "bounce").glob("*.npz"))
    assert len(files) == 1 and files[0].name.startswith(bounce.key(scene))
    bounce._volumes.clear()

    def no_bake(*args):
        raise AssertionError("baked again")

    with monkeypatch.context() as m:
        m.setattr(bounce, "_bake", no_bake)
        loaded = bounce.attach(scene).probes.bounce
    for name in ("local_to_world", "sh", "validity"):
        assert np.array_equal(getattr(loaded, name), getattr(baked, name)), name
    assert (loaded.resolution, loaded.influence, loaded.facing_bias, loaded.falloff) == (
        baked.resolution, baked.influence, baked.facing_bias, baked.falloff)
    whole = files[0].read_bytes()
    for damaged in (b"not a volume", whole[:len(whole) // 2], whole[:-40]):
        bounce._volumes.clear()
        files[0].write_bytes(damaged)  # (a cut zip: its directory, or a member's end gone)
        again = bounce.attach(scene).probes.bounce
        assert np.array_equal(again.sh, baked.sh) and files[0].read_bytes() == whole
    os.utime(files[0], (1e9, 1e9))  # the older of two, whatever the clock
    monkeypatch.setattr(bounce, "KEPT_ON_DISK", 1)
    bounce.attach(ground_scene(albedo=0.3))
    assert [p.name.split("-")[0] for p in (tmp_path / "bounce").glob("*.npz")] == [
        bounce.key(ground_scene(albedo=0.3))]
