"""One frame: rasterize -> look up materials -> shade direct light -> resolve samples.

Anti-aliasing: ``settings.samples`` sample positions per pixel from the R2 low-discrepancy
sequence (Roberts 2018), averaged with a one-pixel box filter; each sample is a full rasterize
and deferred-shade pass over the visible points only.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from . import raster, shade
from .scene import Scene


class Cancelled(Exception):
    """The host asked the render to stop."""


def sample_offsets(count: int) -> np.ndarray:
    """(count, 2) float64 sub-pixel sample positions in [0, 1)^2 (R2 sequence, Roberts 2018)."""
    if count == 1:
        return np.array([[0.5, 0.5]])
    g = 1.32471795724474602596  # plastic number: root of x^3 = x + 1
    a = np.array([1.0 / g, 1.0 / (g * g)])
    i = np.arange(count)[:, None]
    return (0.5 + a * i) % 1.0


def _gather_geometry(scene: Scene) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Concatenate all mesh batches: positions (T,3,3), normals (T,3,3), material (T,)."""
    if not scene.meshes:
        empty = np.zeros((0, 3, 3), np.float32)
        return empty, empty, np.zeros(0, np.int32)
    pos = np.concatenate([m.positions for m in scene.meshes]).astype(np.float32, copy=False)
    nrm = np.concatenate([m.normals for m in scene.meshes]).astype(np.float32, copy=False)
    mat = np.concatenate([m.material for m in scene.meshes]).astype(np.int32, copy=False)
    return pos, nrm, mat


def _drop_broken(positions, normals, mat_index, warn):
    """Remove triangles with non-finite corners or zero area; warn once with the counts."""
    finite = np.isfinite(positions).all(axis=(1, 2))
    with np.errstate(invalid="ignore", over="ignore"):
        cross = np.cross(positions[:, 1] - positions[:, 0], positions[:, 2] - positions[:, 0])
        area2 = np.einsum("tc,tc->t", cross, cross)
    flat = finite & ~(area2 > 0.0)
    keep = finite & ~flat
    if keep.all():
        return positions, normals, mat_index
    if warn is not None:
        warn(f"Skipped {int((~finite).sum())} triangles with NaN or infinite vertices and "
             f"{int(flat.sum())} with zero area")
    return positions[keep], np.nan_to_num(normals[keep]), mat_index[keep]


def render_frame(
    scene: Scene,
    progress: Callable[[float], None] | None = None,
    should_stop: Callable[[], bool] | None = None,
    warn: Callable[[str], None] | None = None,
) -> dict[str, np.ndarray]:
    """Render one frame.

    scene:       the frame's plain-data description
    progress:    called with the finished fraction in [0, 1]
    should_stop: polled between samples; returning True raises ``Cancelled``
    warn:        called once with a message when triangles are skipped (NaN or zero area)
    returns:     {"Combined": (H, W, 4) float32 RGBA scene-linear radiance, row 0 at the top}
    """
    cam = scene.camera
    h, w = cam.height, cam.width
    positions, normals, mat_index = _gather_geometry(scene)
    mats = scene.materials or []
    albedo_t = np.array([m.albedo for m in mats], np.float32).reshape(-1, 3)
    rf0_t = np.array([m.rf0 for m in mats], np.float32).reshape(-1, 3)
    gloss_t = np.array([m.gloss for m in mats], np.float32).reshape(-1)
    emit_t = np.array([m.emission for m in mats], np.float32).reshape(-1, 3)
    cull_t = np.array([m.backface_culling for m in mats], bool).reshape(-1)
    if len(positions) and (mat_index.max(initial=0) >= len(mats) or mat_index.min() < 0):
        raise ValueError("a triangle refers to a material index outside Scene.materials")

    positions, normals, mat_index = _drop_broken(positions, normals, mat_index, warn)
    view_proj = cam.projection @ cam.world_to_camera
    homog = np.concatenate([positions, np.ones(positions.shape[:2] + (1,), np.float32)], -1)
    clip = (homog.astype(np.float64) @ view_proj.T).astype(np.float32)
    cull = cull_t[mat_index] if len(mat_index) else None
    eye = cam.position.astype(np.float32)
    forward = cam.forward.astype(np.float32)

    background = np.zeros(4, np.float32)
    if not scene.settings.film_transparent:
        background[:3] = scene.world.color
        background[3] = 1.0
    accum = np.zeros((h, w, 4), np.float32)
    offsets = sample_offsets(max(1, int(scene.settings.samples)))
    for k, offset in enumerate(offsets):
        if should_stop is not None and should_stop():
            raise Cancelled()
        frags = raster.rasterize(clip, w, h, cull=cull, sample_offset=tuple(offset))
        hit = frags.tri >= 0
        sample = np.empty((h, w, 4), np.float32)
        sample[~hit] = background
        tri = frags.tri[hit]
        if tri.size:
            bary = frags.bary[hit]
            p = np.einsum("nk,nkc->nc", bary, positions[tri])
            n = np.einsum("nk,nkc->nc", bary, normals[tri])
            n /= np.maximum(np.linalg.norm(n, axis=-1, keepdims=True), 1e-20)
            if cam.orthographic:
                v = np.broadcast_to(-forward, p.shape).astype(np.float32)
            else:
                v = eye - p
                v /= np.maximum(np.linalg.norm(v, axis=-1, keepdims=True), 1e-20)
            # Seen from behind: shade the side facing the camera, as Cycles does.
            n = np.where((np.sum(n * v, -1) < 0)[:, None], -n, n)
            m = mat_index[tri]
            diffuse, specular = shade.shade_direct(
                p, n, v, albedo_t[m], rf0_t[m], gloss_t[m], scene.lights,
                model=scene.settings.specular_model,
            )
            sample[hit, :3] = diffuse + specular + emit_t[m]
            sample[hit, 3] = 1.0
        accum += sample
        if progress is not None:
            progress((k + 1) / len(offsets))
    accum /= len(offsets)
    return {"Combined": accum}
