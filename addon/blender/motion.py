"""Motion blur (Render > Motion Blur, as Cycles reads it): the scene evaluated again at
``STEPS`` times over the shutter, each object's corners and the camera's view there
(``core.render.motion_blur`` draws each sample at its own time).

The shutter opens at the frame (Position: Start), half the Shutter before it (Center) or the
whole Shutter before it (End), and stays open Shutter frames. An object's Motion Blur toggle
(Object > Motion Blur) turns its blur off, its Deformation toggle its deformation's (its
transform's stays). An object whose triangles change in number over the shutter renders
still, with one warning.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from ..core import scene as cs
from ..core.render.job import Warnings
from . import extract

STEPS = 3  # times read over the shutter: its opening, middle and closing (Cycles' default)
_OPENS = {"START": 0.0, "CENTER": -0.5, "END": -1.0}  # the opening, in shutters from the frame


def offsets(scene) -> list[float]:
    """The ``STEPS`` times read, in frames from the current frame (subframe included)."""
    r = scene.render
    shutter = float(r.motion_blur_shutter)
    first = _OPENS.get(r.motion_blur_position, -0.5) * shutter
    return [first + shutter * k / (STEPS - 1) for k in range(STEPS)]


def attach(engine, depsgraph, core: cs.Scene, warnings: Warnings, should_stop=None) -> cs.Scene:
    """``core`` (``extract.extract_scene`` of ``depsgraph`` at the current frame) with the
    motion of its meshes and camera over the shutter, read by moving ``engine`` (the
    ``RenderEngine`` rendering it) to each time and back."""
    scene = depsgraph.scene
    now = scene.frame_current + scene.frame_subframe
    steps: list[tuple[list[cs.MeshBatch], cs.Camera]] = []
    try:
        for dt in offsets(scene):
            t = now + dt
            engine.frame_set(int(math.floor(t)), t - math.floor(t))
            steps.append((extract.read_meshes(depsgraph, should_stop),
                          extract.extract_camera(depsgraph)))
    finally:  # back to the frame rendered
        engine.frame_set(int(math.floor(now)), now - math.floor(now))
    blur = {o.name: _toggles(o) for o in scene.objects}
    # a batch is followed by its object's name and its place among that object's batches (an
    # object that appears or leaves over the shutter leaves the others followed)
    named = [_by_name(s[0]) for s in steps]
    seen: dict[str, int] = {}
    meshes = []
    for m in core.meshes:
        k = seen[m.name] = seen.get(m.name, -1) + 1
        later = [n[m.name][k] if k < len(n.get(m.name, ())) else None for n in named]
        meshes.append(_moved(m, later, blur.get(m.name, (True, True)), warnings))
    views = np.stack([s[1].world_to_camera for s in steps])
    camera = core.camera
    if blur.get(scene.camera.name, (True, True))[0] and not np.allclose(
            views, views[0], atol=0.0, rtol=0.0):
        camera = dataclasses.replace(camera, motion=views)
    return dataclasses.replace(core, meshes=meshes, camera=camera)


def _by_name(meshes: list) -> dict[str, list]:
    out: dict[str, list] = {}
    for m in meshes:
        out.setdefault(m.name, []).append(m)
    return out


def _toggles(obj) -> tuple[bool, bool]:
    """Object > Motion Blur: (blurred, its deformation too)."""
    own = getattr(obj, "cycles", None)
    if own is None:
        return True, True
    return bool(own.use_motion_blur), bool(own.use_deform_motion)


def _moved(mesh: cs.MeshBatch, later: list, toggles: tuple[bool, bool],
           warnings: Warnings) -> cs.MeshBatch:
    """``mesh`` with its ``motion`` from the same batch read at each step (``later``, None
    where there was none), or as it is when it does not move or cannot."""
    blurred, deform = toggles
    if not blurred:
        return mesh
    if any(b is None or b.positions.shape != mesh.positions.shape for b in later):
        warnings.add(f"Object '{mesh.name}': its geometry changes over the shutter; rendered "
                     "without motion blur")
        return mesh
    if deform:
        steps = np.stack([b.positions for b in later]).astype(np.float32)
    else:  # the transform's motion alone: the frame's corners carried by each step's matrix
        here = _matrices(mesh)
        corners = mesh.positions.reshape(len(here), -1, 3, 3)  # (instances, their triangles)
        steps = []
        for b in later:
            m = np.linalg.inv(_matrices(b)) @ here  # (I, 4, 4) frame -> step, per instance
            steps.append((np.einsum("itcj,ikj->itck", corners, m[:, :3, :3])
                          + m[:, None, None, :3, 3]).reshape(mesh.positions.shape))
        steps = np.stack(steps).astype(np.float32)
    if not np.isfinite(steps).all():  # a step the frame cannot follow: its own corners there
        steps = np.where(np.isfinite(steps), steps, mesh.positions[None]).astype(np.float32)
    if np.array_equal(steps, np.broadcast_to(mesh.positions, steps.shape)):
        return mesh
    return dataclasses.replace(mesh, motion=steps)


def _matrices(mesh: cs.MeshBatch) -> np.ndarray:
    """(I, 4, 4) world_to_object of the batch's I instances (one for a plain object)."""
    w2o = np.eye(4) if mesh.world_to_object is None else np.asarray(mesh.world_to_object)
    return w2o.reshape(-1, 4, 4)
