"""What a frame holds in memory, and the words for running out of it.

A render keeps, per triangle, its corners and corner normals in world space (float32), its
material, object instance and a few flags, UVs and attributes where meshes have them, its
corners at each step of the shutter where it moves (motion blur), its Cryptomatte ids and
linking sets where wanted; per object instance its world-to-object matrix; per light a shadow
map (six faces, one for a spot,
up to four sun cascades). ``frame_bytes`` adds these up (the figure a message gives when
memory runs out: Blender's own memory and the render's transient buffers come on top).
"""

from __future__ import annotations

from ..system.machine import limit_note, size

__all__ = ["OutOfMemory", "frame_bytes", "out_of_memory"]

_PER_TRIANGLE = 36 + 36 + 4 + 4 + 3  # positions, normals, material, instance, flags
_PER_INSTANCE = 16 * 8 + 6 * 4  # world_to_object float64, texture space float32
_MAPS = {"POINT": 6, "AREA": 6, "SPOT": 1, "SUN": 4}  # faces or cascades at most


class OutOfMemory(MemoryError):
    """Memory ran out while a scene of ``triangles`` triangles (so far, with the batch being
    made) was read."""

    def __init__(self, triangles: int) -> None:
        super().__init__(f"{triangles:,} triangles")
        self.triangles = int(triangles)


def frame_bytes(scene) -> int:
    """Bytes the render of ``scene`` (a ``core.scene.Scene``) keeps for its geometry and
    shadow maps, the sky's dome included (an estimate: sun lights count four cascades)."""
    total = 0
    for m in scene.meshes:
        tris = len(m.positions)
        total += tris * _PER_TRIANGLE
        if m.uvs is not None:
            total += tris * 24
        total += sum(int(a.size) * 4 for a in m.attributes.values())
        if m.motion is not None:
            total += int(m.motion.size) * 4 + tris * 4  # the steps, and the triangle's row
        total += tris * 8 * len(scene.settings.cryptomatte)
        w2o = m.world_to_object
        total += (1 if w2o is None or w2o.ndim == 2 else len(w2o)) * _PER_INSTANCE
    if any(m.motion is not None for m in scene.meshes):  # each share's corners and normals
        from .motion_blur import SHUTTER_TIMES

        total += SHUTTER_TIMES * 72 * sum(len(m.positions) for m in scene.meshes)
    if any(light.receivers or light.blockers for light in scene.lights):
        total += sum(len(m.positions) for m in scene.meshes) * 16  # the linking sets
    res = int(scene.settings.shadow_resolution)
    for light in scene.lights:
        if light.shadow:
            total += _MAPS.get(light.kind, 6) * res * res * 4 * 17 // 16  # and the pyramid
    sky = int(scene.settings.sky_resolution)
    total += _dome_maps(scene) * sky * sky * 4 * 17 // 16
    return total


def _dome_maps(scene) -> int:
    """Shadow maps of the world's dome (``core.render.sky``): the directions the world sends light
    from."""
    if not scene.meshes or scene.probes is None:
        return 0
    from ..formulas.sh import fibonacci_directions, radiance_luminance

    count = max(0, int(scene.settings.sky_directions))
    lit = radiance_luminance(scene.probes.world_sh, fibonacci_directions(count)) > 0.0
    return int(lit.sum())


def out_of_memory(scene, error: MemoryError | None = None) -> str:
    """One line for a render that ran out of memory: what the frame of ``scene`` (a
    ``core.scene.Scene``, or None before it was read: then what ``error``, an
    ``OutOfMemory``, counted) needs, and the process's limit."""
    if scene is None:
        read = ""
        if isinstance(error, OutOfMemory):
            read = (f": its {error.triangles:,} triangles need about "
                    f"{size(error.triangles * _PER_TRIANGLE)} beside Blender's own")
        return (f"BO2 Lighting ran out of memory reading the scene{read}{limit_note()}; hide "
                "or simplify objects, or render on a machine with more memory")
    tris = sum(len(m.positions) for m in scene.meshes)
    maps = sum(1 for light in scene.lights if light.shadow) + _dome_maps(scene)
    return (f"BO2 Lighting ran out of memory: {tris:,} triangles and {maps} shadow "
            f"map{'s' * (maps != 1)} need about "
            f"{size(frame_bytes(scene))} beside Blender's own{limit_note()}; lower "
            "the shadow resolution, hide or simplify objects, or render on a machine with more "
            "memory")
