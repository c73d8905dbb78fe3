"""Blender meshes as the core's triangle arrays: corners, normals, UV maps, attributes and
tangents of the triangles of an evaluated mesh, in object space, and their transform to world
space.
"""

from __future__ import annotations

import numpy as np

from ..core.formulas import tangents


def read_mesh(mesh, requires=frozenset(), warn=None, warn_ngons=None):
    """Object-space triangles of an evaluated mesh.

    requires: corner attributes the materials read (``core.scene.program.Program.requires``)
    warn:     called with the key of each attribute the mesh cannot give
    warn_ngons: called when n-gons leave a normal map with per-triangle tangents
    returns:  positions (T, 3, 3), corner normals (T, 3, 3), corner UVs of the active render
              UV map (T, 3, 2) or None, material slot (T,), attributes {key: (T, 3, k)}
    """
    mesh.calc_loop_triangles()
    tris = mesh.loop_triangles
    nt = len(tris)
    vert_idx = np.empty(nt * 3, np.int32)
    loop_idx = np.empty(nt * 3, np.int32)
    slot = np.empty(nt, np.int32)
    tris.foreach_get("vertices", vert_idx)
    tris.foreach_get("loops", loop_idx)
    tris.foreach_get("material_index", slot)
    co = np.empty(len(mesh.vertices) * 3, np.float32)
    mesh.vertices.foreach_get("co", co)
    corner = np.empty(len(mesh.corner_normals) * 3, np.float32)
    mesh.corner_normals.foreach_get("vector", corner)
    pos = co.reshape(-1, 3)[vert_idx].reshape(nt, 3, 3)
    nrm = corner.reshape(-1, 3)[loop_idx].reshape(nt, 3, 3)
    active = next((uv for uv in mesh.uv_layers if uv.active_render), None)
    uvs = _uv_layer(mesh, active, loop_idx, nt)
    attributes = {}
    for key in sorted(requires):
        kind, name = key
        if kind == "uv":
            layer = active if name == "" else mesh.uv_layers.get(name)
            value = _uv_layer(mesh, layer, loop_idx, nt)
        elif kind == "attribute":
            value = _attribute(mesh, name, vert_idx, loop_idx, tris, nt)
        else:
            value = _tangents(mesh, active if name == "" else mesh.uv_layers.get(name),
                              loop_idx, nt, pos, warn_ngons)
        if value is None:
            if warn is not None:
                warn(key)
            continue
        attributes[key] = value
    return pos, nrm, uvs, slot, attributes


def _uv_layer(mesh, layer, loop_idx, nt):
    if layer is None or len(layer.uv) != len(mesh.loops):
        return None
    flat = np.empty(len(mesh.loops) * 2, np.float32)
    layer.uv.foreach_get("vector", flat)
    return flat.reshape(-1, 2)[loop_idx].reshape(nt, 3, 2)


# data type -> (the property foreach_get reads, components)
_ATTRIBUTE_WIDTH = {"FLOAT": ("value", 1), "INT": ("value", 1), "INT8": ("value", 1),
                    "BOOLEAN": ("value", 1), "FLOAT2": ("vector", 2), "INT32_2D": ("value", 2),
                    "FLOAT_VECTOR": ("vector", 3), "FLOAT_COLOR": ("color", 4),
                    "BYTE_COLOR": ("color", 4)}


