"""The core's passes (``core.render.passes``) as Blender knows them: view layer flags and 5.0's
names.

Blender 5.0 renamed some built-in passes; the engine registers and writes every pass under the
running Blender's name, as Cycles does, so that compositor set-ups work with both engines.
``DiffCol`` and ``GlossCol`` are Cycles' colour passes, which the comparison with Cycles reads.
"""

from __future__ import annotations

import bpy

from ..core.render import cryptomatte as crypto
from ..core.render.passes import PASSES

# Pass (pipeline name) -> its flag on the view layer, or on the view layer's ``bo2`` settings.
FLAGS = {
    "Combined": "use_pass_combined",
    "Depth": "use_pass_z",
    "Normal": "use_pass_normal",
    "Position": "use_pass_position",
    "UV": "use_pass_uv",
    "IndexMA": "use_pass_material_index",
    "DiffDir": "use_pass_diffuse_direct",
    "GlossDir": "use_pass_glossy_direct",
    "DiffInd": "use_pass_diffuse_indirect",
    "GlossInd": "use_pass_glossy_indirect",
    "Emit": "use_pass_emit",
    "AO": "use_pass_ambient_occlusion",
    "Albedo": "bo2.use_pass_albedo",
    "Specular Color": "bo2.use_pass_specular_color",
    "Gloss": "bo2.use_pass_gloss",
    "Lightmap": "bo2.use_pass_lightmap",
    "Lightmap Texels": "bo2.use_pass_lightmap_texels",
    "Shadow Catcher": "bo2.use_pass_shadow_catcher",
    "DiffCol": "use_pass_diffuse_color",
    "GlossCol": "use_pass_glossy_color",
}
CYCLES_COLOR = {"DiffCol": "RGB", "GlossCol": "RGB"}  # Cycles' colour passes: channel ids
RENAMED_IN_5 = {"DiffDir": "Diffuse Direct", "GlossDir": "Glossy Direct", "Emit": "Emission",
                "IndexMA": "Material Index", "DiffInd": "Diffuse Indirect",
                "GlossInd": "Glossy Indirect", "DiffCol": "Diffuse Color",
                "GlossCol": "Glossy Color", "AO": "Ambient Occlusion"}


def readable_name(name: str) -> str:
    """Blender 5.0's name of a pass (``Diffuse Direct``), whatever Blender runs."""
    return RENAMED_IN_5.get(name, name)


def blender_name(name: str) -> str:
    """The running Blender's name of the pass ``name`` (pipeline name)."""
    return readable_name(name) if bpy.app.version >= (5, 0, 0) else name


def channel_ids(name: str) -> str:
    """Channel ids of a pass of either engine ("RGBA", "XYZ", ...): a light group's is RGB, a
    Cryptomatte pass's rgba, a shader AOV's RGBA or X."""
    if name.startswith("Combined_"):
        return "RGB"
    if name.startswith("Crypto"):
        return "rgba"
    if name in CYCLES_COLOR:
        return CYCLES_COLOR[name]
    return PASSES[name].ids if name in PASSES else "RGBAX"


def _owner(view_layer, name: str):
    flag = FLAGS[name]
    return (view_layer.bo2 if flag.startswith("bo2.") else view_layer), flag.removeprefix("bo2.")


def enabled(view_layer, name: str) -> bool:
    """Whether pass ``name`` is turned on in ``view_layer``."""
    owner, flag = _owner(view_layer, name)
    return bool(getattr(owner, flag, False))


def set_enabled(view_layer, name: str, on: bool = True) -> None:
    """Turn pass ``name`` on or off in ``view_layer``."""
    owner, flag = _owner(view_layer, name)
    setattr(owner, flag, bool(on))


def draw_flag(layout, view_layer, name: str) -> None:
    """The checkbox of pass ``name``, labelled with its 5.0 name."""
    owner, flag = _owner(view_layer, name)
    layout.prop(owner, flag, text=readable_name(name))


def cryptomatte(view_layer) -> tuple[str, ...]:
    """The Cryptomatte passes turned on in ``view_layer`` (``core.render.cryptomatte.KINDS``)."""
    return tuple(kind for kind in crypto.KINDS
                 if getattr(view_layer, f"use_pass_cryptomatte_{kind.lower()}", False))


def cryptomatte_passes(view_layer) -> list[str]:
    """The names of the Cryptomatte passes ``view_layer`` has: Crypto<Kind>NN."""
    levels = int(view_layer.pass_cryptomatte_depth)
    return [name for kind in cryptomatte(view_layer) for name in crypto.passes(kind, levels)]


def aovs(view_layer) -> tuple[tuple[str, str], ...]:
    """The view layer's shader AOVs (View Layer > Shader AOV): (name, "COLOR" or "VALUE")
    each, those Blender marks invalid (a name used twice or a pass's) left out."""
    return tuple((aov.name, aov.type) for aov in view_layer.aovs if aov.is_valid)
