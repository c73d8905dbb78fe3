"""Blender materials -> ``core.scene.Material``.

Principled BSDF conversion (constant socket values):
    albedo = base_color (1 - metallic) (1 - transmission)
    rf0    = lerp(F0(ior) 2 specular_ior_level specular_tint, base_color, metallic),
             F0(ior) = ((ior - 1) / (ior + 1))^2, clamped to [0, 1]
    gloss  = brdf.roughness_to_gloss(roughness)
    emission = emission_color emission_strength
Any other surface node falls back to a grey dielectric; every fallback or ignored link gives one
warning naming the material and the node.
"""

import numpy as np

from ..core import brdf
from ..core.scene import Material


def _input(node, name, default):
    sock = node.inputs.get(name)
    if sock is None:
        return default
    value = sock.default_value
    try:
        return np.array(value[:], np.float32)
    except TypeError:
        return float(value)


def _surface_node(material):
    tree = material.node_tree if material is not None else None
    if tree is None:
        return None
    outputs = [n for n in tree.nodes if n.type == "OUTPUT_MATERIAL"]
    active = [n for n in outputs if n.is_active_output] or outputs
    if not active:
        return None
    links = active[0].inputs["Surface"].links
    return links[0].from_node if links else None


def convert_principled(node, name: str, warnings: list[str]) -> Material:
    """Read a Principled BSDF node's constant inputs into the talk's parameters."""
    linked = [s.name for s in node.inputs if s.is_linked and s.enabled]
    if linked:
        warnings.append(
            f"Material '{name}': inputs {', '.join(linked)} of '{node.name}' are connected to "
            "nodes; their unconnected values are used"
        )
    base = _input(node, "Base Color", np.full(4, 0.8, np.float32))[:3]
    metallic = float(np.clip(_input(node, "Metallic", 0.0), 0.0, 1.0))
    roughness = float(np.clip(_input(node, "Roughness", 0.5), 0.0, 1.0))
    ior = max(float(_input(node, "IOR", 1.5)), 1.0)
    level = float(_input(node, "Specular IOR Level", 0.5))
    tint = _input(node, "Specular Tint", np.ones(4, np.float32))
    tint = tint[:3] if np.ndim(tint) else np.full(3, tint, np.float32)
    transmission = float(np.clip(_input(node, "Transmission Weight", 0.0), 0.0, 1.0))
    f0 = ((ior - 1.0) / (ior + 1.0)) ** 2 * 2.0 * level
    dielectric = np.clip(f0 * tint, 0.0, 1.0)
    emission = _input(node, "Emission Color", np.zeros(4, np.float32))[:3]
    emission = emission * float(_input(node, "Emission Strength", 0.0))
    return Material(
        name=name,
        albedo=(base * (1.0 - metallic) * (1.0 - transmission)).astype(np.float32),
        rf0=(dielectric + (base - dielectric) * metallic).astype(np.float32),
        gloss=float(brdf.roughness_to_gloss(np.float32(roughness))),
        emission=emission.astype(np.float32),
    )


def convert_material(material, warnings: list[str]) -> Material:
    """One Blender material (or None for an empty slot) -> ``core.scene.Material``."""
    if material is None:
        return Material(name="(empty slot)")
    name = material.name
    culling = bool(getattr(material, "use_backface_culling", False))
    node = _surface_node(material)
    if node is not None and node.type == "BSDF_PRINCIPLED":
        result = convert_principled(node, name, warnings)
    elif node is not None and node.type == "EMISSION":
        color = _input(node, "Color", np.ones(4, np.float32))[:3]
        strength = float(_input(node, "Strength", 1.0))
        result = Material(name=name, albedo=np.zeros(3, np.float32), rf0=np.zeros(3, np.float32),
                          emission=(color * strength).astype(np.float32))
    else:
        kind = "no surface node" if node is None else f"node '{node.name}' ({node.bl_idname})"
        warnings.append(f"Material '{name}': {kind} is not supported; rendered as grey dielectric")
        color = np.array(material.diffuse_color[:3], np.float32)
        result = Material(name=name, albedo=color)
    result.backface_culling = culling
    return result
