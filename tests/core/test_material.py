"""Material programs (``core.scene.material``) evaluated at points, against the talk's
parameters worked out by hand for each tree."""

import math

import numpy as np
import pytest

from bo2_lighting.addon.core.scene.material import Points, evaluate
from bo2_lighting.addon.core.scene.nodes import NODES, principled_to_talk
from bo2_lighting.addon.core.scene.program import ProgramBuilder, talk_program


def points(n=1):
    up = np.tile(np.array([[0.0, 0.0, 1.0]], np.float32), (n, 1))
    fields = {"position": np.zeros((n, 3), np.float32), "normal": up, "geo": up, "view": up,
              "backfacing": np.zeros((n, 1), np.float32),
              "world_to_object": np.tile(np.eye(4), (n, 1, 1)),
              "texspace": np.tile(np.array([[[0.0] * 3, [1.0] * 3]], np.float32), (n, 1, 1)),
              "window": np.zeros((n, 2), np.float32), "world_to_camera": np.eye(4)}
    return Points(n, np.tile(np.array([[1.0, 0.0, 0.0]], np.float32), (n, 1)), fields,
                  lambda key, bary: None)


def gloss_of(roughness):
    """docs/model.md: g = log(2 / r^4 - 2) / log(8192), clamped to [0, 1]."""
    return min(1.0, max(0.0, math.log(2.0 / roughness**4 - 2.0) / math.log(8192.0)))


def test_the_talks_parameters_come_through():
    p = evaluate(talk_program((0.5, 0.25, 0.125), (0.9, 0.8, 0.7), 0.6, (1.0, 2.0, 3.0), 2.0),
                 points(3))
    np.testing.assert_allclose(p.albedo, [[0.5, 0.25, 0.125]] * 3)
    np.testing.assert_allclose(p.rf0, [[0.9, 0.8, 0.7]] * 3, rtol=1e-6)
    np.testing.assert_allclose(p.gloss, [0.6] * 3, rtol=1e-6)
    np.testing.assert_allclose(p.emission, [[2.0, 4.0, 6.0]] * 3)  # colour times strength
    np.testing.assert_allclose(p.alpha, 1.0)
    assert p.normal is None and p.occlusion is None


def test_principled_to_talk_by_hand():
    # base (0.8, 0.2, 0.2), metallic 0.5, IOR 1.5 (F0 0.04), level 0.5 (x 2 = 1), white tint
    albedo, rf0, gloss = principled_to_talk(
        np.array([[0.8, 0.2, 0.2]]), np.array([[0.5]]), np.array([[0.5]]), np.array([[1.5]]),
        np.array([[0.5]]), np.array([[1.0, 1.0, 1.0]]), np.array([[0.0]]))
    np.testing.assert_allclose(albedo, [[0.4, 0.1, 0.1]])  # base (1 - metallic)
    np.testing.assert_allclose(rf0, [[0.42, 0.12, 0.12]])  # 0.5 * 0.04 + 0.5 * base
    np.testing.assert_allclose(gloss, [[gloss_of(0.5)]], rtol=1e-6)
    # transmission 1 takes the diffuse away; metallic 1 gives rf0 = base
    albedo, rf0, _ = principled_to_talk(
        np.array([[0.8, 0.2, 0.2]]), np.array([[1.0]]), np.array([[0.5]]), np.array([[1.5]]),
        np.array([[0.5]]), np.array([[1.0, 1.0, 1.0]]), np.array([[1.0]]))
    np.testing.assert_allclose(albedo, 0.0)
    np.testing.assert_allclose(rf0, [[0.8, 0.2, 0.2]])


def test_a_mix_of_diffuse_and_glossy():
    b = ProgramBuilder()
    diffuse = b.add("diffuse", b.const(0.8, 0.4, 0.2), None)
    glossy = b.add("glossy", b.const(1.0, 0.5, 0.25), b.const(0.5), None)
    surface = b.add("mix_shader", b.const(0.25), diffuse, glossy)
    p = evaluate(b.build(surface), points())
    # 0.75 of the diffuse's albedo, 0.25 of the glossy's colour as rf0; the gloss is the
    # glossy's own (divided by its specular weight, 0.25)
    np.testing.assert_allclose(p.albedo, [[0.6, 0.3, 0.15]], rtol=1e-6)
    np.testing.assert_allclose(p.rf0, [[0.25, 0.125, 0.0625]], rtol=1e-6)
    np.testing.assert_allclose(p.gloss, [gloss_of(0.5)], rtol=1e-5)


def test_node_arithmetic_feeds_the_surface():
    # emission = (2 * 3 + 1) as a colour, strength 0.5: 3.5 on every channel
    b = ProgramBuilder()
    seven = b.add("math", b.const(2.0), b.const(3.0), b.const(1.0), param=("MULTIPLY_ADD",
                                                                          False))
    colour = b.add("to_vector", seven)
    surface = b.add("emission", colour, b.const(0.5))
    program = b.build(surface)
    assert program.constant  # nothing reads the points: evaluated once per material
    np.testing.assert_allclose(evaluate(program, points(2)).emission, [[3.5] * 3] * 2)


def test_transparency_and_holdout():
    b = ProgramBuilder()
    clear = b.add("transparent", b.const(1.0, 1.0, 1.0))
    diffuse = b.add("diffuse", b.const(0.5, 0.5, 0.5), None)
    surface = b.add("mix_shader", b.const(0.25), diffuse, clear)
    program = b.build(surface)
    assert program.fades and not program.holdout
    p = evaluate(program, points())
    # a quarter transparent: alpha 0.75, the opaque part's albedo divided back by its alpha
    np.testing.assert_allclose(p.alpha, [0.75])
    np.testing.assert_allclose(p.albedo, [[0.5, 0.5, 0.5]], rtol=1e-6)
    b = ProgramBuilder()
    holdout = b.build(b.add("holdout"))
    assert holdout.holdout and not holdout.fades


@pytest.mark.parametrize("roughness", [0.2, 0.5, 0.8])
def test_glossy_roughness_to_gloss(roughness):
    b = ProgramBuilder()
    surface = b.add("glossy", b.const(1.0, 1.0, 1.0), b.const(roughness), None)
    np.testing.assert_allclose(evaluate(b.build(surface), points()).gloss, [gloss_of(roughness)],
                               rtol=1e-5)


def test_an_operation_is_built_as_declared():
    b = ProgramBuilder()
    with pytest.raises(ValueError, match="reads 3 inputs"):
        b.add("glossy", b.const(1.0, 1.0, 1.0), b.const(0.5))  # the normal slot left out
    with pytest.raises(ValueError, match="parameters"):
        b.add("math", b.const(1.0), b.const(2.0), b.const(0.0), param=("ADD",))
    assert NODES["principled"].index("alpha") == 9 and NODES["bo2"].index("alpha") == 6
    assert all(node.reference is not None and node.output for node in NODES.values())
