"""Small matrix work done term by term, without BLAS or LAPACK.

NumPy hands matrix products and inverses to OpenBLAS, which spreads even a 4 x 4 inverse over
its own threads; those threads then spin for a while after every call, taking a core from the
render's tile threads (a probe capture of 16 x 16 faces ran 30% slower for it). Everything that
runs per tile or per shaded point goes through these functions instead.
"""

from __future__ import annotations

import numpy as np


def inverse(matrix) -> np.ndarray:
    """Inverse of a square matrix (4 x 4 here) by Gauss-Jordan elimination with partial
    pivoting, float64. Raises ``np.linalg.LinAlgError`` for a singular matrix; NaN spreads,
    as with ``np.linalg.inv``."""
    a = np.array(matrix, np.float64)
    n = len(a)
    inv = np.eye(n)
    for col in range(n):
        pivot = col + int(np.argmax(np.abs(a[col:, col])))
        if a[pivot, col] == 0.0:
            raise np.linalg.LinAlgError("Singular matrix")
        a[[col, pivot]], inv[[col, pivot]] = a[[pivot, col]], inv[[pivot, col]]
        scale = 1.0 / a[col, col]
        a[col] *= scale
        inv[col] *= scale
        for row in range(n):
            if row != col and a[row, col] != 0.0:
                f = a[row, col]
                a[row] -= f * a[col]
                inv[row] -= f * inv[col]
    return inv


def linear(points: np.ndarray, rows) -> np.ndarray:
    """``points @ rows.T`` term by term: points (..., 3), rows (K, 3) -> (..., K), in the
    points' dtype."""
    p = np.asarray(points)
    r = np.asarray(rows, p.dtype)
    return p[..., :1] * r[:, 0] + p[..., 1:2] * r[:, 1] + p[..., 2:3] * r[:, 2]


def transform(points: np.ndarray, matrix) -> np.ndarray:
    """``points`` (..., 3) through the affine 4 x 4 ``matrix``: (..., 3) in the points'
    dtype."""
    m = np.asarray(matrix, np.asarray(points).dtype)
    return linear(points, m[:3, :3]) + m[:3, 3]
