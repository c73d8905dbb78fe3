"""Blender's node arithmetic (``core.scene.node_math``) against values worked out by hand from
Cycles' SVM formulas (``intern/cycles/kernel/svm``), each written next to its number."""

import numpy as np
import pytest

from bo2_lighting.addon.core.scene import node_math as nm


def value(x):
    return float(np.asarray(x).reshape(-1)[0])


@pytest.mark.parametrize("operation, a, b, c, expected", [
    ("ADD", 2.0, 3.0, 0.0, 5.0),
    ("DIVIDE", 1.0, 0.0, 0.0, 0.0),            # safe division: x / 0 = 0
    ("POWER", -8.0, 1.0 / 3.0, 0.0, 0.0),      # negative base, non-integer exponent: 0
    ("POWER", -2.0, 3.0, 0.0, -8.0),           # negative base, integer exponent: (-2)^3
    ("LOGARITHM", 8.0, 2.0, 0.0, 3.0),         # log_2 8
    ("LOGARITHM", -1.0, 2.0, 0.0, 0.0),        # non-positive argument: 0
    ("SQRT", -4.0, 0.0, 0.0, 0.0),             # sqrt(max(a, 0))
    ("MULTIPLY_ADD", 2.0, 3.0, 4.0, 10.0),     # 2 * 3 + 4
    ("MODULO", -7.0, 3.0, 0.0, -1.0),          # fmod keeps the dividend's sign
    ("FLOORED_MODULO", -7.0, 3.0, 0.0, 2.0),   # -7 - 3 floor(-7 / 3) = -7 + 9
    ("WRAP", 5.5, 2.0, 0.0, 1.5),              # into [0, 2): 5.5 - 2 floor(5.5 / 2)
    ("SNAP", 7.3, 2.0, 0.0, 6.0),              # floor(7.3 / 2) * 2
    ("PINGPONG", 3.0, 2.0, 0.0, 1.0),          # 0 -> 2 -> 0: at 3, 1
    ("COMPARE", 1.0, 1.05, 0.1, 1.0),          # |a - b| <= 0.1
    ("SMOOTH_MIN", 1.0, 1.0, 1.0, 5.0 / 6.0),  # h = 1: min - h^3 c / 6 = 1 - 1/6
    ("ROUND", 2.5, 0.0, 0.0, 3.0),             # floor(a + 0.5)
    ("SIGN", -0.0, 0.0, 0.0, 0.0),
    ("DEGREES", np.pi, 0.0, 0.0, 180.0),
])
def test_math(operation, a, b, c, expected):
    assert value(nm.math(operation, a, b, c)) == pytest.approx(expected, rel=1e-5, abs=1e-6)


def test_wrap_matches_its_definition():
    # Cycles' wrapf(v, max, min): v - range floor((v - min) / range), range = max - min
    for v, top, bottom in ((5.5, 2.0, 0.0), (-0.5, 1.0, -1.0), (7.0, 3.0, 1.0)):
        span = top - bottom
        expected = v - span * np.floor((v - bottom) / span)
        assert value(nm.math("WRAP", v, top, bottom)) == pytest.approx(expected)


def test_math_clamps_and_drops_overflow():
    assert value(nm.math("ADD", 0.7, 0.6, 0.0, use_clamp=True)) == 1.0
    assert value(nm.math("EXPONENT", 1000.0, 0.0, 0.0)) == 0.0  # inf -> 0, as Cycles' output


