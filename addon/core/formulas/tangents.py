"""Tangent space and normal maps.

Per-triangle tangents dP/du made orthogonal to the normal (Gram-Schmidt), the bitangent sign
from the UV winding, as in MikkTSpace (Mikkelsen 2008, "Simulation of wrinkled surfaces
revisited"); Blender uses MikkTSpace's per-vertex tangents, the per-triangle tangent here is an
approximation that agrees on flat regions. The Normal Map node, Tangent Space mode, as in
Cycles ``svm_node_normal_map`` (Blender 4.x and 5.x).
"""

from __future__ import annotations

import numpy as np

__all__ = ["apply_normal_map", "tangent_frame"]


def _any_perpendicular(n: np.ndarray) -> np.ndarray:
    """(N, 3) unit vectors perpendicular to unit normals n (Duff et al. 2017, branchless ONB)."""
    sign = np.where(n[:, 2] >= 0.0, 1.0, -1.0)
    a = -1.0 / (sign + n[:, 2])
    b = n[:, 0] * n[:, 1] * a
    return np.stack([1.0 + sign * n[:, 0] * n[:, 0] * a, sign * b, -sign * n[:, 0]], -1)


def tangent_frame(tri_positions, tri_uvs, normals) -> tuple[np.ndarray, np.ndarray]:
    """Per-triangle tangent-space frame for tangent-space normal maps.

    The tangent is dP/du of the triangle, made orthogonal to the per-point normal
    (Gram-Schmidt); the bitangent is sign * cross(normal, tangent), where the sign is +1 when
    dP/dv points along cross(normal, tangent) and -1 for mirrored UVs (MikkTSpace convention,
    Mikkelsen 2008). Blender computes MikkTSpace per-vertex tangents; one tangent per triangle
    is an approximation that matches on flat regions and at UV-continuous flat quads.

    tri_positions: (N, 3, 3) world-space corners of the triangle under each point
    tri_uvs:       (N, 3, 2) corner UVs
    normals:       (N, 3) unit shading normals at the points
    returns:       tangent (N, 3) float32 unit, orthogonal to the normal; bitangent_sign (N,)
                   float32 in {-1, +1}. Zero-area UV triangles give an arbitrary tangent
                   perpendicular to the normal and sign +1.
    """
    p = np.asarray(tri_positions, np.float64).reshape(-1, 3, 3)
    t = np.asarray(tri_uvs, np.float64).reshape(-1, 3, 2)
    n = np.asarray(normals, np.float64).reshape(-1, 3)
    n = n / np.maximum(np.linalg.norm(n, axis=-1, keepdims=True), 1e-30)
    e1 = p[:, 1] - p[:, 0]
    e2 = p[:, 2] - p[:, 0]
    du1, dv1 = t[:, 1, 0] - t[:, 0, 0], t[:, 1, 1] - t[:, 0, 1]
    du2, dv2 = t[:, 2, 0] - t[:, 0, 0], t[:, 2, 1] - t[:, 0, 1]
    det = du1 * dv2 - du2 * dv1
    # dP/du and dP/dv times det; dividing by det's sign keeps their orientation.
    sgn = np.where(det < 0.0, -1.0, 1.0)[:, None]
    dpdu = (e1 * dv2[:, None] - e2 * dv1[:, None]) * sgn
    dpdv = (e2 * du1[:, None] - e1 * du2[:, None]) * sgn
    tangent = dpdu - n * np.einsum("nc,nc->n", n, dpdu)[:, None]
    length = np.linalg.norm(tangent, axis=-1)
    uv_sizes = np.hypot(du1, dv1) * np.hypot(du2, dv2)
    # A UV triangle of (relative) zero area, or dP/du along the normal, has no usable tangent.
    good = (np.abs(det) > 1e-9 * uv_sizes) & (length > 1e-6 * np.linalg.norm(dpdu, axis=-1))
    tangent = np.where(
        good[:, None], tangent / np.where(good, length, 1.0)[:, None], _any_perpendicular(n)
    )
    sign = np.where(np.einsum("nc,nc->n", np.cross(n, tangent), dpdv) < 0.0, -1.0, 1.0)
    sign = np.where(good, sign, 1.0)
    return tangent.astype(np.float32), sign.astype(np.float32)


def apply_normal_map(normal, tangent, bitangent_sign, map_rgb, strength=1.0) -> np.ndarray:
    """Blender's Normal Map node in Tangent Space mode (Cycles ``svm_node_normal_map``).

    c = 2 rgb - 1; strength s scales the tangential part and blends the normal part:
    c_xy *= max(s, 0), c_z = 1 + (c_z - 1) clamp(s, 0, 1); then
    n' = normalize(c_x t + c_y b + c_z n) with b = sign cross(n, t). So s = 0 returns n and
    s = 1 the plain mapping (Cycles and EEVEE of Blender 4.x and 5.x; older releases blended the
    mapped normal with n instead). For a back face, Cycles maps with the front-facing normal
    and frame and negates the result: pass the front normal and negate the output.

    normal:         (N, 3) unit shading normal
    tangent:        (N, 3) unit tangent orthogonal to the normal (``tangent_frame``)
    bitangent_sign: (N,) +1 or -1
    map_rgb:        (N, 3) normal map colour in [0, 1], Non-Color data
    strength:       scalar or (N,) Strength input
    returns:        (N, 3) float32 unit normals; where the mapped vector vanishes, the input n
    """
    n = np.asarray(normal, np.float32).reshape(-1, 3)
    t = np.asarray(tangent, np.float32).reshape(-1, 3)
    sign = np.asarray(bitangent_sign, np.float32).reshape(-1, 1)
    c = 2.0 * np.asarray(map_rgb, np.float32).reshape(-1, 3) - 1.0
    s = np.asarray(strength, np.float32).reshape(-1, 1)
    cxy = c[:, :2] * np.maximum(s, 0.0)
    cz = 1.0 + (c[:, 2:] - 1.0) * np.clip(s, 0.0, 1.0)
    b = sign * np.cross(n, t)
    out = cxy[:, :1] * t + cxy[:, 1:] * b + cz * n
    length = np.linalg.norm(out, axis=-1, keepdims=True)
    ok = length > 1e-12
    return np.where(ok, out / np.where(ok, length, 1.0), n).astype(np.float32)
