"""Blender's light probe objects as BO2 probes: their bake files, and loading them for a render.

Sphere light probes are reflection probes (influence distance and falloff); Volume light probes
are irradiance volumes (their x/y/z resolution; the object's box, with the influence distance
around it); the World is the fallback of both. Each probe object's bake is one OpenEXR file
(``core.files.probe_file``) that the object's image datablock declares, in the .blend's folder
inside the bake folder or packed into the .blend (``bake_files``); the bake folder is
``scene.bo2.bake_folder``, ``//bo2_bake/`` (next to the .blend) by default. Baking is
``core.bakes.bake``, driven by ``blender/bake.py``.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..core.bakes import bake
from ..core.files import bake_file, probe_file
from ..core.lighting import probes as cp
from ..core.lighting.world_probes import world_probes
from ..core.render.job import Warnings
from ..core.scene import World
from ..core.system.cache import Cache, stamp
from . import bake_files, props
from .bake_files import BakeError, bake_folder, writable_folder  # noqa: F401 (re-exported)

KINDS = {"SPHERE": "reflection", "VOLUME": "irradiance"}


def capture_backend(scene) -> str:
    """"BO2" or "CYCLES": ``scene.bo2.probes.backend``, else the preferences' default."""
    backend = scene.bo2.probes.backend
    return props.preferences().bake_backend if backend == "DEFAULT" else backend


def probe_objects(scene, selected_only: bool = False) -> list:
    """Sphere and Volume light probe objects that render, in name order."""
    objs = [o for o in scene.objects if o.type == "LIGHT_PROBE" and o.data.type in KINDS
            and not o.hide_render and (not selected_only or o.select_get())]
    return sorted(objs, key=lambda o: o.name)


def spec(obj) -> bake.ProbeSpec:
    """The core's description of light probe object ``obj`` (Sphere or Volume)."""
    data = obj.data
    volume = data.type == "VOLUME"
    # the parallax proxy: the probe's own (custom parallax) or its influence shape and distance
    custom = not volume and bool(getattr(data, "use_custom_parallax", False))
    shape = getattr(data, "parallax_type" if custom else "influence_type", "ELIPSOID")
    distance = getattr(data, "parallax_distance" if custom else "influence_distance", 0.0)
    return bake.ProbeSpec(
        name=obj.name, kind=KINDS[data.type],
        local_to_world=np.array(obj.matrix_world, np.float64),
        influence=float(data.influence_distance),
        falloff=float(getattr(data, "falloff", 1.0)),  # a volume has none since 4.2: 1
        resolution=((int(data.resolution_x), int(data.resolution_y), int(data.resolution_z))
                    if volume else None),
        clip_start=float(data.clip_start), clip_end=float(getattr(data, "clip_end", 1e4)),
        proxy="none" if volume else ("box" if shape == "BOX" else "sphere"),
        proxy_distance=0.0 if volume else float(distance),
        volume=bake.VolumeSettings(**{f.name: float(getattr(data, f.name, f.default))
                                      for f in dataclasses.fields(bake.VolumeSettings)})
        if volume else bake.VolumeSettings())


# --------------------------------------------------------------------------------------------
# loading baked probes for a render

_files = Cache("bake file reads", kept=4096)  # path -> (file stamp, result or error)


def cached_read(path: Path, reader):
    """``reader(path)`` (``probe_file.read``, ``lightmap_file.read``), cached while the file's
    modification time and size stay (its ``BakeFileError`` too: a damaged file is read
    once, not at every redraw)."""
    try:
        now = stamp(path)
    except OSError:
        _files.pop(path)
        return reader(path)  # raises the reader's own error
    cached = _files.get(path)
    if cached is None or cached[0] != now:
        try:
            cached = (now, reader(path))
        except bake_file.BakeFileError as exc:
            cached = (now, exc)
        _files.put(path, cached)
    if isinstance(cached[1], bake_file.BakeFileError):
        raise cached[1]
    return cached[1]


def _read(path: Path) -> tuple:
    """``probe_file.read(path)``, cached (``cached_read``)."""
    return cached_read(path, probe_file.read)