def test_vector_math():
    a, b = [[1.0, 2.0, 2.0]], [[0.0, 0.0, 1.0]]
    # dot (1, 2, 2) . (0, 0, 1) = 2, on every component of the vector output
    assert value(nm.vector_math("DOT_PRODUCT", a, b, [[0, 0, 0]], 1.0)) == pytest.approx(2.0)
    # length 3; normalize (1, 2, 2) / 3
    assert value(nm.vector_math("LENGTH", a, b, [[0, 0, 0]], 1.0)) == pytest.approx(3.0)
    np.testing.assert_allclose(nm.vector_math("NORMALIZE", a, b, [[0, 0, 0]], 1.0),
                               [[1 / 3, 2 / 3, 2 / 3]], rtol=1e-6)
    # reflect (1, 0, -1) about the normal (0, 0, 1): (1, 0, 1)
    np.testing.assert_allclose(nm.vector_math("REFLECT", [[1.0, 0.0, -1.0]], b, [[0, 0, 0]],
                                              1.0), [[1.0, 0.0, 1.0]], atol=1e-6)
    # cross (1, 0, 0) x (0, 1, 0) = (0, 0, 1); scale by 2.5
    np.testing.assert_allclose(nm.vector_math("CROSS_PRODUCT", [[1, 0, 0]], [[0, 1, 0]],
                                              [[0, 0, 0]], 1.0), [[0, 0, 1]])
    np.testing.assert_allclose(nm.vector_math("SCALE", a, b, [[0, 0, 0]], 2.5),
                               [[2.5, 5.0, 5.0]])


def test_colour_models_round_trip_and_known_points():
    # pure red: hue 0, saturation 1, value 1; cyan (0, 1, 1): hue 1/2
    np.testing.assert_allclose(nm.rgb_to_hsv([[1.0, 0.0, 0.0]]), [[0.0, 1.0, 1.0]])
    np.testing.assert_allclose(nm.rgb_to_hsv([[0.0, 1.0, 1.0]]), [[0.5, 1.0, 1.0]])
    # grey 0.5: no hue, no saturation, value 0.5; HSL lightness (max + min) / 2
    np.testing.assert_allclose(nm.rgb_to_hsv([[0.5, 0.5, 0.5]]), [[0.0, 0.0, 0.5]])
    np.testing.assert_allclose(nm.rgb_to_hsl([[1.0, 0.0, 0.0]]), [[0.0, 1.0, 0.5]])
    rgb = np.random.default_rng(3).random((64, 3)).astype(np.float32)
    np.testing.assert_allclose(nm.hsv_to_rgb(nm.rgb_to_hsv(rgb)), rgb, atol=2e-6)
    np.testing.assert_allclose(nm.hsl_to_rgb(nm.rgb_to_hsl(rgb)), rgb, atol=2e-6)


def test_blend_modes():
    a, b = [[0.2, 0.4, 0.8]], [[0.5, 0.5, 0.5]]
    # MIX at 0.25: 0.75 a + 0.25 b
    np.testing.assert_allclose(nm.blend("MIX", 0.25, a, b), [[0.275, 0.425, 0.725]], rtol=1e-6)
    # MULTIPLY at 1: a b; SCREEN at 1: 1 - (1 - a)(1 - b)
    np.testing.assert_allclose(nm.blend("MULTIPLY", 1.0, a, b), [[0.1, 0.2, 0.4]], rtol=1e-6)
    np.testing.assert_allclose(nm.blend("SCREEN", 1.0, a, b), [[0.6, 0.7, 0.9]], rtol=1e-6)
    # DIFFERENCE at 1: |a - b|; clamped result stays in [0, 1]
    np.testing.assert_allclose(nm.blend("DIFFERENCE", 1.0, a, b), [[0.3, 0.1, 0.3]], atol=1e-6)
    assert nm.blend("ADD", 1.0, a, b, clamp_result=True).max() == 1.0


