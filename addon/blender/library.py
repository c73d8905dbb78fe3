"""The node group asset library: ``node_groups/bo2_node_groups.blend`` with every BO2 group
marked as an asset in the "BO2 Lighting" catalog.

``build()`` writes the file (``tools/build_node_library.py``, from the specs in
``node_groups/``); ``register_library()`` adds ``node_groups/`` to Blender's asset libraries
(Preferences > File Paths), so the groups show in the Asset Browser and in the shader editor's
Add menu; ``unregister_library()`` removes exactly what it added.
"""

from __future__ import annotations

import os
from pathlib import Path

import bpy

from . import node_groups

LIBRARY_NAME = "BO2 Lighting"
LIBRARY_DIR = node_groups.SPEC_DIR
LIBRARY_FILE = LIBRARY_DIR / "bo2_node_groups.blend"
CATALOG_FILE = LIBRARY_DIR / "blender_assets.cats.txt"
CATALOG_ID = "c33160b0-b9e2-4415-bb72-eec7a1bc6d3c"
CATALOG_PATH = "BO2 Lighting"
_added: list[str] = []  # the library this session added (its path)


def _same(a: str, b: Path) -> bool:
    try:
        return os.path.samefile(bpy.path.abspath(a), b)
    except OSError:
        return False


def register_library() -> None:
    """Add ``node_groups/`` as the asset library "BO2 Lighting", unless one points there
    (one of that name, left by saved preferences, is then taken as this one)."""
    libraries = bpy.context.preferences.filepaths.asset_libraries
    existing = [lib for lib in libraries if _same(lib.path, LIBRARY_DIR)]
    if existing:  # ours from an earlier session's saved preferences is ours to remove
        _added.extend(lib.path for lib in existing if lib.name == LIBRARY_NAME)
        return
    lib = libraries.new(name=LIBRARY_NAME, directory=str(LIBRARY_DIR))
    try:
        lib.import_method = "APPEND_REUSE"  # a group added twice is not duplicated
    except TypeError:  # Blender 5 offers Link, Append and Pack
        lib.import_method = "APPEND"
    _added.append(lib.path)


def unregister_library() -> None:
    """Remove the library ``register_library()`` added."""
    libraries = bpy.context.preferences.filepaths.asset_libraries
    for path in _added:
        lib = next((lib for lib in libraries if lib.path == path), None)
        if lib is not None:
            libraries.remove(lib)
    _added.clear()


def build(path: Path = LIBRARY_FILE) -> list[str]:
    """Write the library: every group of ``node_groups.GROUP_NAMES`` built from its spec and
    marked as an asset (catalog, description, tags), in a file of its own, and the catalog
    definition beside it. Runs in a fresh file (the current one is replaced). Returns the
    group names."""
    bpy.ops.wm.read_factory_settings(use_empty=True)
    for name in node_groups.GROUP_NAMES:
        tree = node_groups.ensure_group(name)
        tree.asset_mark()
        tree.asset_data.catalog_id = CATALOG_ID
        tree.asset_data.description = node_groups.load_spec(name).get("description", "")
        tree.asset_data.tags.new("BO2 Lighting")
        tree.asset_data.author = "BO2 Lighting developers"
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    part = path.with_name(path.name + ".part.blend")
    bpy.ops.wm.save_as_mainfile(filepath=str(part), compress=True, copy=True)
    os.replace(part, path)
    catalog = path.parent / CATALOG_FILE.name
    catalog.write_text("# Asset catalogs of BO2 Lighting (Blender's catalog definition "
                       "format).\nVERSION 1\n\n"
                       f"{CATALOG_ID}:{CATALOG_PATH}:{CATALOG_PATH}\n")
    return list(node_groups.GROUP_NAMES)
