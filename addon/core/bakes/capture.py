"""Capture the scene around a point as a cube map, with the engine's own pipeline.

Six 90-degree square views along the faces of ``cubemap.FACES``: emission, direct light with
shadows, the world seen as background, and the indirect light of the probes given (in a bake,
the previous bounce's). A pixel (row r, column c) of face f is the texel of
the same index in ``cubemap`` (direction forward + a right + b up, a and b the pixel centre's
coordinates in [-1, 1]).
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np

from ..formulas import cubemap
from ..lighting.probes import Probes
from ..render import pipeline
from ..render.buffers import mesh_flags, with_camera
from ..render.job import RenderJob
from ..render.shadow_maps import build_shadow_maps, dome_lit, shadow_map_count
from ..render.visibility import nearest_faces
from ..scene import Camera

__all__ = ["Capture", "Surfaces", "face_camera"]


def face_camera(position, face: int, size: int, near: float, far: float) -> Camera:
    """The 90-degree square camera of cube face ``face`` at ``position`` (3,), metres."""
    forward, right, up = (np.asarray(v, np.float64) for v in cubemap.FACES[face])
    view = np.eye(4)
    view[0, :3], view[1, :3], view[2, :3] = right, up, -forward
    view[:3, 3] = -view[:3, :3] @ np.asarray(position, np.float64)
    proj = np.array([[1.0, 0.0, 0.0, 0.0], [0.0, 1.0, 0.0, 0.0],
                     [0.0, 0.0, (far + near) / (near - far), 2.0 * far * near / (near - far)],
                     [0.0, 0.0, -1.0, 0.0]])
    return Camera(world_to_camera=view, projection=proj, width=size, height=size)


class Capture:
    """Renders cube maps of one scene at many points, its geometry and shadow maps prepared
    once for every view (the shadow maps when a cube map is first rendered, and again when
    the world's lit directions change, ``shadow_maps.dome_lit``).

    job:   the job of the scene (its camera and probes are ignored; its settings' samples and
           filter apply, the film is opaque and the border off), its stop and warning sink
    focus: the world box (lo (3,), hi (3,)) the captures see (``bake.capture_region``): the
           suns' shadow maps cover it, or every caster when None
    """

    def __init__(self, job: RenderJob, *, focus: tuple | None = None):
        # no contact occlusion: a few texels per face cannot hold it, and the probes' light is
        # occluded at the look-up (``occlusion``)
        scene = job.scene
        settings = dataclasses.replace(scene.settings, film_transparent=False, border=None,
                                       ambient_occlusion=False, nearest_reflections=False,
                                       cryptomatte=(), light_groups=(), aovs=())
        meshes = scene.meshes  # a shadow catcher is a surface like any other to the probes,
        # and they see the frame's own time (no motion blur)
        if any(m.shadow_catcher or m.motion is not None for m in meshes):
            meshes = [dataclasses.replace(m, shadow_catcher=False, motion=None) for m in meshes]
        self.scene = dataclasses.replace(scene, settings=settings, probes=None, meshes=meshes,
                                         camera=dataclasses.replace(scene.camera, motion=None))
        self.job, self.focus = job, focus
        self._frame = None  # the geometry, prepared once for every view
        # the dome directions its shadow maps were built for (``shadow_maps.dome_lit``; None:
        # no dome, for views without indirect light), or False before any: ``cube`` needs
        # them, ``surfaces`` not
        self._shadowed: tuple | None | bool = False
        self._seen: dict = {}  # per probe kind: ``Frame.seen`` of its captures

    def cube(self, position, size: int, near: float, far: float,
             probes: Probes | None = None, kind: str = "reflection") -> np.ndarray:
        """(6, size, size, 3) float32 radiance seen from ``position`` (3,), metres, between
        the clip distances ``near`` and ``far`` (metres), lit indirectly by ``probes``, for a
        probe of ``kind`` ("reflection": a Sphere probe's, "irradiance": a Volume's; the
        objects hidden from such probes are not seen, ``MeshBatch.sphere_probes``)."""
        cams = self._cameras(position, size, near, far)
        dome = None
        if probes is not None:  # the world's light is occluded by the dome's maps
            count = shadow_map_count(self._frame.scene, sky=True)
            dome = tuple(dome_lit(self._frame.scene, count - len(self.scene.lights),
                                  probes.world_sh))
        if self._shadowed is False or self._shadowed != dome:
            self._frame.shadow_maps = build_shadow_maps(
                self.job, self._frame, fit_shadows=False, focus=self.focus,
                sky=dome is not None, world_sh=None if probes is None else probes.world_sh)
            self._shadowed = dome
        frame = dataclasses.replace(self._frame, seen=self._seen[kind], scene=dataclasses.replace(
            self._frame.scene, camera=cams[0], probes=probes))  # each view projects its own
        faces = pipeline.render_views(self.job.on(frame.scene), cams, frame=frame)
        return np.stack([face["Combined"][..., :3] for face in faces])

    def surfaces(self, position, size: int, near: float, far: float) -> Surfaces:
        """What surrounds ``position`` (3,), metres: the surfaces a Volume probe's capture
        sees in a ``size`` cube between the clip distances, how far they are and whether they
        show their fronts (one ray per texel centre, weighted by its solid angle). Faces of
        backface-culled materials are seen from the front only, as in a render."""
        cams = self._cameras(position, size, near, far)
        frame = dataclasses.replace(self._frame, seen=self._seen["irradiance"])
        directions = cubemap.texel_directions(size).reshape(6, -1, 3)
        weight = cubemap.texel_solid_angles(size).reshape(-1)
        front = back = 0.0
        nearest = (np.inf, None)
        distances = np.full((6, size * size), np.inf, np.float32)
        for face, cam in enumerate(cams):
            tri, depth, normals = nearest_faces(with_camera(frame, cam, once=True))
            hit = np.flatnonzero(tri >= 0)
            d = directions[face, hit]
            forward = np.asarray(cubemap.FACES[face][0], np.float32)
            distances[face, hit] = depth[hit] / (d @ forward)  # view depth -> ray length
            behind = np.einsum("nk,nk->n", normals, d) > 0.0  # the ray meets a back face
            front += float(weight[hit[~behind]].sum())
            back += float(weight[hit[behind]].sum())
            if behind.any():
                dist = distances[face, hit[behind]]
                k = int(np.argmin(dist))
                if dist[k] < nearest[0]:
                    nearest = (float(dist[k]), d[behind][k].astype(np.float64))
        ratio = front / (front + back) if front + back > 0.0 else 1.0
        return Surfaces(ratio, nearest[1], nearest[0], distances.reshape(6, size, size))

    def _cameras(self, position, size: int, near: float, far: float) -> list[Camera]:
        """The six face cameras at ``position``; the geometry prepared on first use, without
        shadow maps, through a camera of its own (so that no capture depends on which came
        first: a cluster's workers take them in any order)."""
        far = max(far, 2.0 * near)
        cams = [face_camera(position, face, size, near, far) for face in range(6)]
        if self._frame is None:
            scene = dataclasses.replace(self.scene,
                                        camera=face_camera(np.zeros(3), 0, 16, 0.1, 100.0))
            maps = [None] * shadow_map_count(scene, sky=True)
            frame = pipeline.prepare(self.job.on(scene), shadow_maps=maps)
            # objects hidden from the camera are still in the light a probe gathers, as in
            # Cycles' indirect light: the captures see them, unless hidden from that kind
            meshes = scene.meshes
            self._seen = {
                "reflection": mesh_flags(frame, [m.sphere_probes for m in meshes]),
                "irradiance": mesh_flags(frame, [m.volume_probes for m in meshes])}
            self._frame = dataclasses.replace(frame, seen=None)
        return cams


@dataclass(frozen=True)
class Surfaces:
    """The surfaces around a point (``Capture.surfaces``).

    front_ratio:  the front-facing fraction of the solid angle that meets a surface, in
                  [0, 1]; 1 when nothing is met (EEVEE's validity of a volume sample)
    back_direction, back_distance: unit direction (3,) and distance (metres) of the nearest
                  back face met (the way out of the object around the point), or None, inf
    distances:    (6, S, S) float32 metres along each texel centre's ray to the first surface
                  (``cubemap`` texel order), inf where none
    """

    front_ratio: float
    back_direction: np.ndarray | None
    back_distance: float
    distances: np.ndarray
