"""Textures: sRGB, mip chains, sampling, ray-differential LOD, tangent frames, lat-long mapping.

Independent values: published sRGB points (IEC 61966-2-1), mip levels averaged by hand, texel
values read directly from the image array, closed-form ray/plane intersections of orthographic
and perspective cameras, Blender's Normal Map formula evaluated by hand, and the lat-long UVs of
the six axes measured in Cycles renders (tests/blender/test_environment_mapping.py).
"""

import math

import numpy as np
import pytest

from bo2_lighting.addon.core.formulas import tangents, texture
from bo2_lighting.addon.core.scene import Camera

RNG = np.random.default_rng(7)


# --- sRGB ------------------------------------------------------------------------------------


def test_srgb_published_points():
    # 0.5 -> 0.214041140 and 128/255 -> 0.215860500 (IEC 61966-2-1 tables); the segment joint.
    lin = texture.srgb_to_linear(np.array([0.0, 0.04045, 0.5, 128 / 255, 1.0]))
    assert lin.dtype == np.float32
    np.testing.assert_allclose(lin, [0.0, 0.0031308, 0.21404114, 0.2158605, 1.0], rtol=2e-6,
                               atol=1e-8)
    enc = texture.linear_to_srgb(np.array([0.0, 0.0031308, 0.21404114, 1.0]))
    np.testing.assert_allclose(enc, [0.0, 0.04045, 0.5, 1.0], rtol=2e-6, atol=1e-7)


def test_srgb_round_trip_any_shape():
    x = RNG.random((7, 5, 3)).astype(np.float32) * 1.2
    back = texture.linear_to_srgb(texture.srgb_to_linear(x))
    assert back.shape == x.shape and back.dtype == np.float32
    np.testing.assert_allclose(back, x, atol=2e-6)
    assert np.isfinite(texture.srgb_to_linear(np.array([-1.0, -0.01]))).all()


def test_make_texture_decodes_colour_not_alpha():
    px = np.full((2, 2, 4), 0.5, np.float32)
    tex = texture.make_texture(px, srgb=True)
    np.testing.assert_allclose(tex.linear(0)[..., :3], 0.21404114, rtol=2e-6)
    np.testing.assert_allclose(tex.linear(0)[..., 3], 0.5)
    grey = texture.make_texture(np.full((2, 2, 1), 0.5, np.float32), srgb=True)
    np.testing.assert_allclose(grey.linear(0), 0.21404114, rtol=2e-6)
    raw = texture.make_texture(px, srgb=False)
    np.testing.assert_allclose(raw.mips[0], 0.5)


# --- mip chain -------------------------------------------------------------------------------


def test_mips_of_4x4_are_2x2_box_means():
    img = np.arange(16, dtype=np.float32).reshape(4, 4, 1)
    mips = texture.make_texture(img, srgb=False).mips
    assert [m.shape for m in mips] == [(4, 4, 1), (2, 2, 1), (1, 1, 1)]
    # (0+1+4+5)/4, (2+3+6+7)/4, (8+9+12+13)/4, (10+11+14+15)/4
    np.testing.assert_allclose(mips[1][..., 0], [[2.5, 4.5], [10.5, 12.5]])
    np.testing.assert_allclose(mips[2][..., 0], [[7.5]])
    assert all(m.dtype == np.float32 for m in mips)


def test_mips_of_odd_5x3_use_area_weights():
    # Width 5, height 3: texel (row r, column c) = c + 10 r; the column means are 10 + c.
    img = (np.arange(5)[None, :] + 10.0 * np.arange(3)[:, None]).astype(np.float32)
    mips = texture.make_texture(img[..., None], srgb=False).mips
    assert [m.shape[:2] for m in mips] == [(3, 5), (1, 2), (1, 1)]
    # 5 -> 2 texels, each covering 2.5 input texels: (2/5, 2/5, 1/5) of columns 0, 1, 2 and
    # (1/5, 2/5, 2/5) of columns 2, 3, 4: 0.4*10 + 0.4*11 + 0.2*12 = 10.8, and 13.2.
    np.testing.assert_allclose(mips[1][0, :, 0], [10.8, 13.2], rtol=1e-6)
    np.testing.assert_allclose(mips[2][0, 0, 0], 12.0, rtol=1e-6)  # the image's mean