def _attribute(mesh, name, vert_idx, loop_idx, tris, nt):
    """(T, 3, 4) RGBA corner values of a mesh attribute (a value f as (f, f, f, 1), a vector as
    (x, y, z, 1), colours linear), as Cycles' Attribute node reads them; None if absent."""
    if name == "":
        attrs = mesh.color_attributes
        index = getattr(attrs, "render_color_index", -1)
        attr = attrs[index] if 0 <= index < len(attrs) else None
    else:
        attr = mesh.attributes.get(name)
    if attr is None or attr.data_type not in _ATTRIBUTE_WIDTH or attr.domain == "EDGE":
        return None
    kind, width = _ATTRIBUTE_WIDTH[attr.data_type]
    raw = np.empty(len(attr.data) * width, np.float32)
    if attr.data_type in ("INT", "INT8", "BOOLEAN", "INT32_2D"):
        ints = np.empty(len(attr.data) * width, bool if attr.data_type == "BOOLEAN" else np.int32)
        attr.data.foreach_get("value", ints)
        raw = ints.astype(np.float32)
    else:
        attr.data.foreach_get(kind, raw)
    raw = raw.reshape(-1, width)
    if attr.domain == "POINT":
        index = vert_idx
    elif attr.domain == "CORNER":
        index = loop_idx
    else:  # FACE
        poly = np.empty(nt, np.int32)
        tris.foreach_get("polygon_index", poly)
        index = np.repeat(poly, 3)
    values = raw[index]
    out = np.ones((nt * 3, 4), np.float32)
    if width == 1:
        out[:, :3] = values
    else:
        out[:, :width] = values
        if width == 2:
            out[:, 2] = 0.0
    return out.reshape(nt, 3, 4)


def _tangents(mesh, layer, loop_idx, nt, pos, warn_ngons=None):
    """(T, 3, 4) MikkTSpace tangents (object space) and bitangent signs of a UV map, as
    Blender computes them (``Mesh.calc_tangents``); None without that map. Blender computes
    them for triangles and quads only: a mesh with n-gons gets one tangent per triangle
    (``tangents.tangent_frame``) and ``warn_ngons`` is called."""
    if layer is None:
        return None
    try:
        mesh.calc_tangents(uvmap=layer.name)
    except RuntimeError:
        uvs = _uv_layer(mesh, layer, loop_idx, nt)
        if uvs is None:
            return None
        if warn_ngons is not None:
            warn_ngons()
        normal = np.cross(pos[:, 1] - pos[:, 0], pos[:, 2] - pos[:, 0])
        normal /= np.maximum(np.linalg.norm(normal, axis=-1, keepdims=True), 1e-30)
        tangent, sign = tangents.tangent_frame(pos, uvs, normal)
        out = np.concatenate([tangent, sign[:, None]], 1)
        return np.repeat(out[:, None], 3, axis=1).astype(np.float32)
    t = np.empty(len(mesh.loops) * 3, np.float32)
    sign = np.empty(len(mesh.loops), np.float32)
    mesh.loops.foreach_get("tangent", t)
    mesh.loops.foreach_get("bitangent_sign", sign)
    out = np.concatenate([t.reshape(-1, 3), sign[:, None]], 1)[loop_idx]
    return out.reshape(nt, 3, 4)


def to_world(pos, nrm, uvs, attributes: dict, matrix: np.ndarray):
    """Object-space triangles -> world space; mirrored matrices keep counter-clockwise fronts
    (the corners of every attribute reversed alike, bitangent signs turned)."""
    lin = matrix[:3, :3]
    det = np.linalg.det(lin)
    wpos = pos @ lin.T.astype(np.float32) + matrix[:3, 3].astype(np.float32)
    normal_matrix = np.linalg.inv(lin).T if abs(det) > 1e-20 else lin
    wn = nrm @ normal_matrix.T.astype(np.float32)
    wn /= np.maximum(np.linalg.norm(wn, axis=-1, keepdims=True), 1e-20)
    attributes = dict(attributes)
    for key, a in attributes.items():
        if key[0] == "tangent":
            t = a.copy()
            t[..., :3] = a[..., :3] @ lin.T.astype(np.float32)
            t[..., :3] /= np.maximum(np.linalg.norm(t[..., :3], axis=-1, keepdims=True), 1e-20)
            if det < 0:
                t[..., 3] = -t[..., 3]
            attributes[key] = t
    if det < 0:
        wpos, wn = wpos[:, ::-1], wn[:, ::-1]
        uvs = uvs[:, ::-1] if uvs is not None else None
        attributes = {k: a[:, ::-1] for k, a in attributes.items()}
    contiguous = (np.ascontiguousarray(a, np.float32) if a is not None else None
                  for a in (wpos, wn, uvs))
    return (*contiguous, {k: np.ascontiguousarray(a, np.float32) for k, a in attributes.items()})