def test_colour_adjustments():
    # Invert at 0.5 of 0.2: (0.2 + 0.8) / 2; gamma 2 of 0.5: 0.25, of -0.5: unchanged
    assert value(nm.invert(0.5, [[0.2, 0.2, 0.2]])) == pytest.approx(0.5)
    np.testing.assert_allclose(nm.gamma([[0.5, -0.5, 2.0]], 2.0), [[0.25, -0.5, 4.0]])
    assert value(nm.gamma([[0.3, 0.3, 0.3]], 0.0)) == 1.0  # a gamma of 0 gives white
    # Brightness 0.1, contrast 0.5 of 0.4: 1.5 * 0.4 + 0.1 - 0.25 = 0.45
    assert value(nm.bright_contrast([[0.4, 0.4, 0.4]], 0.1, 0.5)) == pytest.approx(0.45)
    # Hue/Saturation/Value: hue 0.5, saturation 1, value 1 is neutral; hue +1/3 turns red green
    red = [[1.0, 0.0, 0.0]]
    np.testing.assert_allclose(nm.hue_saturation_value(0.5, 1.0, 1.0, 1.0, red), red, atol=1e-6)
    np.testing.assert_allclose(nm.hue_saturation_value(0.5 + 1 / 3, 1.0, 1.0, 1.0, red),
                               [[0.0, 1.0, 0.0]], atol=1e-5)


def test_mapping_map_range_clamp_ramp():
    # POINT: rotate (1, 0, 0) by 90 degrees about Z, scale 2, move by (0, 0, 1): (0, 2, 1)
    out = nm.mapping("POINT", [[1.0, 0.0, 0.0]], [[0.0, 0.0, 1.0]], [[0.0, 0.0, np.pi / 2]],
                     [[2.0, 2.0, 2.0]])
    np.testing.assert_allclose(out, [[0.0, 2.0, 1.0]], atol=1e-6)
    # TEXTURE is the inverse: (0, 2, 1) back to (1, 0, 0)
    back = nm.mapping("TEXTURE", out, [[0.0, 0.0, 1.0]], [[0.0, 0.0, np.pi / 2]],
                      [[2.0, 2.0, 2.0]])
    np.testing.assert_allclose(back, [[1.0, 0.0, 0.0]], atol=1e-6)
    # Map Range LINEAR 0.25 from [0, 1] to [10, 20]: 12.5; STEPPED with 2 steps: floor(0.75) / 2
    assert value(nm.map_range("LINEAR", 0.25, 0, 1, 10, 20, 4, False)) == pytest.approx(12.5)
    assert value(nm.map_range("STEPPED", 0.25, 0, 1, 10, 20, 2, False)) == pytest.approx(10.0)
    # SMOOTHSTEP at the middle: 0.5; SMOOTHERSTEP at 0.25: 6 t^5 - 15 t^4 + 10 t^3
    assert value(nm.map_range("SMOOTHSTEP", 0.5, 0, 1, 0, 1, 4, False)) == pytest.approx(0.5)
    t = 0.25
    assert value(nm.map_range("SMOOTHERSTEP", t, 0, 1, 0, 1, 4, False)) == pytest.approx(
        6 * t**5 - 15 * t**4 + 10 * t**3, rel=1e-5)
    # Clamp RANGE swaps a reversed range; MINMAX does not
    assert value(nm.clamp("RANGE", 5.0, 3.0, 1.0)) == 3.0
    assert value(nm.clamp("MINMAX", 5.0, 3.0, 1.0)) == 1.0
    # a 3-entry ramp 0, 1, 0 read at 0.25: halfway between entries 0 and 1
    table = np.array([[0.0], [1.0], [0.0]], np.float32)
    assert value(nm.ramp_lookup(table, [[0.25]], True, False)) == pytest.approx(0.5)
    assert value(nm.ramp_lookup(table, [[0.25]], False, False)) == 0.0  # constant: entry 0


def test_fresnel_dielectric():
    # normal incidence, IOR 1.5: ((1.5 - 1) / (1.5 + 1))^2 = 0.04
    assert value(nm.fresnel_dielectric_cos(1.0, 1.5)) == pytest.approx(0.04, rel=1e-5)
    # grazing: 1; total internal reflection (eta < 1 at a grazing angle): 1
    assert value(nm.fresnel_dielectric_cos(0.0, 1.5)) == pytest.approx(1.0)
    assert value(nm.fresnel_dielectric_cos(0.1, 1 / 1.5)) == 1.0