def test_bad_inputs_raise():
    with pytest.raises(ValueError):
        texture.make_texture(np.zeros((2, 2, 2), np.float32), srgb=False)
    with pytest.raises(ValueError):
        texture.make_texture(np.zeros((2, 2, 3), np.float32), srgb=False, extension="WRAP")


# --- sampling --------------------------------------------------------------------------------


def centre_uv(col, row_from_top, w, h):
    """UV of the centre of a texel given by its column and its row counted from the top."""
    return [(col + 0.5) / w, (h - 1 - row_from_top + 0.5) / h]


def test_bilinear_at_texel_centres_and_halfway():
    img = RNG.random((4, 6, 3)).astype(np.float32)
    tex = texture.make_texture(img, srgb=False)
    rows, cols = np.meshgrid(np.arange(4), np.arange(6), indexing="ij")
    uv = np.array([centre_uv(c, r, 6, 4) for r, c in zip(rows.ravel(), cols.ravel(), strict=True)])
    out = texture.sample(tex, uv)
    assert out.shape == (24, 3) and out.dtype == np.float32
    np.testing.assert_allclose(out, img.reshape(-1, 3), atol=1e-6)
    # Halfway between columns 2 and 3 of row 1, and between rows 1 and 2 of column 4.
    half_u = texture.sample(tex, [[3.0 / 6, centre_uv(0, 1, 6, 4)[1]]])[0]
    np.testing.assert_allclose(half_u, 0.5 * (img[1, 2] + img[1, 3]), atol=1e-6)
    half_v = texture.sample(tex, [[4.5 / 6, 2.0 / 4]])[0]
    np.testing.assert_allclose(half_v, 0.5 * (img[1, 4] + img[2, 4]), atol=1e-6)


def test_uv_origin_is_the_bottom_left_texel():
    img = RNG.random((3, 4, 3)).astype(np.float32)
    bottom_left = img[-1, 0]  # the LAST row of a top-first array
    tex = texture.make_texture(img, srgb=False, extension="EXTEND")
    np.testing.assert_allclose(texture.sample(tex, [[0.0, 0.0]])[0], bottom_left, atol=1e-6)
    near = texture.make_texture(img, srgb=False, interpolation="Closest")
    np.testing.assert_allclose(texture.sample(near, [[0.01, 0.01]])[0], bottom_left)
    np.testing.assert_allclose(texture.sample(near, [[0.99, 0.99]])[0], img[0, -1])


