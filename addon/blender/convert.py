"""Principled BSDF <-> BO2 Material: converting a material's surface, both ways.

To BO2: the Principled BSDF's inputs (their links or values) go through **BO2 Principled to
Talk** (``core.scene.nodes.principled_to_talk`` in nodes, docs/engine.md) into a **BO2
Material**; Normal, Emission and Alpha go straight across. Textured materials stay textured.

Back: a BO2 Material fed by BO2 Principled to Talk gets its Principled BSDF back exactly (the
same links and values). Otherwise its constant albedo a, rf0 r and gloss g are inverted for a
Principled with IOR 1.5 (dielectric F0 = 0.04): with s = mean(a + r) and the mean albedo a_m,
1 - metallic = u = (s - sqrt(s^2 - 0.16 a_m)) / 0.08 solves a = b u, r = 0.04 u + b (1 - u) for
a grey F0; Base Color = a + r - 0.04 u. A dielectric (metallic 0) keeps Base Color = a and takes
rf0 through Specular IOR Level = mean(r) / 0.08 and Specular Tint = r / mean(r); roughness is
``brdf.gloss_to_roughness(g)``. Linked albedo, rf0 or gloss without that group cannot be
inverted: the conversion refuses and names them.
"""

from __future__ import annotations

import numpy as np

from ..core.formulas import brdf
from ..core.scene.nodes import principled_to_talk
from . import node_groups

_TALK_INPUTS = ("Base Color", "Metallic", "Roughness", "IOR", "Specular IOR Level",
                "Specular Tint", "Transmission Weight")
_ACROSS = {"Normal": "Normal", "Emission Color": "Emission",
           "Emission Strength": "Emission Strength", "Alpha": "Alpha"}  # Principled -> BO2
_NOT_TALK = ("Coat Weight", "Sheen Weight", "Subsurface Weight")
_PARAMS = ("Albedo", "Specular Color", "Gloss")  # BO2 Principled to Talk -> BO2 Material


class ConvertError(Exception):
    """The material cannot be converted; one-line message."""


def surface_node(material):
    """(tree, output node, the node on its Surface) of ``material``; raises ConvertError."""
    tree = material.node_tree if material is not None else None
    if tree is None:
        raise ConvertError("the material has no node tree")
    output = next((n for n in tree.nodes if n.type == "OUTPUT_MATERIAL" and n.is_active_output),
                  None)
    if output is None or not output.inputs["Surface"].is_linked:
        raise ConvertError(f"material '{material.name}' has no surface on its Material Output")
    return tree, output, output.inputs["Surface"].links[0].from_node


def _carry(tree, src, dst) -> None:
    """Give input socket ``dst`` what ``src`` has: its link, else its value."""
    if src.is_linked:
        tree.links.new(src.links[0].from_socket, dst)
    elif hasattr(dst, "default_value"):
        value = src.default_value
        try:
            dst.default_value = value
        except (TypeError, ValueError):  # colour <-> vector widths
            dst.default_value = tuple(value)[:len(dst.default_value)]


def talk_values(node) -> dict | None:
    """The talk's albedo, rf0 (3,) and gloss of a Principled BSDF ``node`` whose inputs that
    matter are constants, or None when some are linked (they vary over the surface)."""
    if any(node.inputs[name].is_linked for name in _TALK_INPUTS):
        return None
    v = {name: np.atleast_2d(np.asarray(node.inputs[name].default_value, np.float64))
         for name in _TALK_INPUTS}
    albedo, rf0, gloss = principled_to_talk(
        v["Base Color"][:, :3], v["Metallic"], v["Roughness"], v["IOR"],
        v["Specular IOR Level"], v["Specular Tint"][:, :3], v["Transmission Weight"])
    return {"albedo": albedo[0], "rf0": rf0[0], "gloss": float(gloss.reshape(-1)[0])}


def to_bo2(material) -> list[str]:
    """Convert the Principled BSDF on ``material``'s surface to a BO2 Material; returns
    warnings (inputs the talk's model has no place for)."""
    tree, output, node = surface_node(material)
    if node.type != "BSDF_PRINCIPLED":
        raise ConvertError(f"the surface of '{material.name}' is '{node.name}', not a "
                           "Principled BSDF")
    warnings = [f"'{name}' of '{node.name}' is not part of the talk's model and is dropped"
                for name in _NOT_TALK if name in node.inputs and (
                    node.inputs[name].is_linked or node.inputs[name].default_value > 0.0)]
    _check_sockets(node_groups.ensure_group(node_groups.PRINCIPLED_GROUP), _TALK_INPUTS, _PARAMS)
    _check_sockets(node_groups.ensure_group(node_groups.MATERIAL_GROUP),
                   (*_PARAMS, *_ACROSS.values()), ("BSDF",))
    x, y = node.location
    added = []
    try:
        params = tree.nodes.new("ShaderNodeGroup")
        added.append(params)
        params.node_tree = node_groups.ensure_group(node_groups.PRINCIPLED_GROUP)
        params.location = (x - 220.0, y)
        bo2 = node_groups.add_material_node(tree, (x + 60.0, y))
        added.append(bo2)
        for name in _TALK_INPUTS:
            _carry(tree, node.inputs[name], params.inputs[name])
        for name in _PARAMS:
            tree.links.new(params.outputs[name], bo2.inputs[name])
        for src, dst in _ACROSS.items():
            _carry(tree, node.inputs[src], bo2.inputs[dst])
        tree.links.new(bo2.outputs["BSDF"], output.inputs["Surface"])
    except Exception:
        for new in added:  # the tree as it was
            tree.nodes.remove(new)
        raise
    tree.nodes.remove(node)
    return warnings


