"""Where each object's bake lives: its own OpenEXR file, declared by an image datablock.

A light probe's bake, or a mesh's lightmap, is one OpenEXR file (``core.probe_file``,
``core.lightmap_file``). The object holds an image datablock that declares it
(``object.bo2.bake``): the file's path relative to the .blend, so that Blender's External
Data tools (Report Missing Files, Make Paths Relative) and Blender Asset Tracer see it and
move it with the .blend, or the file's bytes packed into the .blend (``pack``), so that a
saved file carries its light. The object holds the datablock, so renaming it keeps its bake.

New bakes are written into the .blend's own folder, ``<bake folder>/<.blend name>/``
(lightmaps in ``lightmaps/`` inside it), each under the object's name and a random suffix:
two .blend files of one folder, or a file saved under another name, never share a bake. Of the
objects that hold one datablock (an object and its duplicates), the first in name order keeps
it; the others get their own at their next bake.

Bakes of earlier versions (``<bake folder>/<object name>.exr``, keyed by name and shared by
every .blend of the folder) are copied into the .blend's folder when it is opened (``adopt``;
the old files stay, other .blend files may read them).
"""

from __future__ import annotations

import atexit
import hashlib
import os
import re
import shutil
import tempfile
import uuid
from pathlib import Path

import bpy

from . import probes

LIGHTMAPS = "lightmaps"  # sub-folder of the lightmaps


def _safe(name: str) -> str:
    """``name`` with characters unsafe in file names replaced by '_'."""
    return re.sub(r"[^\w\-. ]", "_", name).strip() or "_"


def file_folder(scene) -> Path:
    """This .blend's own bake folder: ``<bake folder>/<.blend name>/`` (an unsaved file with
    an absolute bake folder: ``untitled``). Raises BakeError when unknown."""
    stem = Path(bpy.data.filepath).stem if bpy.data.filepath else "untitled"
    return probes.bake_folder(scene) / _safe(stem)


def image(obj):
    """The image datablock that declares ``obj``'s bake, or None."""
    return obj.bo2.bake


def _sharers(img) -> list:
    return [o for o in bpy.data.objects if o.bo2.bake == img]


def shared_with(obj) -> list[str]:
    """Names of the other objects whose bake is ``obj``'s (duplicates of it)."""
    img = image(obj)
    return [] if img is None else [o.name for o in _sharers(img) if o != obj]


def _keeps(obj) -> bool:
    """Whether ``obj`` keeps its datablock at its next bake: it holds one, and no object that
    also holds it comes before it in name order (the others, its duplicates, get their own)."""
    img = image(obj)
    return img is not None and min(o.name for o in _sharers(img)) == obj.name


def path(obj) -> Path | None:
    """The absolute path of ``obj``'s bake file (whether or not it exists, packed or not), or
    None when nothing declares one."""
    img = image(obj)
    if img is None or not img.filepath:
        return None
    return Path(bpy.path.abspath(img.filepath, library=img.library))


_unpacked: list[Path] = []  # the folder of this process's copies of packed bakes


def _copies() -> Path:
    if not _unpacked:
        folder = Path(tempfile.mkdtemp(prefix="bo2_packed_"))
        atexit.register(shutil.rmtree, folder, True)
        _unpacked.append(folder)
    return _unpacked[0]


def readable(obj) -> Path | None:
    """A file holding ``obj``'s bake as it renders: the packed bytes (copied once into a
    temporary file named by their digest), else the declared file; None without one."""
    img = image(obj)
    if img is None:
        return None
    if img.packed_file is not None:
        data = img.packed_file.data
        copy = _copies() / f"{hashlib.sha256(data).hexdigest()[:40]}.exr"
        if not copy.exists():
            _write_atomically(copy, data)
        return copy
    return path(obj)


def packed(obj) -> bool:
    """Whether ``obj``'s bake is packed into the .blend."""
    img = image(obj)
    return img is not None and img.packed_file is not None


def _write_atomically(target: Path, data: bytes) -> None:
    target.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=f".{target.stem}.", suffix=".tmp", dir=target.parent)
    try:
        with os.fdopen(fd, "wb") as f:
            f.write(data)
        os.replace(tmp, target)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise


def target(scene, obj, sub: str = "") -> Path:
    """Where a new bake of ``obj`` is written: its declared file when that is in this .blend's
    folder and no other object holds it, else a new name there."""
    folder = file_folder(scene) / sub
    current = path(obj)
    if current is not None and current.parent == folder and _keeps(obj):
        return current
    return folder / f"{_safe(obj.name)}-{uuid.uuid4().hex[:8]}.exr"


def declare(obj, file: Path, pack: bool) -> None:
    """Make ``obj``'s image datablock declare ``file`` (just written), relative to the .blend
    when it is saved, and pack its bytes when ``pack``."""
    img = image(obj)
    if not _keeps(obj):
        img = bpy.data.images.load(str(file), check_existing=False)  # read when looked at
        img.name = f"BO2 {'lightmap' if obj.type == 'MESH' else 'bake'} {obj.name}"
        img.use_fake_user = True
        obj.bo2.bake = img
    img.filepath = bpy.path.relpath(str(file)) if bpy.data.filepath else str(file)
    if img.packed_file is not None:
        img.unpack(method="REMOVE")
    if pack:
        img.pack()


def pack(objs) -> int:
    """Pack the bake files of ``objs`` into the .blend; returns how many were packed. Raises
    BakeError for a declared file that is missing."""
    count = 0
    for obj in objs:
        img = image(obj)
        if img is None or img.packed_file is not None:
            continue
        file = path(obj)
        if file is None or not file.is_file():
            raise probes.BakeError(f"'{obj.name}': its bake file {file} is missing; re-bake "
                                   "it, or find the file (File > External Data > Find Missing "
                                   "Files)")
        img.pack()
        count += 1
    return count


def unpack(objs) -> int:
    """Write the packed bakes of ``objs`` back to their files (each replaced atomically) and
    keep them there, not in the .blend; returns how many."""
    count = 0
    for obj in objs:
        img = image(obj)
        if img is None or img.packed_file is None:
            continue
        file = path(obj)
        if file is None:
            raise probes.BakeError(f"'{obj.name}': its packed bake has no file path")
        try:
            _write_atomically(file, img.packed_file.data)
        except OSError as exc:
            raise probes.BakeError(f"Could not write {file} ({exc.strerror}); the bakes stay "
                                   "packed") from None
        img.unpack(method="REMOVE")
        count += 1
    return count


def forget(obj) -> bool:
    """Delete ``obj``'s bake: its file (unless another object holds it) and its datablock;
    returns whether there was one."""
    img = image(obj)
    if img is None:
        return False
    file = path(obj)
    obj.bo2.bake = None
    if not _sharers(img):
        if file is not None and file.is_file():
            file.unlink()
        bpy.data.images.remove(img)
    return True


def adopt(scene) -> list[str]:
    """Copy the bakes of earlier versions (``<bake folder>/<object name>.exr`` and
    ``lightmaps/<object name>.exr``) of objects that have no bake of their own into this
    .blend's folder, and declare them; returns one message per copied file."""
    from . import lightmaps

    try:
        base = probes.bake_folder(scene)
        folder = file_folder(scene)
    except probes.BakeError:
        return []
    candidates = [(o, "") for o in probes.probe_objects(scene)]
    candidates += [(o, LIGHTMAPS) for o in lightmaps.lightmap_objects(scene)]
    messages = []
    for obj, sub in candidates:
        if image(obj) is not None:
            continue
        old = _legacy_path(base / sub, obj.name)
        if not old.is_file():
            continue
        digest = hashlib.sha1(obj.name.encode()).hexdigest()[:8]
        new = folder / sub / f"{_safe(obj.name)}-{digest}.exr"
        try:
            if not new.is_file() or new.stat().st_size != old.stat().st_size:
                _write_atomically(new, old.read_bytes())
        except OSError as exc:
            messages.append(f"Could not copy the bake of '{obj.name}' from {old} ({exc.strerror})")
            continue
        declare(obj, new, pack=False)
        messages.append(f"The bake of '{obj.name}' was copied from {old} into {new.parent}; "
                        "save the file to keep it there")
    return messages


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
        notices.extend(adopt(scene))
    for message in notices:
        print(f"BO2 Lighting: {message}")