def test_extension_modes():
    img = RNG.random((4, 4, 4)).astype(np.float32)
    img[..., 3] = 1.0
    uv = RNG.random((50, 2))
    rep = texture.make_texture(img, srgb=False, extension="REPEAT")
    np.testing.assert_allclose(texture.sample(rep, uv + [1.0, -2.0]), texture.sample(rep, uv),
                               atol=1e-5)
    # REPEAT at u = 0 on a texel row: the mean of the first and last columns.
    v_row0 = centre_uv(0, 0, 4, 4)[1]
    np.testing.assert_allclose(texture.sample(rep, [[0.0, v_row0]])[0],
                               0.5 * (img[0, 0] + img[0, 3]), atol=1e-6)

    ext = texture.make_texture(img, srgb=False, extension="EXTEND")
    np.testing.assert_allclose(texture.sample(ext, [[1.7, v_row0]])[0], img[0, 3], atol=1e-6)
    np.testing.assert_allclose(texture.sample(ext, [[-3.0, 5.0]])[0], img[0, 0], atol=1e-6)

    clip = texture.make_texture(img, srgb=False, extension="CLIP")
    outside = texture.sample(clip, [[1.5, 0.5], [0.5, -0.2], [-0.13, 0.5]])
    np.testing.assert_array_equal(outside, 0.0)  # alpha too, beyond half a texel
    # within half a texel outside, the edge texel fades out (Cycles' CLIP): at a quarter
    # texel beyond the edge, a quarter of the edge texel
    np.testing.assert_allclose(texture.sample(clip, [[1.0 + 0.25 / 4, v_row0]])[0],
                               0.25 * img[0, 3], atol=1e-6)
    np.testing.assert_allclose(texture.sample(clip, [centre_uv(3, 0, 4, 4)])[0], img[0, 3],
                               atol=1e-6)
    # On the image edge half of the taps read transparent black.
    np.testing.assert_allclose(texture.sample(clip, [[1.0, v_row0]])[0], 0.5 * img[0, 3],
                               atol=1e-6)

    mir = texture.make_texture(img, srgb=False, extension="MIRROR")
    # Mirrored repeat: the image reflected about u = 1 and about u = 0.
    np.testing.assert_allclose(texture.sample(mir, [[1.0 + 0.5 / 4, v_row0]])[0], img[0, 3],
                               atol=1e-6)
    np.testing.assert_allclose(texture.sample(mir, [[1.0 + 1.5 / 4, v_row0]])[0], img[0, 2],
                               atol=1e-6)
    np.testing.assert_allclose(texture.sample(mir, [[-0.5 / 4, v_row0]])[0], img[0, 0],
                               atol=1e-6)
    u = RNG.random(20)
    v = np.full(20, 0.3)
    a = texture.sample(mir, np.stack([u, v], -1))
    np.testing.assert_allclose(texture.sample(mir, np.stack([2.0 - u, v], -1)), a, atol=1e-5)
    np.testing.assert_allclose(texture.sample(mir, np.stack([-u, v], -1)), a, atol=1e-5)


def test_trilinear_blends_two_levels():
    img = np.array([[1.0, 2.0], [3.0, 4.0]], np.float32)[..., None]
    tex = texture.make_texture(img, srgb=False)
    uv = [centre_uv(1, 0, 2, 2)]  # texel value 2; level 1 is the mean 2.5
    np.testing.assert_allclose(texture.sample(tex, uv, lod=0.0)[0], [2.0], atol=1e-6)
    np.testing.assert_allclose(texture.sample(tex, uv, lod=0.5)[0], [2.25], atol=1e-6)
    np.testing.assert_allclose(texture.sample(tex, uv, lod=1.0)[0], [2.5], atol=1e-6)
    np.testing.assert_allclose(texture.sample(tex, uv, lod=9.0)[0], [2.5], atol=1e-6)  # clamped
    np.testing.assert_allclose(texture.sample(tex, uv, lod=-4.0)[0], [2.0], atol=1e-6)
    np.testing.assert_allclose(texture.sample(tex, uv, lod=np.nan)[0], [2.5], atol=1e-6)


def test_trilinear_per_point_lod_on_a_larger_image():
    img = RNG.random((16, 8, 3)).astype(np.float32)
    tex = texture.make_texture(img, srgb=False)
    uv = RNG.random((200, 2))
    lod = RNG.random(200) * 5.0
    out = texture.sample(tex, uv, lod)
    # Independently: bilinear on standalone textures made of each level.
    levels = [texture.Texture([m], "REPEAT", "Linear") for m in tex.mips]
    per = np.stack([texture.sample(t, uv) for t in levels])
    lo = np.floor(np.minimum(lod, len(levels) - 1)).astype(int)
    hi = np.minimum(lo + 1, len(levels) - 1)
    f = (np.minimum(lod, len(levels) - 1) - lo)[:, None]
    idx = np.arange(200)
    np.testing.assert_allclose(out, (1 - f) * per[lo, idx] + f * per[hi, idx], atol=1e-5)


def test_closest_reads_level_zero_texels():
    img = RNG.random((4, 4, 3)).astype(np.float32)
    tex = texture.make_texture(img, srgb=False, interpolation="Closest")
    # Anywhere inside texel (row 1, column 2), whatever the lod.
    uv = [[(2 + 0.9) / 4, (4 - 1 - 1 + 0.1) / 4]]
    np.testing.assert_allclose(texture.sample(tex, uv, lod=3.0)[0], img[1, 2])


