"""Blender lamps as the core's ``Light``: power and colour as Cycles reads them, an area
light's size and emitting area, and the Euler rotations of mapping nodes.
"""

from __future__ import annotations

import numpy as np

from ..core import scene as cs


def area_light_size(data, matrix: np.ndarray) -> np.ndarray:
    """(2,) metres: an area light's Size (X) and Size Y (Size for squares and discs), times
    its object's scale along X and Y, as Cycles sizes it."""
    square = data.shape in {"SQUARE", "DISK"}
    scale = np.linalg.norm(np.asarray(matrix, np.float64)[:3, :2], axis=0)
    return np.array([data.size, data.size if square else data.size_y]) * scale


def _emitter_area(data, matrix: np.ndarray) -> float:
    """The area Cycles divides a light's power by when Normalize is on: a sphere's surface
    (point, spot), the disc of the sun's cone on the unit sphere, an area light's surface
    (m^2). Measured against Cycles (``test_lights``): a light of no size has 1, but a point or
    spot of radius 0 has 4."""
    if data.type in {"POINT", "SPOT"}:
        radius = float(data.shadow_soft_size)
        return 4.0 * np.pi * radius ** 2 if radius > 0.0 else 4.0
    if data.type == "SUN":
        area = np.pi * np.sin(float(data.angle) / 2.0) ** 2
    else:
        area = float(np.prod(area_light_size(data, matrix)))
        area *= np.pi / 4.0 if data.shape in {"DISK", "ELLIPSE"} else 1.0
    return area if area > 0.0 else 1.0


def light_color(data, matrix: np.ndarray) -> np.ndarray:
    """(3,) float32 colour times power of a Blender light placed by ``matrix`` (4, 4), as
    Cycles reads it: Color (times the blackbody colour of Temperature when it is on) x Power x
    2^Exposure; with Normalize off, times the light's area as well (its power then grows with
    its size)."""
    color = np.array(data.color[:3], np.float64)
    if getattr(data, "use_temperature", False):
        color *= np.array(data.temperature_color[:3], np.float64)
    power = float(data.energy) * 2.0 ** float(getattr(data, "exposure", 0.0))
    if not getattr(data, "normalize", True):
        power *= _emitter_area(data, matrix)
    return (color * power).astype(np.float32)


def blender_light(obj, matrix: np.ndarray) -> cs.Light:
    data = obj.data
    axis = -matrix[:3, 2]
    axis = axis / max(np.linalg.norm(axis), 1e-20)
    light = cs.Light(
        kind=data.type,
        color=light_color(data, matrix),
        position=matrix[:3, 3].copy(),
        direction=axis,
        shadow=bool(data.use_shadow),
        name=obj.name,
    )
    if data.type in {"POINT", "SPOT"}:
        light.radius = float(data.shadow_soft_size)
    if data.type == "SPOT":
        light.spot_size = float(data.spot_size)
        light.spot_blend = float(data.spot_blend)
    elif data.type == "SUN":
        light.radius = float(data.angle)
    elif data.type == "AREA":
        light.size = area_light_size(data, matrix)
    return light


def euler_xyz(rx: float, ry: float, rz: float) -> np.ndarray:
    """(3, 3) rotation of Blender's XYZ Euler angles (radians): Rz Ry Rx."""
    cx, sx, cy, sy, cz, sz = np.cos(rx), np.sin(rx), np.cos(ry), np.sin(ry), np.cos(rz), np.sin(rz)
    rot_x = np.array([[1, 0, 0], [0, cx, -sx], [0, sx, cx]])
    rot_y = np.array([[cy, 0, sy], [0, 1, 0], [-sy, 0, cy]])
    rot_z = np.array([[cz, -sz, 0], [sz, cz, 0], [0, 0, 1]])
    return rot_z @ rot_y @ rot_x
