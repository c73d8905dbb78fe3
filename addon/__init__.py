"""BO2 Lighting add-on: registration of the Blender classes, in one explicit ordered list.

``addon/core`` is pure NumPy and never imports ``bpy``; ``addon/blender`` is the Blender glue.
The Blender modules are imported inside ``register()`` so that the ``bo2`` command and the core
tests can import this package without loading ``bpy``.
"""

import functools
import tomllib
from pathlib import Path

_registered: list = []


@functools.cache
def version() -> str:
    """The extension's version, as its manifest (``blender_manifest.toml``) gives it."""
    with open(Path(__file__).resolve().parent.parent / "blender_manifest.toml", "rb") as fh:
        return str(tomllib.load(fh)["version"])


def _classes() -> list:
    from .blender import engine, operators, props, ui

    return [*props.CLASSES, *engine.CLASSES, *operators.CLASSES, *ui.CLASSES]


def _kernel_cache() -> None:
    """Compiled kernels are cached in the extension's user folder (kept across updates); a
    development checkout, not installed as an extension, keeps the per-user default."""
    import bpy

    from .core import kernels

    try:
        folder = bpy.utils.extension_path_user(__package__.rpartition(".")[0], path="kernels",
                                               create=True)
    except ValueError:  # "does not name an extension"
        return
    kernels.configure(folder)


def register() -> None:
    """Register every class of the add-on, in order; safe to call after ``unregister()``."""
    import bpy

    from .blender import adoption, library, node_groups, props, ui
    from .core import kernels

    if _registered:
        return
    _kernel_cache()
    if not bpy.app.background:  # off the UI thread: the window's first render finds them ready
        kernels.prepare()
    for cls in _classes():
        bpy.utils.register_class(cls)
        _registered.append(cls)
    props.attach()
    ui.enable_panels()
    node_groups.append_menus()
    ui.append_menus()
    library.register_library()
    bpy.app.handlers.load_post.append(props.on_load)  # before adoption, which reads them
    bpy.app.handlers.load_post.append(adoption.on_load)


def unregister() -> None:
    """Remove everything ``register()`` added, in reverse order."""
    import bpy

    from .blender import adoption, library, node_groups, props, ui, viewport

    if not _registered:
        return
    viewport.close_all()
    for handler in (adoption.on_load, props.on_load):
        if handler in bpy.app.handlers.load_post:
            bpy.app.handlers.load_post.remove(handler)
    library.unregister_library()
    ui.remove_menus()
    node_groups.remove_menus()
    ui.disable_panels()
    props.detach()
    for cls in reversed(_registered):
        bpy.utils.unregister_class(cls)
    _registered.clear()
