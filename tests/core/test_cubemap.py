"""Cube maps: face convention, texel directions, solid angles, direction -> texel, seamless
trilinear sampling, lat-long conversion and the source pyramid.

Independent values: the face table and texel formula written out by hand from the documented
convention; solid angles by midpoint quadrature of dOmega = da db / (1 + a^2 + b^2)^(3/2) and by
the Van Oosterom-Strackee formula for spherical triangles (the closed form the module uses is
Oehrstroem's area element); 4 pi; continuity checked by sampling both sides of each of the 12
edges and around each of the 8 corners; an analytic function of direction sampled into a
lat-long image and back.
"""

import itertools
import math

import numpy as np
import pytest

from bo2_lighting.addon.core.formulas import cubemap, texture

RNG = np.random.default_rng(11)

# The documented face table: rows (forward, right, up), face order +X, -X, +Y, -Y, +Z, -Z.
TABLE = np.array(
    [
        [[1, 0, 0], [0, -1, 0], [0, 0, 1]],
        [[-1, 0, 0], [0, 1, 0], [0, 0, 1]],
        [[0, 1, 0], [1, 0, 0], [0, 0, 1]],
        [[0, -1, 0], [-1, 0, 0], [0, 0, 1]],
        [[0, 0, 1], [-1, 0, 0], [0, 1, 0]],
        [[0, 0, -1], [-1, 0, 0], [0, -1, 0]],
    ],
    float,
)


def spec_direction(face, row, col, size):
    """Texel direction straight from the documented formula."""
    a = 2.0 * (col + 0.5) / size - 1.0
    b = 1.0 - 2.0 * (row + 0.5) / size
    f, r, u = TABLE[face]
    d = f + a * r + b * u
    return d / np.linalg.norm(d)


def spec_directions(size):
    """(6, S, S, 3) float64 texel directions from the documented formula."""
    out = np.empty((6, size, size, 3))
    for f, i, j in itertools.product(range(6), range(size), range(size)):
        out[f, i, j] = spec_direction(f, i, j, size)
    return out


def unit(v):
    v = np.asarray(v, float)
    return v / np.linalg.norm(v, axis=-1, keepdims=True)


# --- face table and texel directions ------------------------------------------------------


def test_faces_table_is_the_documented_convention():
    np.testing.assert_array_equal(cubemap.FACES, TABLE)
    assert cubemap.FACES.dtype == np.float64 and cubemap.FACES.shape == (6, 3, 3)
    axes = [[1, 0, 0], [-1, 0, 0], [0, 1, 0], [0, -1, 0], [0, 0, 1], [0, 0, -1]]
    for face, (fwd, right, up) in enumerate(cubemap.FACES):
        np.testing.assert_array_equal(fwd, axes[face])
        # A camera looking along forward with this up sees right to its right.
        np.testing.assert_array_equal(np.cross(fwd, up), right)
        np.testing.assert_allclose(np.stack([fwd, right, up]) @ np.stack([fwd, right, up]).T,
                                   np.eye(3))
    # Side faces are upright in Blender's Z-up world.
    for face in range(4):
        np.testing.assert_array_equal(cubemap.FACES[face, 2], [0, 0, 1])


def test_texel_directions_follow_the_formula():
    for size in (1, 3, 4, 7):
        d = cubemap.texel_directions(size)
        assert d.shape == (6, size, size, 3) and d.dtype == np.float32
        np.testing.assert_allclose(d, spec_directions(size), atol=2e-7)


