"""Helpers shared by the Blender tests."""

import bpy


def engine_available(identifier: str) -> bool:
    """True when ``identifier`` is in the scene's render engine list (what the UI offers)."""
    render = bpy.context.scene.render
    previous = render.engine
    try:
        render.engine = identifier
    except TypeError:
        return False
    render.engine = previous
    return bpy.types.RenderEngine.bl_rna_get_subclass_py(identifier) is not None
