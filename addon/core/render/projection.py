"""Triangles through a camera's matrix into clip space: all at once (``project``), or a part at a
time for inputs too large to hold projected (``Projection``).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = ["CHUNK", "Projection", "project"]

CHUNK = 1 << 17  # triangles projected (and set up) at once from a large input


@dataclass
class Projection:
    """Triangles ``positions`` (T, 3, 3) through the 4 x 4 ``matrix`` into clip space as
    ``dtype`` (``project``), a part at a time: ``rasterize`` takes it in place of the clip
    array, so that the clip coordinates of a large input never exist all at once."""

    positions: np.ndarray
    matrix: np.ndarray
    dtype: type = np.float64
    index: np.ndarray | None = None  # (K,) int64 the triangles of ``positions`` (None: all)

    def __len__(self) -> int:
        return len(self.positions) if self.index is None else len(self.index)

    def part(self, lo: int, hi: int) -> np.ndarray:
        """(hi - lo, 3, 4) clip coordinates of triangles lo to hi (of ``index``)."""
        rows = self.positions[lo:hi] if self.index is None else self.positions[self.index[lo:hi]]
        return project(rows, self.matrix, self.dtype)

    def survivors(self) -> Projection:
        """This projection of the triangles that may touch the viewport only (``kernels.raster.
        survivors``, a chunk at a time): ``index`` says which."""
        from ..kernels import raster as kernels

        kept = []
        for lo in range(0, len(self), CHUNK):
            part = self.part(lo, min(lo + CHUNK, len(self)))
            orig = np.empty(len(part), np.int64)
            count, _ = kernels.survivors(part, orig)
            kept.append(orig[:count] + lo)
        index = np.concatenate(kept) if kept else np.zeros(0, np.int64)
        if self.index is not None:
            index = self.index[index]
        return Projection(self.positions, self.matrix, self.dtype, index)


def project(corners: np.ndarray, matrix: np.ndarray, dtype=np.float32) -> np.ndarray:
    """(T, 3, 4) clip-space corners of (T, 3, 3) world corners through a 4 x 4 matrix, each
    coordinate summed in float64 (``kernels.raster.project``) and stored as ``dtype``
    (float32 or float64)."""
    from ..kernels import raster as kernels

    corners = np.ascontiguousarray(corners, dtype)
    clip = np.empty(corners.shape[:2] + (4,), dtype)
    kernels.project(corners, np.ascontiguousarray(matrix, np.float64), clip)
    return clip
