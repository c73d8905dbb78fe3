"""Where each object's bake lives: its own OpenEXR file, declared by an image datablock.

A light probe's bake, or a mesh's lightmap, is one OpenEXR file (``core.files.probe_file``,
``core.files.lightmap_file``). The object holds an image datablock that declares it
(``object.bo2.bake``): the file's path relative to the .blend, so that Blender's External
Data tools (Report Missing Files, Make Paths Relative) and Blender Asset Tracer see it and
move it with the .blend, or the file's bytes packed into the .blend (``pack``), so that a
saved file carries its light. The object holds the datablock, so renaming it keeps its bake.

New bakes are written into the .blend's own folder, ``<bake folder>/<.blend name>/``
(lightmaps in ``lightmaps/`` inside it; with an absolute bake folder the name carries a digest
of the .blend's path, since .blend files of one name may live in several folders), each under
the object's name and a random suffix. A file is only ever written, replaced or deleted inside
the .blend's own folder: a file saved under another name reads its original's bakes until its
own bake writes new ones, and its Clear or Unpack leaves the original's files alone. So two
.blend files never change each other's bakes. Of the objects that hold one datablock (an object
and its duplicates), the first in name order keeps it; the others get their own at their next
bake.

The bake folder is ``scene.bo2.bake_folder``, else the preferences' default, ``//bo2_bake/``
(``bake_folder``). Bakes of earlier versions are adopted when a file is opened (``adoption``).
"""

from __future__ import annotations

import hashlib
import os
import re
import shutil
import tempfile
import uuid
from pathlib import Path

import bpy

from ..core.system import atomic
from . import interrupt, props

LIGHTMAPS = "lightmaps"  # sub-folder of the lightmaps


class BakeError(Exception):
    """A bake that cannot start or finish; one-line message."""


def _setting(scene) -> str:
    """The bake folder as set: the scene's, else the preferences' default."""
    return scene.bo2.bake_folder or props.preferences().bake_folder or "//bo2_bake/"


def bake_folder(scene) -> Path:
    """Absolute bake folder of ``scene``: ``scene.bo2.bake_folder``, else the preferences'
    default (relative to the .blend)."""
    folder = _setting(scene)
    if folder.startswith("//") and not bpy.data.filepath:
        raise BakeError("Save the .blend file first (the bake folder is relative to it), "
                        "or set an absolute Bake Folder")
    return Path(bpy.path.abspath(folder))


def writable_folder(scene) -> Path:
    """``bake_folder(scene)``, checked before any work: a folder (or a path one can be made
    at) where a file can be written. Nothing is created. Raises BakeError."""
    folder = bake_folder(scene)
    existing = folder
    while not existing.exists() and existing != existing.parent:
        existing = existing.parent
    if not existing.is_dir():
        raise BakeError(f"Bake folder {folder}: {existing} is a file, not a folder; choose "
                        "another Bake Folder")
    try:
        with tempfile.TemporaryFile(dir=existing):
            pass
    except OSError as exc:
        raise BakeError(f"Bake folder {folder} is not writable ({exc.strerror}); choose "
                        "another Bake Folder") from None
    return folder


def _safe(name: str) -> str:
    """``name`` with characters unsafe in file names replaced by '_'."""
    return re.sub(r"[^\w\-. ]", "_", name).strip() or "_"


def _norm(path) -> Path:
    return Path(os.path.normpath(str(path)))


def file_folder(scene) -> Path:
    """This .blend's own bake folder: ``<bake folder>/<.blend name>/``; a name that is not
    safe in file names, or an absolute bake folder, adds a digest of the .blend's path (an
    unsaved file with an absolute bake folder: ``untitled``). Raises BakeError when unknown."""
    blend = bpy.data.filepath
    stem = Path(blend).stem if blend else "untitled"
    name = _safe(stem)
    if blend and (name != stem or not _setting(scene).startswith("//")):
        name += "-" + hashlib.sha1(os.path.abspath(blend).encode()).hexdigest()[:8]
    return _norm(bake_folder(scene) / name)


def _own(scene, file: Path | None) -> bool:
    """Whether ``file`` lies in this .blend's own bake folder (its sub-folders too)."""
    if file is None:
        return False
    try:
        folder = file_folder(scene)
    except BakeError:
        return False
    return folder in _norm(file).parents


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
    return _norm(bpy.path.abspath(img.filepath, library=img.library))


_unpacked: list[Path] = []  # the folder of this process's copies of packed bakes


def _copies() -> Path:
    if not _unpacked:
        folder = Path(tempfile.mkdtemp(prefix="bo2_packed_"))
        interrupt.at_exit(lambda: shutil.rmtree(folder, True))
        _unpacked.append(folder)
    return _unpacked[0]


_copied: dict[tuple, Path] = {}  # (packed data's address, size) -> its copy