def test_texel_directions_landmarks():
    d = cubemap.texel_directions(5)
    # The centre texel of each face looks along its forward axis.
    for face in range(6):
        np.testing.assert_allclose(d[face, 2, 2], TABLE[face, 0], atol=1e-7)
    np.testing.assert_allclose(d[0, 2, 2], [1, 0, 0], atol=1e-7)
    # Top row of a side face tilts towards +Z, bottom row towards -Z.
    np.testing.assert_allclose(d[0, 0, 2], unit([1, 0, 0.8]), atol=1e-7)
    for face in range(4):
        assert d[face, 0, 2, 2] > 0.6 and d[face, 4, 2, 2] < -0.6
        assert np.all(np.diff(d[face, :, 2, 2]) < 0)  # z decreases down the rows
    # On +X, columns go towards right = -Y; on +Z, the top row tilts towards +Y.
    assert d[0, 2, 4, 1] < -0.6 and d[0, 2, 0, 1] > 0.6
    assert d[4, 0, 2, 1] > 0.6 and d[4, 2, 4, 0] < -0.6
    # -Z, -Y, +Z form a vertical strip: the bottom row of +Z meets the top row of -Y.
    np.testing.assert_allclose(d[4, 4, 2], unit([0, -0.8, 1]), atol=1e-7)
    np.testing.assert_allclose(d[3, 0, 2], unit([0, -1, 0.8]), atol=1e-7)


# --- solid angles ---------------------------------------------------------------------------


def quadrature_solid_angle(size, row, col, n=400):
    """Midpoint rule of dOmega = da db / (1 + a^2 + b^2)^(3/2) over one texel."""
    a0 = -1.0 + 2.0 * col / size
    b0 = -1.0 + 2.0 * row / size
    h = 2.0 / size / n
    a = a0 + h * (np.arange(n) + 0.5)
    b = b0 + h * (np.arange(n) + 0.5)
    aa, bb = np.meshgrid(a, b)
    return float(np.sum((1.0 + aa * aa + bb * bb) ** -1.5) * h * h)


def triangle_solid_angle(a, b, c):
    """Van Oosterom & Strackee (1983): tan(Omega / 2) = |a.(b x c)| / (1 + a.b + b.c + c.a)."""
    a, b, c = unit(a), unit(b), unit(c)
    num = abs(np.dot(a, np.cross(b, c)))
    den = 1.0 + np.dot(a, b) + np.dot(b, c) + np.dot(c, a)
    return 2.0 * math.atan2(num, den)


def test_solid_angles_sum_to_four_pi():
    for size in (1, 2, 5, 16, 64):
        omega = cubemap.texel_solid_angles(size)
        assert omega.shape == (size, size) and omega.dtype == np.float64
        assert 6.0 * omega.sum() == pytest.approx(4.0 * np.pi, rel=1e-13)
        assert np.all(omega > 0)
    assert cubemap.texel_solid_angles(1)[0, 0] == pytest.approx(4.0 * np.pi / 6.0, rel=1e-14)


def test_solid_angles_match_quadrature_and_spherical_triangles():
    size = 8
    omega = cubemap.texel_solid_angles(size)
    for row, col in [(0, 0), (0, 7), (3, 4), (4, 4), (2, 6), (7, 1)]:
        assert omega[row, col] == pytest.approx(quadrature_solid_angle(size, row, col), rel=1e-5)
        # The texel's edges are great-circle arcs: two spherical triangles are exact.
        e = -1.0 + 2.0 * np.arange(size + 1) / size
        p00 = [1.0, e[col], e[row]]
        p01 = [1.0, e[col + 1], e[row]]
        p10 = [1.0, e[col], e[row + 1]]
        p11 = [1.0, e[col + 1], e[row + 1]]
        exact = triangle_solid_angle(p00, p01, p11) + triangle_solid_angle(p00, p11, p10)
        assert omega[row, col] == pytest.approx(exact, rel=1e-12)
    # Texels at a face centre are the largest, at the corners the smallest (ratio 3^1.5 limit).
    assert omega[0, 0] < omega[3, 3]


# --- direction -> face and texel ------------------------------------------------------------


def test_direction_to_face_inverts_the_texel_mapping():
    size = 6
    d = spec_directions(size)
    face, x, y = cubemap.direction_to_face(d.reshape(-1, 3), size)
    f, i, j = np.meshgrid(range(6), range(size), range(size), indexing="ij")
    np.testing.assert_array_equal(face, f.ravel())
    np.testing.assert_allclose(x, j.ravel() + 0.5, atol=1e-12)
    np.testing.assert_allclose(y, i.ravel() + 0.5, atol=1e-12)