# --- level of detail and ray differentials ---------------------------------------------------


def test_lod_from_uv_derivatives():
    tex = texture.make_texture(np.zeros((128, 256, 3), np.float32), srgb=False)
    dx = np.array([[1 / 256, 0.0], [4 / 256, 0.0], [0.0, 0.0]])
    dy = np.array([[0.0, 1 / 128], [0.0, 1 / 128], [0.0, 2 / 128]])
    np.testing.assert_allclose(texture.lod_from_uv_derivatives(tex, dx, dy), [0.0, 2.0, 1.0],
                               atol=1e-6)
    # Diagonal step of (3, 4) texels: length 5.
    lod = texture.lod_from_uv_derivatives(tex, [[3 / 256, 4 / 128]], [[0.0, 0.0]])
    np.testing.assert_allclose(lod, [math.log2(5.0)], atol=1e-6)


def big_ground_triangle(n, length):
    """(n, 3, 3) copies of a large triangle on z = 0 and its UVs xy / length."""
    tri = np.array([[-50.0, -50.0, 0.0], [50.0, -50.0, 0.0], [-50.0, 50.0, 0.0]])
    tri = np.broadcast_to(tri, (n, 3, 3))
    return tri, tri[..., :2] / length


def ortho_camera(half, width, height, z):
    """An orthographic camera at (0, 0, z) looking down, image up = +Y, OpenGL projection."""
    view = np.eye(4)
    view[2, 3] = -z
    aspect = width / height
    near, far = 0.1, 100.0
    proj = np.diag([1.0 / (half * aspect), 1.0 / half, -2.0 / (far - near), 1.0])
    proj[2, 3] = -(far + near) / (far - near)
    return Camera(view, proj, width, height, orthographic=True)


def test_uv_derivatives_orthographic_analytic():
    # Plane z = 0 seen straight down, pixel size s, UV = xy / L: duv/dx = s / L exactly.
    s, length, n = 0.02, 3.0, 5
    points = np.column_stack([RNG.uniform(-5, 5, (n, 2)), np.zeros(n)])
    tri, uv = big_ground_triangle(n, length)
    down = np.array([0.0, 0.0, -1.0])
    dx, dy = texture.uv_derivatives(tri, uv, points, points + [s, 0, 4], down,
                                    points + [0, s, 4], down)
    assert dx.shape == (n, 2) and dx.dtype == np.float32
    np.testing.assert_allclose(dx, np.tile([s / length, 0.0], (n, 1)), atol=1e-7)
    np.testing.assert_allclose(dy, np.tile([0.0, s / length], (n, 1)), atol=1e-7)

    # The same through a Camera: half-height 1 m, 100 x 50 pixels, so 0.04 m per pixel; image
    # y runs along -Y.
    cam = ortho_camera(half=1.0, width=100, height=50, z=4.0)
    x = np.array([10.5, 50.5, 77.5])
    y = np.array([3.5, 25.5, 40.5])
    o, d = cam.rays(x, y)
    hits = o + (-o[:, 2:] / d[:, 2:]) * d
    np.testing.assert_allclose(hits[:, 0], 0.04 * x - 2.0, atol=1e-6)
    np.testing.assert_allclose(hits[:, 1], 1.0 - 0.04 * y, atol=1e-6)
    tri, uv = big_ground_triangle(3, length)
    dx, dy = texture.uv_derivatives(tri, uv, hits, *cam.rays(x + 1, y), *cam.rays(x, y + 1))
    np.testing.assert_allclose(dx, np.tile([0.04 / length, 0.0], (3, 1)), atol=1e-6)
    np.testing.assert_allclose(dy, np.tile([0.0, -0.04 / length], (3, 1)), atol=1e-6)


