"""The materials stage: what a material program reads at the visible points
(``material.Points``) and the talk's parameters it gives there (``material.SurfaceParams``):
constants from the frame's tables, programs evaluated per material over its points.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from ..formulas import env_brdf
from ..scene import Material, material, nodes
from .buffers import Frame


def material_points(frame: Frame, tri, bary, p, n, geo, v, sx, sy, shifts=True) -> material.Points:
    """What a material program reads at the points (``material.Points``): tri (N,), bary
    (N, 3), p, n, geo, v (N, 3) (``shade_points``), window positions sx, sy (N,)."""
    from ..kernels import shading

    cam = frame.scene.camera
    tri = np.ascontiguousarray(tri, np.int32)

    def interpolate(key, weights):
        corners = frame.uvs if key == ("uv", "") else frame.attributes.get(key)
        if corners is None:
            return None
        if not len(corners):  # no triangle has UVs
            return np.zeros((len(tri), corners.shape[2]), np.float32)
        out = np.empty((len(tri), corners.shape[2]), np.float32)
        shading.interpolate(tri, np.ascontiguousarray(weights, np.float32), corners, out)
        return out

    def window(x, y):
        return np.stack([x / cam.width, 1.0 - y / cam.height], 1).astype(np.float32)

    def moved(axis, step):
        x, y = sx() + step * (axis == 0), sy() + step * (axis == 1)
        origin, direction = cam.rays(x, y)
        b, q = np.empty((len(tri), 3), np.float32), np.empty((len(tri), 3), np.float32)
        # NaN where a ray runs along the plane: steps are then unknown, the coarsest mip level
        # is read and a bump keeps the normal
        shading.plane_hits(tri, frame.positions, origin, direction, b, q)
        return b, {"position": q, "window": lambda: window(x, y)}

    def part(a):  # the points' rows of a (N, ...) array, gathered when first read
        return a if callable(a) else (lambda: a)

    p, n, geo, v, sx, sy = (part(a) for a in (p, n, geo, v, sx, sy))
    fields = {
        "position": p, "normal": n, "geo": geo, "view": v,
        "backfacing": lambda: (np.einsum("nc,nc->n", geo(), face_normals(frame, tri))
                               < 0.0)[:, None].astype(np.float32),
        "world_to_object": lambda: frame.world_to_object[frame.obj[tri]],
        "texspace": lambda: frame.texspace[frame.obj[tri]],
        "window": lambda: window(sx(), sy()),
        "world_to_camera": cam.world_to_camera,
    }
    return material.Points(len(tri), bary, fields, interpolate, moved if shifts else None)


def face_normals(frame: Frame, tri) -> np.ndarray:
    """(N, 3) unnormalized front-face normals of triangles ``tri`` (counter-clockwise)."""
    q = frame.positions[tri]
    return np.cross(q[:, 1] - q[:, 0], q[:, 2] - q[:, 0])


def surface_params(frame: Frame, tri, bary, p, n, geo, v, sx, sy,
                   shifts=True, layered=True) -> material.SurfaceParams:
    """The talk's parameters at the points on triangles ``tri`` (N,): constants from the
    tables, programs evaluated per material over its points. The normal is the shading
    normal ``n`` unless a program changes it. With ``RenderSettings.layered_diffuse`` (and
    ``layered``: the lightmap bake weights the albedo its own way), the albedo under a
    specular layer is weighted by one less that layer's albedo toward ``v``
    (``env_brdf.diffuse_layering``)."""
    s = _surface_params(frame, tri, bary, p, n, geo, v, sx, sy, shifts)
    if (not layered or not frame.scene.settings.layered_diffuse or s.layer is None
            or not s.layer.any()):
        return s
    n_dot_v = np.einsum("nc,nc->n", s.normal, v)
    keep = env_brdf.diffuse_layering(s.layer, s.layer_f0, s.gloss, n_dot_v)
    return dataclasses.replace(s, albedo=(s.albedo * keep[:, None]).astype(np.float32))


def _surface_params(frame: Frame, tri, bary, p, n, geo, v, sx, sy,
                    shifts) -> material.SurfaceParams:
    mid = frame.material[tri]
    t = frame.tables
    mats = frame.scene.materials or [Material()]
    varying = np.flatnonzero(t["varying"])
    if len(varying) and len(mid) and (mid == mid[0]).all() and t["varying"][mid[0]]:
        # one textured material over the whole block: its program alone, nothing gathered
        s = material.evaluate(mats[mid[0]].program,
                              material_points(frame, tri, bary, p, n, geo, v, sx, sy, shifts))
        return s if s.normal is not None else dataclasses.replace(s, normal=n)
    albedo, rf0 = t["albedo"][mid], t["rf0"][mid]
    emission, gloss, alpha = t["emission"][mid], t["gloss"][mid, 0], t["alpha"][mid, 0]
    shadow_alpha = t["shadow_alpha"][mid, 0]
    layered = frame.scene.settings.layered_diffuse  # the layer is gathered only when read
    layer, layer_f0 = ((t["layer"][mid, 0], t["layer_f0"][mid, 0]) if layered
                       else (None, None))
    normal = n
    occlusion = t["occlusion"][mid, 0] if (t["occlusion"] < 1.0).any() else None
    for m in varying:
        sel = np.flatnonzero(mid == m)
        if not len(sel):
            continue
        rows = [lambda a=a, sel=sel: a[sel] for a in (p, n, geo, v, sx, sy)]
        pts = material_points(frame, tri[sel], bary[sel], *rows, shifts)
        s = material.evaluate(mats[m].program, pts)
        albedo[sel], rf0[sel], emission[sel] = s.albedo, s.rf0, s.emission
        gloss[sel], alpha[sel] = s.gloss, s.alpha
        shadow_alpha[sel] = s.alpha if s.shadow_alpha is None else s.shadow_alpha
        if layered:
            layer[sel], layer_f0[sel] = s.layer, s.layer_f0
        if s.normal is not None:
            normal = normal.copy() if normal is n else normal
            normal[sel] = s.normal
        if s.occlusion is not None:
            occlusion = np.ones(len(tri), np.float32) if occlusion is None else occlusion
            occlusion[sel] = s.occlusion
    return material.SurfaceParams(albedo, rf0, gloss, emission, alpha, normal, occlusion,
                                  layer, layer_f0, shadow_alpha)


def surface_alpha(frame: Frame, tri, bary, sx, sy) -> np.ndarray:
    """(N,) the surfaces' alpha at the points on triangles ``tri``."""
    from ..kernels import shading

    m = len(tri)
    p, n, geo = (np.empty((m, 3), np.float32) for _ in range(3))
    uv = np.empty((m, 2), np.float32)
    _, d = frame.scene.camera.rays(sx, sy)
    shading.surface(np.ascontiguousarray(tri, np.int32), np.ascontiguousarray(bary, np.float32),
                    frame.positions, frame.normals, frame.uvs, -d, p, n, geo, uv)
    return _surface_params(frame, tri, bary, p, n, geo, -d, sx, sy, True).alpha


