"""The bake's rules without Blender: capture points, bounces, SH of the captures, metadata.

Independent values:
- capture points: the volume sample positions (i + 0.5) / res * 2 - 1 of the local cube, written
  out by hand for a translated and scaled box;
- SH of a constant radiance L: c00 = 2 sqrt(pi) L, the other coefficients 0 (docs/sh.md);
- bounces in a closed box of albedo rho lit by emission E (every surface sees the same light):
  after n bounces the radiance is E (1 + rho + ... + rho^(n-1)), the partial sums of the
  geometric series whose limit is E / (1 - rho).
"""

import math

import numpy as np
import pytest

from bo2_lighting.addon.core.bakes import bake
from bo2_lighting.addon.core.formulas.texture import make_texture
from bo2_lighting.addon.core.lighting.world_probes import world_key, world_probes
from bo2_lighting.addon.core.scene import World

C00 = 2.0 * math.sqrt(math.pi)


def box(scale=(2.0, 1.0, 0.5), offset=(1.0, -2.0, 3.0)) -> np.ndarray:
    m = np.diag([*scale, 1.0])
    m[:3, 3] = offset
    return m


def volume(resolution=(2, 1, 1)) -> bake.ProbeSpec:
    return bake.ProbeSpec("Volume", "irradiance", box(), influence=0.5, resolution=resolution,
                          clip_start=0.0001, clip_end=0.0001)


def sphere(position=(0.0, 0.0, 1.0)) -> bake.ProbeSpec:
    m = np.eye(4)
    m[:3, 3] = position
    return bake.ProbeSpec("Sphere", "reflection", m, influence=3.0, falloff=0.25,
                          clip_start=0.1, clip_end=50.0)


def constant_cube(size: int, radiance: float) -> np.ndarray:
    return np.full((6, size, size, 3), radiance, np.float32)


def test_capture_points():
    np.testing.assert_allclose(sphere((1.0, 2.0, 3.0)).points, [[1.0, 2.0, 3.0]])
    # local x at -0.5 and 0.5 (two samples), y and z at 0: world = offset + scale * local
    np.testing.assert_allclose(volume().points, [[0.0, -2.0, 3.0], [2.0, -2.0, 3.0]])
    assert volume((3, 2, 4)).points.shape == (24, 3)
    with pytest.raises(ValueError, match="unknown probe kind"):
        bake.ProbeSpec("X", "cubemap", np.eye(4), 1.0)


def test_the_first_bounce_is_lit_by_the_world_alone():
    """No probe region decides where the sky reaches: the first volume captures are lit by the
    world (occluded by what each surface sees, in the captures' frames), with no probe present;
    a reflection probe is captured after the volumes, lit by this bounce's volumes, as a frame
    is (its surfaces have as many diffuse bounces as the frame's)."""
    world = World(color=np.full(3, 0.5, np.float32))
    lit = []

    def capture(position, size, near, far, probes, kind):
        lit.append((kind, probes.world_sh[0].copy(), len(probes.reflection),
                    [float(v.sh[0, 0, 0, 0, 0]) for v in probes.volumes]))
        return constant_cube(size, 1.0 + len(lit))

    job = bake.Bake([sphere(), volume()], world, capture, bounces=2, face_size=4,
                    volume_face_size=4)
    list(job.steps())
    assert [k for k, *_ in lit] == ["irradiance"] * 2 + ["reflection"] + ["irradiance"] * 2 + [
        "reflection"]
    for _, world_sh, *_ in lit:
        np.testing.assert_allclose(world_sh, C00 * 0.5, rtol=1e-3)
    assert lit[0][2:] == lit[1][2:] == (0, [])  # the first volumes: the world alone
    last = float(job.results[1].coeffs[0, 0, 0])  # the volume's first sample, 2nd bounce
    assert lit[2][2] == 0 and len(lit[2][3]) == 1  # the 1st bounce's volume, no reflection
    assert lit[3][2] == 1 and lit[5][2] == 1  # then the previous bounce's reflection
    assert lit[5][3] == [pytest.approx(last)] and lit[2][3] != lit[5][3]  # this bounce's
    assert [r.spec.kind for r in job.results] == ["reflection", "irradiance"]  # specs' order


def test_each_bounce_sees_the_previous_ones_probes():
    """A closed box: emission E plus albedo rho times the light the previous bounce baked."""
    emission, rho, bounces = 1.0, 0.5, 4
    seen = []

    def capture(position, size, near, far, probes, kind):
        assert near >= 1e-3 and far >= 2.0 * near
        # the previous bounce's radiance (the first bounce: the world's, black)
        incoming = probes.volumes[0].sh[0, 0, 0, 0, 0] / C00 if probes.volumes else 0.0
        seen.append(incoming)
        return constant_cube(size, emission + rho * incoming)

    job = bake.Bake([volume((1, 1, 1))], World(color=np.zeros(3, np.float32)), capture,
                    bounces=bounces, volume_face_size=4)
    fractions = list(job.steps())
    assert fractions == [1 / 4, 2 / 4, 3 / 4, 1.0]
    expected = [emission * sum(rho ** k for k in range(n)) for n in range(bounces + 1)]
    np.testing.assert_allclose(seen, expected[:bounces], rtol=1e-4)
    (result,) = job.results
    np.testing.assert_allclose(result.coeffs[0, 0], C00 * expected[bounces], rtol=1e-4)
    np.testing.assert_allclose(result.coeffs[0, 1:], 0.0, atol=1e-5)
    assert result.chains is None and result.face_size == 4
    # the added light shrinks geometrically towards E / (1 - rho)
    assert expected[bounces] < emission / (1 - rho)