def test_uv_derivatives_perspective_against_analytic_intersection():
    # A pinhole at height hgt, pitched 30 degrees down from the horizon, looking along +Y at
    # the ground z = 0 with UV = xy / L. Window (x, y) -> direction forward + a right - b up,
    # intersected in closed form: hit = eye - hgt / d_z d.
    hgt, length, w, h = 2.0, 4.0, 64, 48
    tan_half = math.tan(math.radians(20.0))
    pitch = math.radians(30.0)
    forward = np.array([0.0, math.cos(pitch), -math.sin(pitch)])
    up = np.array([0.0, math.sin(pitch), math.cos(pitch)])
    right = np.array([1.0, 0.0, 0.0])
    eye = np.array([0.0, 0.0, hgt])

    def ray(x, y):
        a = (2.0 * x / w - 1.0) * tan_half * (w / h)
        b = (1.0 - 2.0 * y / h) * tan_half
        return forward + a[:, None] * right + b[:, None] * up

    def uv_of(d):
        hit = eye + (-hgt / d[:, 2:]) * d
        return hit[:, :2] / length

    x = np.array([5.5, 32.5, 60.5, 20.5])
    y = np.array([30.5, 24.5, 40.5, 47.5])
    d = ray(x, y)
    points = eye + (-hgt / d[:, 2:]) * d
    tri, uv = big_ground_triangle(len(x), length)
    dx, dy = texture.uv_derivatives(tri, uv, points, eye, ray(x + 1, y), eye, ray(x, y + 1))
    np.testing.assert_allclose(dx, uv_of(ray(x + 1, y)) - uv_of(d), rtol=1e-4, atol=1e-7)
    np.testing.assert_allclose(dy, uv_of(ray(x, y + 1)) - uv_of(d), rtol=1e-4, atol=1e-7)
    # And one pixel is close to the derivative: central finite difference with a tiny step.
    eps = 1e-4
    deriv = (uv_of(ray(x + eps, y)) - uv_of(ray(x - eps, y))) / (2 * eps)
    np.testing.assert_allclose(dx, deriv, rtol=0.05, atol=1e-6)

    # The same camera as a scene.Camera (OpenGL perspective projection) and its rays, whose
    # origins lie on the near plane (any point of a ray will do).
    rot = np.stack([right, up, -forward])  # world -> camera rows: x, y, z axes
    view = np.eye(4)
    view[:3, :3] = rot
    view[:3, 3] = -rot @ eye
    near, far = 0.1, 100.0
    proj = np.zeros((4, 4))
    proj[0, 0] = 1.0 / (tan_half * w / h)
    proj[1, 1] = 1.0 / tan_half
    proj[2, 2] = -(far + near) / (far - near)
    proj[2, 3] = -2.0 * far * near / (far - near)
    proj[3, 2] = -1.0
    cam = Camera(view, proj, w, h)
    dx2, dy2 = texture.uv_derivatives(tri, uv, points, *cam.rays(x + 1, y), *cam.rays(x, y + 1))
    np.testing.assert_allclose(dx2, dx, rtol=1e-4, atol=1e-6)
    np.testing.assert_allclose(dy2, dy, rtol=1e-4, atol=1e-6)


def test_uv_derivatives_degenerate_cases_are_finite_and_coarse():
    tex = texture.make_texture(np.zeros((64, 64, 3), np.float32), srgb=False)
    tri, uv = big_ground_triangle(3, 1.0)
    uv = uv.copy()
    uv[2] = 0.25  # zero-area UV triangle for the third point
    points = np.array([[0.0, 0.0, 0.0], [1.0, 1.0, 0.0], [2.0, 0.0, 0.0]])
    along = np.array([[1.0, 0.0, 0.0], [0.0, 0.0, -1.0], [0.0, 0.0, -1.0]])  # first: parallel
    origins = points + [0.0, 0.0, 1.0]
    dx, dy = texture.uv_derivatives(tri, uv, points, origins + [0.01, 0, 0], along,
                                    origins + [0, 0.01, 0], along)
    assert np.isfinite(dx).all() and np.isfinite(dy).all()
    lod = texture.lod_from_uv_derivatives(tex, dx, dy)
    assert lod[0] >= tex.levels - 1 and lod[2] >= tex.levels - 1
    np.testing.assert_allclose(dx[1], [0.01, 0.0], atol=1e-7)  # the healthy one
    flat = np.zeros((1, 3, 3))  # zero-area triangle
    dx, dy = texture.uv_derivatives(flat, uv[:1], points[:1], origins[:1], along[1],
                                    origins[:1], along[1])
    assert np.isfinite(dx).all() and np.isfinite(dy).all()