def test_direction_to_face_round_trip_random_directions():
    v = RNG.normal(size=(5000, 3)) * RNG.uniform(0.1, 10.0, (5000, 1))
    face, x, y = cubemap.direction_to_face(v)  # size 1: coordinates in [0, 1]
    assert face.dtype == np.int64 and x.shape == (5000,)
    assert np.all((x >= 0) & (x <= 1) & (y >= 0) & (y <= 1))
    # The face is the largest absolute component, with its sign.
    axis = np.argmax(np.abs(v), axis=1)
    np.testing.assert_array_equal(face, 2 * axis + (v[np.arange(5000), axis] < 0))
    a = 2.0 * x - 1.0
    b = 1.0 - 2.0 * y
    back = TABLE[face, 0] + a[:, None] * TABLE[face, 1] + b[:, None] * TABLE[face, 2]
    np.testing.assert_allclose(unit(back), unit(v), atol=1e-12)
    # Scale matters only through the size argument.
    _, x8, y8 = cubemap.direction_to_face(v, 8)
    np.testing.assert_allclose(x8, 8 * x)
    np.testing.assert_allclose(y8, 8 * y)


def test_direction_to_face_degenerate_input():
    face, x, y = cubemap.direction_to_face([[0.0, 0.0, 0.0], [np.nan, 1.0, 0.0]], 4)
    np.testing.assert_array_equal(face, [0, 0])
    np.testing.assert_allclose(x, [2.0, 2.0])
    np.testing.assert_allclose(y, [2.0, 2.0])


# --- sampling -------------------------------------------------------------------------------


def random_chain(size, channels=2, seed=3):
    rng = np.random.default_rng(seed)
    chain = []
    while size >= 1:
        chain.append(rng.random((6, size, size, channels)).astype(np.float32))
        size //= 2
    return chain


def edges():
    """The 12 edges as (face i, face j): faces with perpendicular forward axes."""
    out = []
    for i, j in itertools.combinations(range(6), 2):
        if abs(np.dot(TABLE[i, 0], TABLE[j, 0])) < 0.5:
            out.append((i, j))
    assert len(out) == 12
    return out


def test_sample_reads_texel_centres_exactly():
    chain = random_chain(8)
    for m, level in enumerate(chain):
        s = level.shape[1]
        d = spec_directions(s).reshape(-1, 3)
        got = cubemap.sample(chain, d, np.full(len(d), float(m)))
        assert got.dtype == np.float32 and got.shape == (len(d), 2)
        np.testing.assert_allclose(got, level.reshape(-1, 2), atol=1e-6)
    # lod None reads level 0; a single array is a one-level chain.
    d = spec_directions(8).reshape(-1, 3)
    np.testing.assert_allclose(cubemap.sample(chain[0], d), chain[0].reshape(-1, 2), atol=1e-6)


def test_sample_interpolates_between_levels():
    chain = random_chain(4)
    d = unit(RNG.normal(size=(50, 3)))
    lo = cubemap.sample(chain, d, 1.0)
    hi = cubemap.sample(chain, d, 2.0)
    mid = cubemap.sample(chain, d, np.full(50, 1.25))
    np.testing.assert_allclose(mid, 0.75 * lo + 0.25 * hi, atol=1e-6)
    # Clamped beyond the chain; NaN reads the coarsest level.
    np.testing.assert_allclose(cubemap.sample(chain, d, 9.0), cubemap.sample(chain, d, 2.0))
    np.testing.assert_allclose(cubemap.sample(chain, d, np.nan), cubemap.sample(chain, d, 2.0))


