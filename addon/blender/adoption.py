"""Bakes of earlier versions adopted when a .blend is opened.

Earlier versions wrote ``<bake folder>/<object name>.exr`` (lightmaps in ``lightmaps/``), keyed
by name and shared by every .blend of the folder. The first time a file is opened (per scene,
``scene.bo2.bakes_adopted``), each such file that was baked for an object as it stands (a
probe's kind and matrix, a lightmap's object) is copied into the .blend's own folder and
declared (``bake_files``); the old files stay, other .blend files may read them. One message
per file goes to the console and to the Light Probes panel (``notices``).
"""

from __future__ import annotations

import hashlib
import re
from pathlib import Path

import bpy
import numpy as np

from ..core.system import atomic
from . import bake_files, lightmaps, probes


def adopt(scene) -> list[str]:
    """Copy the bakes of earlier versions (``<bake folder>/<object name>.exr`` and
    ``lightmaps/<object name>.exr``) into this .blend's folder and declare them, for the
    objects with no bake of their own whose old file was baked for them where they stand (a
    probe's kind and matrix, a lightmap's object name); once per scene
    (``scene.bo2.bakes_adopted``). Returns one message per file copied or refused."""
    if scene.bo2.bakes_adopted or not bpy.data.filepath:
        return []
    try:
        base = bake_files.bake_folder(scene)
        bake_files.file_folder(scene)  # no folder of its own (unsaved, unwritable): nothing
    except bake_files.BakeError:
        return []
    candidates = [(o, "") for o in probes.probe_objects(scene)]
    candidates += [(o, bake_files.LIGHTMAPS) for o in lightmaps.lightmap_objects(scene)]
    messages = []
    for obj, sub in candidates:
        old = _legacy_path(base / sub, obj.name)
        if bake_files.image(obj) is not None or not old.is_file() or not _baked_for(obj, old, sub):
            continue
        new = bake_files.target(scene, obj, sub)  # it holds no bake: a new name
        try:
            atomic.write_bytes(new, old.read_bytes())
            bake_files.declare(obj, new, pack=False)
        except (OSError, RuntimeError, ValueError, AttributeError) as exc:
            messages.append(f"Could not copy the bake of '{obj.name}' from {old} ({exc})")
            continue
        messages.append(f"The bake of '{obj.name}' was copied from {old} into {new.parent}; "
                        "save the file to keep it there")
    scene.bo2.bakes_adopted = True
    return messages


def _baked_for(obj, file: Path, sub: str) -> bool:
    """Whether the earlier version's ``file`` was baked for ``obj`` as it stands."""
    from ..core.files import bake_file, lightmap_file, probe_file

    try:
        if sub:
            return lightmap_file.read(file)[0].get("object") == obj.name
        meta = probe_file.read(file)[0]
    except bake_file.BakeFileError:
        return False
    described = probes.spec(obj).describe()
    return (meta.get("kind") == described["kind"]
            and np.allclose(meta.get("matrix", 0), described["matrix"], atol=1e-4))


def _legacy_path(folder: Path, name: str) -> Path:
    """The bake file of object ``name`` as earlier versions named it."""
    safe = re.sub(r"[^\w\-. ]", "_", name).strip()
    if safe != name or not safe:
        safe = f"{safe}-{hashlib.sha1(name.encode()).hexdigest()[:8]}"
    return folder / f"{safe}.exr"


notices: list[str] = []  # what ``adopt`` did when the last file was opened (the panel shows it)


@bpy.app.handlers.persistent
def on_load(_filepath="") -> None:
    """``load_post`` handler: adopt the earlier versions' bakes of every scene."""
    notices.clear()
    for scene in bpy.data.scenes:
        try:
            if not scene.bo2.bakes_adopted and scene.view_layers:
                scene.view_layers[0].update()  # the objects' world matrices, just read
            notices.extend(adopt(scene))
        except Exception as exc:  # noqa: BLE001 - a handler must not stop Blender's load
            notices.append(f"Bakes of earlier versions not adopted in scene '{scene.name}': "
                           f"{exc}")
    for message in notices:
        print(f"BO2 Lighting: {message}")