# --- tangent frames and normal maps ----------------------------------------------------------


QUAD = np.array([[[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [1.0, 1.0, 0.0]],
                 [[0.0, 0.0, 0.0], [1.0, 1.0, 0.0], [0.0, 1.0, 0.0]]])
UP = np.array([[0.0, 0.0, 1.0], [0.0, 0.0, 1.0]])


def test_tangent_frame_of_an_axis_aligned_quad():
    t, sign = tangents.tangent_frame(QUAD, QUAD[..., :2], UP)
    np.testing.assert_allclose(t, [[1, 0, 0], [1, 0, 0]], atol=1e-6)
    np.testing.assert_array_equal(sign, [1.0, 1.0])
    # Mirrored in u: u = 1 - x, v = y -> tangent -x, bitangent sign -1.
    mirrored = np.stack([1.0 - QUAD[..., 0], QUAD[..., 1]], -1)
    t, sign = tangents.tangent_frame(QUAD, mirrored, UP)
    np.testing.assert_allclose(t, [[-1, 0, 0], [-1, 0, 0]], atol=1e-6)
    np.testing.assert_array_equal(sign, [-1.0, -1.0])
    # Mirrored in v: u = x, v = -y -> tangent +x, sign -1.
    t, sign = tangents.tangent_frame(QUAD, QUAD[..., :2] * [1, -1], UP)
    np.testing.assert_allclose(t, [[1, 0, 0], [1, 0, 0]], atol=1e-6)
    np.testing.assert_array_equal(sign, [-1.0, -1.0])
    # Rotated UV: u = y, v = -x -> tangent +y; dP/dv = -x = cross(z, y), sign +1.
    t, sign = tangents.tangent_frame(QUAD, np.stack([QUAD[..., 1], -QUAD[..., 0]], -1), UP)
    np.testing.assert_allclose(t, [[0, 1, 0], [0, 1, 0]], atol=1e-6)
    np.testing.assert_array_equal(sign, [1.0, 1.0])


def test_tangent_is_orthogonal_to_a_tilted_normal():
    n = np.array([[0.3, 0.0, 1.0], [0.0, 0.4, 1.0]])
    n /= np.linalg.norm(n, axis=-1, keepdims=True)
    t, sign = tangents.tangent_frame(QUAD, QUAD[..., :2], n)
    np.testing.assert_allclose(np.sum(t * n, -1), 0.0, atol=1e-6)
    np.testing.assert_allclose(np.linalg.norm(t, axis=-1), 1.0, atol=1e-6)
    assert (t[:, 0] > 0.9).all() and (sign == 1).all()
    # Zero-area UVs: still a unit tangent perpendicular to n.
    t, sign = tangents.tangent_frame(QUAD, np.zeros((2, 3, 2)), n)
    np.testing.assert_allclose(np.sum(t * n, -1), 0.0, atol=1e-6)
    np.testing.assert_allclose(np.linalg.norm(t, axis=-1), 1.0, atol=1e-6)


def test_normal_map_node_tangent_space():
    n = np.array([[0.0, 0.0, 1.0]] * 4)
    t = np.array([[1.0, 0.0, 0.0]] * 4)
    sign = np.ones(4)
    flat = tangents.apply_normal_map(n, t, sign, [[0.5, 0.5, 1.0]] * 4)
    np.testing.assert_allclose(flat, n, atol=1e-6)
    # (1, 0.5, 0.5) -> c = (1, 0, 0): the tangent; (0.5, 1, 0.5): the bitangent cross(n, t) = +y.
    out = tangents.apply_normal_map(n, t, sign, [[1.0, 0.5, 0.5], [0.5, 1.0, 0.5],
                                                [0.5, 0.0, 0.5], [1.0, 0.5, 1.0]])
    s = math.sqrt(0.5)
    np.testing.assert_allclose(out, [[1, 0, 0], [0, 1, 0], [0, -1, 0], [s, 0, s]], atol=1e-6)
    out = tangents.apply_normal_map(n, t, -sign, [[0.5, 1.0, 0.5]] * 4)
    np.testing.assert_allclose(out, [[0, -1, 0]] * 4, atol=1e-6)
    # Strength (Cycles, Blender 4.x/5.x): c_xy *= s, c_z = mix(1, c_z, clamp(s, 0, 1)).
    # s = 0 -> n; s = 0.5 with c = (1, 0, 0) -> normalize(0.5 t + 0.5 n); s = 2 with
    # c = (0.6, 0, 0.8) -> normalize(1.2 t + 0.8 n).
    rgb = [[1.0, 0.5, 0.5], [1.0, 0.5, 0.5], [0.8, 0.5, 0.9], [0.2, 0.7, 0.6]]
    out = tangents.apply_normal_map(n, t, sign, rgb, strength=[0.0, 0.5, 2.0, 0.0])
    c = math.hypot(1.2, 0.8)
    np.testing.assert_allclose(out, [[0, 0, 1], [s, 0, s], [1.2 / c, 0, 0.8 / c], [0, 0, 1]],
                               atol=1e-6)
    assert out.dtype == np.float32


# --- equirectangular mapping -----------------------------------------------------------------

# Measured with Cycles renders of a world Environment Texture whose texels encode their own UV
# (tests/blender/test_environment_mapping.py, Blender 4.5 and 5.0): +X (0.5, 0.5),
# +Y (0.25, 0.5), -X (0.0, 0.5), -Y (0.75, 0.5) exactly with Linear interpolation; v -> 1 at +Z
# (top row) and v -> 0 at -Z (bottom row), measured 1 degree off the poles. u at a pole is
# undefined; the formula gives 0.5 (atan2(0, 0) = 0).
MEASURED = {
    (1.0, 0.0, 0.0): (0.5, 0.5),
    (0.0, 1.0, 0.0): (0.25, 0.5),
    (-1.0, 0.0, 0.0): (0.0, 0.5),
    (0.0, -1.0, 0.0): (0.75, 0.5),
    (0.0, 0.0, 1.0): (None, 1.0),
    (0.0, 0.0, -1.0): (None, 0.0),
}


@pytest.mark.parametrize("direction", list(MEASURED))
def test_equirect_uv_of_the_axes_matches_cycles(direction):
    u, v = texture.direction_to_equirect_uv(np.array([direction]))[0]
    mu, mv = MEASURED[direction]
    assert v == pytest.approx(mv, abs=1e-6)
    if mu is not None:
        assert (u - mu + 0.5) % 1.0 - 0.5 == pytest.approx(0.0, abs=1e-6)  # u = 0 and 1 meet


def test_equirect_round_trip_and_shapes():
    d = RNG.normal(size=(100, 3))
    d /= np.linalg.norm(d, axis=-1, keepdims=True)
    uv = texture.direction_to_equirect_uv(d)
    assert uv.shape == (100, 2) and uv.dtype == np.float32
    assert ((uv >= 0) & (uv <= 1)).all()
    back = texture.equirect_uv_to_direction(uv)
    assert back.dtype == np.float32
    np.testing.assert_allclose(back, d, atol=1e-5)
    # Scaled directions map to the same UV; the top row (v = 1) is +Z.
    np.testing.assert_allclose(texture.direction_to_equirect_uv(3.0 * d), uv, atol=1e-6)
    np.testing.assert_allclose(texture.equirect_uv_to_direction([[0.3, 1.0]]), [[0, 0, 1]],
                               atol=1e-6)
    grid = texture.equirect_uv_to_direction(np.zeros((4, 5, 2)))
    assert grid.shape == (4, 5, 3)