@pytest.mark.parametrize("lod_offset", [0.0, 0.4])
def test_sample_is_continuous_across_all_edges_at_every_mip(lod_offset):
    # Random texels: any seam, wrong neighbour or flipped edge shows as a jump.
    chain = random_chain(16)
    eps = 1e-7
    t = np.linspace(-0.999, 0.999, 301)
    for m in range(len(chain)):
        lod = min(m + lod_offset, len(chain) - 1)
        for i, j in edges():
            fi, fj = TABLE[i, 0], TABLE[j, 0]
            along = np.cross(fi, fj)
            p = fi + fj + t[:, None] * along  # on the edge: on both faces
            side_i = p + eps * (fi - fj)
            side_j = p - eps * (fi - fj)
            assert np.all(cubemap.direction_to_face(side_i)[0] == i)
            assert np.all(cubemap.direction_to_face(side_j)[0] == j)
            vi = cubemap.sample(chain, side_i, lod)
            vj = cubemap.sample(chain, side_j, lod)
            np.testing.assert_allclose(vi, vj, atol=1e-4, err_msg=f"edge {i}-{j} lod {lod}")


def test_sample_is_continuous_around_all_corners_at_every_mip():
    chain = random_chain(16)
    eps = 1e-7
    for m, level in enumerate(chain):
        s = level.shape[1]
        for signs in itertools.product((1.0, -1.0), repeat=3):
            c = np.array(signs)
            # One point just inside each of the three faces meeting at the corner, and rings of
            # points around the corner in every face.
            pts = []
            for axis in range(3):
                q = c.copy()
                q[[k for k in range(3) if k != axis]] *= 1.0 - eps
                pts.append(q)
            vals = cubemap.sample(chain, np.array(pts), float(m))
            np.testing.assert_allclose(vals, vals[[0, 0, 0]], atol=1e-4)
            # At the corner: the mean of the three corner texels.
            corner_texels = []
            for q in pts:
                face, x, y = cubemap.direction_to_face(q[None], s)
                corner_texels.append(level[face[0], min(int(y[0]), s - 1), min(int(x[0]), s - 1)])
            np.testing.assert_allclose(vals[0], np.mean(corner_texels, axis=0), atol=1e-4)


def test_sample_smooth_function_is_smooth_everywhere():
    # The x component of the direction, stored at texel centres: bilinear sampling must
    # reproduce it to O(texel^2) everywhere, near edges and corners too (no seams).
    size = 32
    d = spec_directions(size).astype(np.float32)
    chain = [d[..., :1]]
    while chain[-1].shape[1] > 1:
        chain.append(cubemap.downsample(chain[-1]))
    v = unit(RNG.normal(size=(20000, 3)))
    corners = unit(np.array(list(itertools.product((1.0, -1.0), repeat=3))) * [1, 1, 0.999])
    v = np.concatenate([v, corners])
    got = cubemap.sample(chain, v)[:, 0]
    assert np.max(np.abs(got - v[:, 0])) < 4.0 / size**2 * 4
    # Along a path crossing the +X/+Z edge, consecutive samples move by a bounded step.
    s = np.linspace(-0.2, 0.2, 2001)
    path = unit(np.stack([np.ones_like(s), 0.3 + 0 * s, 1.0 + s], axis=1))
    for lod in (0.0, 1.5, 3.0):
        vals = cubemap.sample(chain, path, lod)[:, 0]
        steps = np.abs(np.diff(vals))
        assert steps.max() < 5.0 * np.median(steps) + 1e-6


# --- building cube maps ---------------------------------------------------------------------


def analytic(d):
    d = unit(d)
    x, y, z = d[..., 0], d[..., 1], d[..., 2]
    return 1.0 + 0.5 * x + 0.3 * y * y - 0.2 * z + 0.25 * x * z


def latlong_image(fn, height, width):
    """Lat-long image of fn(direction) at pixel centres (Blender's Environment Texture)."""
    v = 1.0 - (np.arange(height) + 0.5) / height
    u = (np.arange(width) + 0.5) / width
    uu, vv = np.meshgrid(u, v)
    d = texture.equirect_uv_to_direction(np.stack([uu, vv], -1)).astype(np.float64)
    return fn(d)