def test_reflection_probe_chains_and_metadata():
    job = bake.Bake([sphere()], World(), lambda p, size, *_: constant_cube(size, 2.0),
                    bounces=1, face_size=8)
    steps = list(job.steps())
    assert steps == [1.0]
    (result,) = job.results
    assert set(result.chains) == {"bo1", "bo2"}
    assert [m.shape[1] for m in result.chains["bo2"]] == [8, 4, 2, 1]
    for chain in result.chains.values():
        for mip in chain:
            np.testing.assert_allclose(mip, 2.0, rtol=1e-4)
    meta = bake.metadata(result, "BO2", 1, "2026-01-02 03:04:05", 1.23456, "9.9.9")
    assert meta == {"probe": "Sphere", "kind": "reflection",
                    "matrix": sphere().local_to_world.tolist(), "clip_start": 0.1,
                    "face_size": 8, "filters": {"bo2": "cosine power",
                                                "bo1": "angular gaussian"},
                    "backend": "BO2", "bounces": 1, "bake_time": "2026-01-02 03:04:05",
                    "bake_seconds": 1.235, "version": "9.9.9"}
    meta = bake.metadata(bake.BakedProbe(volume(), np.zeros((2, 9, 3)), None, 16), "CYCLES", 1,
                         "t", 0.0, "v")
    assert meta["resolution"] == [2, 1, 1] and meta["filters"] == {}


def test_a_cancelled_bake_has_no_results():
    job = bake.Bake([volume((2, 2, 2))], World(), lambda p, s, *_: constant_cube(s, 1),
                    bounces=2, volume_face_size=2)
    steps = job.steps()
    assert next(steps) == 1 / 16
    steps.close()
    assert job.results == []


def test_world_probes_are_keyed_on_content():
    pixels = np.random.default_rng(1).random((8, 16, 4)).astype(np.float32)
    a = World(texture=make_texture(pixels.copy(), srgb=False), strength=2.0)
    b = World(texture=make_texture(pixels.copy(), srgb=False), strength=2.0)
    assert world_key(a, 16) == world_key(b, 16)
    assert world_probes(a).world_sh is world_probes(b).world_sh  # computed once
    pixels[0, 0, 0] += 1.0
    c = World(texture=make_texture(pixels, srgb=False), strength=2.0)
    assert world_key(c, 16) != world_key(a, 16)
    assert world_key(World(strength=2.0), 16) != world_key(World(strength=3.0), 16)
    # a world of one colour: its probe says so (its chains are not sampled)
    np.testing.assert_allclose(world_probes(World(color=np.ones(3))).world_color, 1.0)
    assert world_probes(a).world_color is None


@pytest.mark.parametrize("bounces", [3, 5])
def test_converged_bounces_reach_the_closed_boxs_limit(bounces):
    """A closed box: the bounces after the last, estimated from the last increments' ratio
    (rho exactly here), complete the geometric series to its limit E / (1 - rho); the
    reflection probe's chains alike."""
    emission, rho = 1.0, 0.5

    def capture(position, size, near, far, probes, kind):
        incoming = probes.volumes[0].sh[0, 0, 0, 0, 0] / C00 if probes.volumes else 0.0
        return constant_cube(size, emission + rho * incoming)

    job = bake.Bake([volume((1, 1, 1)), sphere()], World(color=np.zeros(3, np.float32)),
                    capture, bounces=bounces, converge=True, face_size=8, volume_face_size=4)
    list(job.steps())
    limit = emission / (1 - rho)
    volume_result, reflection = job.results
    np.testing.assert_allclose(volume_result.coeffs[0, 0], C00 * limit, rtol=1e-4)
    np.testing.assert_allclose(reflection.coeffs[0, 0], C00 * limit, rtol=1e-4)
    for levels in reflection.chains.values():
        for level in levels:
            np.testing.assert_allclose(level, limit, rtol=1e-4)
    two = bake.Bake([volume((1, 1, 1))], World(color=np.zeros(3, np.float32)), capture,
                    bounces=2, converge=True, volume_face_size=4)
    list(two.steps())  # two bounces: the first holds the direct light, nothing to go by
    np.testing.assert_allclose(two.results[0].coeffs[0, 0], C00 * emission * (1 + rho),
                               rtol=1e-4)