def caster_alpha(frame: Frame, tri, bary) -> np.ndarray:
    """(N,) alpha of shadow casters at shadow-map texels (triangles ``tri``, weights ``bary``)."""
    q = frame.positions[tri]
    p = np.einsum("nk,nkc->nc", bary, q).astype(np.float32)
    n = nodes.unit_vectors(np.einsum("nk,nkc->nc", bary, frame.normals[tri]))
    geo = nodes.unit_vectors(np.cross(q[:, 1] - q[:, 0], q[:, 2] - q[:, 0]))
    zero = np.zeros(len(tri), np.float32)
    s = _surface_params(frame, tri, bary, p, n, geo, geo, zero, zero, False)
    return s.alpha if s.shadow_alpha is None else s.shadow_alpha


def surface_aovs(frame: Frame, tri, bary, p, n, geo, v, sx, sy) -> np.ndarray:
    """The shader AOVs of ``RenderSettings.aovs`` at the points on triangles ``tri`` (N,)
    (arguments as ``surface_params``): (N, C) float32 side by side
    (``material.evaluate_aovs``)."""
    wanted = frame.scene.settings.aovs
    mid = frame.material[tri]
    mats = frame.scene.materials or [Material()]
    width = sum(4 if kind == "COLOR" else 1 for _, kind in wanted)
    out = np.zeros((len(tri), width), np.float32)
    for m in np.unique(mid):
        if not mats[m].program.aovs:
            continue
        sel = np.flatnonzero(mid == m)
        pts = material_points(frame, tri[sel], bary[sel], p[sel], n[sel], geo[sel], v[sel],
                              sx[sel], sy[sel])
        out[sel] = material.evaluate_aovs(mats[m].program, pts, wanted)
    return out