def test_equirect_to_cube_of_an_analytic_function():
    image = latlong_image(analytic, 256, 512)[..., None].astype(np.float32)
    for size in (8, 32, 128):
        cube = cubemap.equirect_to_cube(image, size)
        assert cube.shape == (6, size, size, 1) and cube.dtype == np.float32
        expect = analytic(spec_directions(size))
        assert np.max(np.abs(cube[..., 0] - expect)) < 0.01, size


def test_equirect_to_cube_orientation():
    # A narrow blob around each axis lands at the centre of the matching face.
    for face, axis in enumerate(TABLE[:, 0]):
        image = latlong_image(lambda d, a=axis: np.exp(-80.0 * (1.0 - unit(d) @ a)), 128, 256)
        cube = cubemap.equirect_to_cube(image, 9)
        assert np.unravel_index(np.argmax(cube[..., 0]), cube.shape[:3]) == (face, 4, 4)


def test_equirect_to_cube_does_not_alias():
    # One-pixel stripes in u and in v: a small cube must see their mean, not a sample of them.
    h, w = 256, 512
    stripes_u = np.tile((np.arange(w) % 2).astype(np.float32), (h, 1))
    stripes_v = np.tile((np.arange(h) % 2).astype(np.float32)[:, None], (1, w))
    for image in (stripes_u, stripes_v):
        cube = cubemap.equirect_to_cube(image, 16)
        assert cube.shape == (6, 16, 16, 1)
        err = cube - 0.5
        # Point sampling would give errors of 0.5; trilinear filtering leaves a little ripple.
        assert np.max(np.abs(err)) < 0.1 and np.mean(np.abs(err)) < 0.01


def test_equirect_to_cube_channels():
    image = RNG.random((64, 128, 4)).astype(np.float32)
    cube = cubemap.equirect_to_cube(image, 8)
    assert cube.shape == (6, 8, 8, 4)
    # The mean over the sphere is kept (up to filtering): both are solid-angle averages.
    omega = cubemap.texel_solid_angles(8)
    cube_mean = np.einsum("fijc,ij->c", cube, omega) / (4 * np.pi)
    lat = (np.arange(64) + 0.5) / 64 * np.pi
    row_w = np.sin(lat)[:, None, None]
    image_mean = (image * row_w).sum(axis=(0, 1)) / (row_w.sum() * 128)
    np.testing.assert_allclose(cube_mean, image_mean, atol=0.01)


def test_downsample_keeps_the_integral_and_constants():
    cube = RNG.random((6, 16, 16, 3)).astype(np.float32)
    half = cubemap.downsample(cube)
    assert half.shape == (6, 8, 8, 3) and half.dtype == np.float32
    integral = np.einsum("fijc,ij->c", cube, cubemap.texel_solid_angles(16))
    integral_half = np.einsum("fijc,ij->c", half, cubemap.texel_solid_angles(8))
    np.testing.assert_allclose(integral_half, integral, rtol=1e-5)
    # Each coarse texel is the solid-angle weighted mean of its 2 x 2 block.
    omega = cubemap.texel_solid_angles(16)
    block = cube[2, 4:6, 6:8]
    expect = np.einsum("ijc,ij->c", block, omega[4:6, 6:8]) / omega[4:6, 6:8].sum()
    np.testing.assert_allclose(half[2, 2, 3], expect, rtol=1e-5)
    const = np.full((6, 8, 8, 2), 0.7, np.float32)
    pyramid = cubemap.build_pyramid(const)
    assert [p.shape[1] for p in pyramid] == [8, 4, 2, 1]
    for level in pyramid:
        np.testing.assert_allclose(level, 0.7, rtol=1e-6)
    with pytest.raises(ValueError):
        cubemap.downsample(np.zeros((6, 3, 3, 1), np.float32))