def readable(obj) -> Path | None:
    """A file holding ``obj``'s bake as it renders: the packed bytes (copied into a temporary
    file named by their digest, once per packing), else the declared file; None without one."""
    img = image(obj)
    if img is None:
        return None
    packed = img.packed_file
    if packed is not None:
        key = (packed.as_pointer(), packed.size)
        copy = _copied.get(key)
        if copy is None or not copy.exists():
            data = packed.data
            copy = _copies() / f"{hashlib.sha256(data).hexdigest()[:40]}.exr"
            if not copy.exists():
                atomic.write_bytes(copy, data)
            _copied[key] = copy
        return copy
    return path(obj)


def failure(obj, path: Path, exc: Exception) -> str:
    """Why ``obj``'s bake file ``path`` (``readable``) cannot be used, from the reader's error
    ("<file name>: <why>"), naming the file once: its name, or "its packed bake"."""
    reason = str(exc).removeprefix(f"{path.name}: ")
    return f"{'its packed bake' if packed(obj) else path.name}: {reason}"


def packed(obj) -> bool:
    """Whether ``obj``'s bake is packed into the .blend."""
    img = image(obj)
    return img is not None and img.packed_file is not None


def target(scene, obj, sub: str = "") -> Path:
    """Where a new bake of ``obj`` is written: its declared file when that is in this .blend's
    folder and no other object holds it, else a new name there."""
    folder = file_folder(scene) / sub
    current = path(obj)
    if current is not None and current.parent == folder and _keeps(obj):
        return current
    return folder / f"{_safe(obj.name)}-{uuid.uuid4().hex[:8]}.exr"


def _declared_path(file: Path) -> str:
    """``file`` as a datablock records it: relative to the saved .blend when it can be."""
    if bpy.data.filepath:
        try:
            return bpy.path.relpath(str(file))
        except ValueError:  # another drive (Windows): only an absolute path reaches it
            pass
    return str(file)


def declare(obj, file: Path, pack: bool) -> None:
    """Make ``obj``'s image datablock declare ``file`` (just written), relative to the .blend
    when it is saved, and pack its bytes when ``pack``. Raises RuntimeError, ValueError or
    AttributeError when Blender refuses (a linked object, an unreadable file)."""
    img = image(obj)
    if not _keeps(obj):
        img = bpy.data.images.load(str(file), check_existing=False)  # read when looked at
        img.name = f"BO2 {'lightmap' if obj.type == 'MESH' else 'bake'} {obj.name}"
        obj.bo2.bake = img  # the object is its user: deleted with it, purged on save
    img.filepath = _declared_path(file)
    if img.packed_file is not None:
        img.unpack(method="REMOVE")
    if pack:
        img.pack()


def pack(objs) -> int:
    """Pack the bake files of ``objs`` into the .blend; returns how many were packed. Raises
    BakeError for a declared file that is missing or that Blender cannot pack."""
    count = 0
    for obj in objs:
        img = image(obj)
        if img is None or img.packed_file is not None:
            continue
        file = path(obj)
        if file is None or not file.is_file():
            raise BakeError(f"'{obj.name}': its bake file {file} is missing; re-bake "
                                   "it, or find the file (File > External Data > Find Missing "
                                   "Files)")
        try:
            img.pack()
        except RuntimeError as exc:
            raise BakeError(f"'{obj.name}': could not pack {file} ({exc})") from None
        count += 1
    return count


def unpack(scene, objs) -> int:
    """Write the packed bakes of ``objs`` back to their files (each replaced atomically) and
    keep them there, not in the .blend; returns how many. A bake declared outside this .blend's
    folder (another file's, after a Save As) is written to a new file in its own folder."""
    count = 0
    for obj in objs:
        img = image(obj)
        if img is None or img.packed_file is None:
            continue
        file = path(obj)
        if not _own(scene, file):
            file = target(scene, obj, LIGHTMAPS if obj.type == "MESH" else "")
        try:
            atomic.write_bytes(file, img.packed_file.data)
        except OSError as exc:
            raise BakeError(f"Could not write {file} ({exc.strerror}); the bakes stay "
                                   "packed") from None
        img.filepath = _declared_path(file)
        img.unpack(method="REMOVE")
        count += 1
    return count


def forget(scene, obj) -> bool:
    """Delete ``obj``'s bake: its datablock, and its file when the file is in this .blend's
    folder and no other object holds it; returns whether there was one."""
    img = image(obj)
    if img is None:
        return False
    file = path(obj)
    obj.bo2.bake = None
    if not _sharers(img):
        if _own(scene, file) and file.is_file():
            try:
                file.unlink()
            except OSError as exc:
                raise BakeError(f"Could not delete {file} ({exc.strerror})") from None
        bpy.data.images.remove(img)
    return True
