"""Term-by-term matrix work against NumPy's LAPACK and BLAS results."""

import numpy as np
import pytest

from bo2_lighting.addon.core.formulas import affine

RNG = np.random.default_rng(5)


def test_inverse_matches_lapack():
    for _ in range(200):
        m = RNG.normal(size=(4, 4)) * RNG.uniform(0.01, 100.0)
        np.testing.assert_allclose(affine.inverse(m) @ m, np.eye(4), atol=1e-9)
        np.testing.assert_allclose(affine.inverse(m), np.linalg.inv(m), rtol=1e-8, atol=1e-12)
    # a camera's projection times view, whose first pivot is 0
    proj = np.array([[1.5, 0, 0, 0], [0, 2.0, 0, 0], [0, 0, -1.002, -0.2002], [0, 0, -1, 0]])
    np.testing.assert_allclose(affine.inverse(proj), np.linalg.inv(proj), rtol=1e-12,
                               atol=1e-15)


def test_singular_matrix_is_refused():
    with pytest.raises(np.linalg.LinAlgError):
        affine.inverse(np.diag([1.0, 2.0, 0.0, 1.0]))
    assert np.isnan(affine.inverse(np.full((4, 4), np.nan))).all()  # as np.linalg.inv


def test_linear_and_transform_match_matrix_products():
    points = RNG.normal(size=(7, 5, 3)).astype(np.float32)
    rows = RNG.normal(size=(2, 3))
    got = affine.linear(points, rows)
    assert got.dtype == np.float32 and got.shape == (7, 5, 2)
    np.testing.assert_allclose(got, points @ rows.T.astype(np.float32), rtol=1e-5, atol=1e-6)
    m = np.eye(4)
    m[:3] = RNG.normal(size=(3, 4))
    p64 = points.astype(np.float64)
    np.testing.assert_allclose(affine.transform(p64, m), p64 @ m[:3, :3].T + m[:3, 3],
                               rtol=1e-12, atol=1e-12)