STATES = ("BAKED", "STALE", "MISSING", "DAMAGED")


@dataclass
class BakeState:
    """A probe object's bake: ``state`` one of ``STATES``; ``path`` its file; ``meta`` the
    file's metadata (empty unless read); ``message`` why it is not BAKED ("" when it is)."""

    state: str
    path: Path
    meta: dict
    message: str = ""


def bake_state(obj) -> BakeState:
    """The state of ``obj``'s bake (``bake_files``): STALE when the probe moved or changed
    since (kind, matrix, volume resolution or the leak settings a bake uses), MISSING without
    a file, DAMAGED when unreadable."""
    declared = bake_files.path(obj)
    if declared is None:
        return BakeState("MISSING", Path(), {}, "not baked (bake the probes)")
    try:
        path = bake_files.readable(obj)
    except OSError as exc:
        return BakeState("DAMAGED", declared, {}, f"its packed bake cannot be read "
                         f"({exc.strerror})")
    if not path.exists():
        return BakeState("MISSING", path, {}, f"{path}: the bake file is missing (bake the "
                         "probes, or File > External Data > Find Missing Files)")
    try:
        meta = _read(path)[0]
    except bake_file.BakeFileError as exc:
        return BakeState("DAMAGED", path, {}, bake_files.failure(obj, path, exc))
    described = spec(obj).describe()
    if meta.get("kind") != described["kind"]:
        return BakeState("DAMAGED", path, meta, f"{path.name}: the bake is of a "
                         f"{meta.get('kind', 'other')} probe; re-bake")
    if (not np.allclose(meta.get("matrix", 0), described["matrix"], atol=1e-4)
            or meta.get("resolution") != described.get("resolution")
            or meta.get("leaks", described.get("leaks")) != described.get("leaks")):
        others = bake_files.shared_with(obj)
        if others:
            return BakeState("STALE", path, meta, f"it shares its bake with '{others[0]}' (a "
                             "duplicate); re-bake to give it its own")
        return BakeState("STALE", path, meta, "the bake is stale (the probe moved or changed "
                         f"since {meta.get('bake_time', 'it was baked')}); re-bake")
    if described["kind"] == "reflection" and set(_read(path)[2]) != set(cp.PREFILTERS):
        return BakeState("DAMAGED", path, meta, "the bake has no prefiltered cube maps; re-bake")
    return BakeState("BAKED", path, meta)


def _probe_from_file(obj, state: BakeState, warnings: Warnings):
    """The core probe of ``obj`` from its bake, or None with one warning. A stale bake is used
    where and as it was baked (its own matrix and resolution), with a warning."""
    where = f"Light probe '{obj.name}'"
    if state.state in ("MISSING", "DAMAGED"):
        warnings.add(f"{where}: {state.message}; the world lights it instead")
        return None
    _, coeffs, chains = _read(state.path)
    current = spec(obj)
    if state.state == "STALE":
        warnings.add(f"{where}: {state.message}. Until then the old bake is used where it "
                     "was baked")
        resolution = state.meta.get("resolution")
        current = dataclasses.replace(
            current, local_to_world=np.array(state.meta["matrix"], np.float64),
            resolution=tuple(resolution) if resolution else current.resolution)
    validity = None
    if state.meta.get("invalid_samples"):
        validity = np.ones(len(coeffs), np.float32)
        validity[np.asarray(state.meta["invalid_samples"], np.int64)] = 0.0
    if current.kind == "reflection":
        return current.probe(coeffs, chains)
    return current.probe(coeffs, None, validity, chains.get(probe_file.DEPTH, [None])[0])


def load_probes(scene, world: World, warnings: Warnings) -> cp.Probes:
    """The world fallback and every baked probe of ``scene`` (missing, stale or corrupt
    bakes: one warning each, and the world instead)."""
    result = world_probes(world)
    objs = probe_objects(scene)
    if not objs:
        return result
    for obj in objs:
        probe = _probe_from_file(obj, bake_state(obj), warnings)
        if isinstance(probe, cp.ReflectionProbe):
            result.reflection.append(probe)
        elif probe is not None:
            result.volumes.append(probe)
    return result