def _check_sockets(tree, inputs, outputs) -> None:
    """Raise ConvertError unless node group ``tree`` (as the file has it: the user may have
    edited it) has these input and output sockets."""
    have = {(item.in_out, item.name) for item in tree.interface.items_tree
            if item.item_type == "SOCKET"}
    missing = [name for kind, names in (("INPUT", inputs), ("OUTPUT", outputs))
               for name in names if (kind, name) not in have]
    if missing:
        raise ConvertError(f"node group '{tree.name}' has no socket {', '.join(missing)} "
                           "(edited?); rename it so that the add-on builds it again")


def invert(albedo, rf0, gloss) -> dict:
    """Principled BSDF inputs of constant talk parameters (module docstring): Base Color,
    Metallic, Roughness, Specular IOR Level, Specular Tint; albedo, rf0 (3,), gloss scalar."""
    a = np.clip(np.asarray(albedo, np.float64)[:3], 0.0, 1.0)
    r = np.clip(np.asarray(rf0, np.float64)[:3], 0.0, 1.0)
    s, a_m, r_m = float(np.mean(a + r)), float(np.mean(a)), float(np.mean(r))
    u = float(np.clip((s - np.sqrt(max(s * s - 0.16 * a_m, 0.0))) / 0.08, 0.0, 1.0))
    roughness = float(brdf.gloss_to_roughness(np.float64(gloss)))
    if u >= 1.0 - 1e-6:  # a dielectric: its rf0 through the specular level and tint
        tint = r / r_m if r_m > 0 else np.ones(3)
        return {"Base Color": (*a, 1.0), "Metallic": 0.0, "Roughness": roughness,
                "Specular IOR Level": float(np.clip(r_m / 0.08, 0.0, 1.0)),
                "Specular Tint": (*np.clip(tint, 0.0, 1.0), 1.0)}
    base = np.clip(a + r - 0.04 * u, 0.0, 1.0)
    return {"Base Color": (*base, 1.0), "Metallic": 1.0 - u, "Roughness": roughness,
            "Specular IOR Level": 0.5, "Specular Tint": (1.0, 1.0, 1.0, 1.0)}


def to_principled(material) -> None:
    """Convert the BO2 Material on ``material``'s surface back to a Principled BSDF."""
    tree, output, node = surface_node(material)
    if not node_groups.is_bo2_material_node(node):
        raise ConvertError(f"the surface of '{material.name}' is '{node.name}', not a BO2 "
                           "Material")
    _check_sockets(node.node_tree, (*_PARAMS, *_ACROSS.values()), ("BSDF",))
    feeds = {name: node.inputs[name].links[0].from_node if node.inputs[name].is_linked else None
             for name in _PARAMS}
    params = next(iter(feeds.values()))
    exact = params is not None and all(f == params for f in feeds.values()) and (
        params.type == "GROUP" and params.node_tree is not None
        and params.node_tree.name.startswith(node_groups.PRINCIPLED_GROUP))
    linked = [name for name, f in feeds.items() if f is not None]
    if linked and not exact:
        raise ConvertError(f"'{node.name}' has {', '.join(linked)} linked to other nodes: "
                           "only constant values (or BO2 Principled to Talk) can be converted "
                           "back")
    if exact:
        _check_sockets(params.node_tree, _TALK_INPUTS, _PARAMS)
    principled = tree.nodes.new("ShaderNodeBsdfPrincipled")
    try:
        principled.location = node.location
        if exact:
            for name in _TALK_INPUTS:
                _carry(tree, params.inputs[name], principled.inputs[name])
        else:
            values = invert(node.inputs["Albedo"].default_value[:3],
                            node.inputs["Specular Color"].default_value[:3],
                            node.inputs["Gloss"].default_value)
            principled.inputs["IOR"].default_value = 1.5
            for name, value in values.items():
                principled.inputs[name].default_value = value
        for src, dst in _ACROSS.items():
            _carry(tree, node.inputs[dst], principled.inputs[src])
        tree.links.new(principled.outputs["BSDF"], output.inputs["Surface"])
    except Exception:
        tree.nodes.remove(principled)  # the tree as it was
        raise
    tree.nodes.remove(node)
    if exact and not any(link.from_node == params for link in tree.links):
        tree.nodes.remove(params)
