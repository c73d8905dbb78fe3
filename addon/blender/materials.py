"""Blender materials -> ``core.scene.Material``; images -> ``core.texture.Texture``.

What the engine reads, per input socket: its constant value, or an Image Texture node linked to
it directly (Color or Alpha output; the node's extension and interpolation; sampled by the
mesh's active render UV map), and for Normal a Normal Map node (tangent space) fed by an Image
Texture. Surfaces it understands:

- Principled BSDF: base color, metallic, roughness, IOR, specular IOR level, specular tint,
  transmission and emission; converted to the talk's albedo, rf0 and gloss per pixel by
  ``core.surface.principled_to_talk`` (formulas in its module docstring).
- The BO2 Material node group: Albedo, Specular Color, Gloss, Normal, Emission, Emission
  Strength, read as they are.
- Emission: an emitter with no reflection. Diffuse BSDF: albedo = its colour, rf0 = 0.

Alpha (transparency, cut-outs) is not rendered yet: a material that uses it renders opaque, with
one warning.

Anything else (other shader nodes, node chains between a texture and a socket, a UV map other
than the active render one) falls back to the socket's own value, or for an unknown surface to a
grey dielectric with the viewport colour, with one warning naming the material and node. A
missing or unreadable image renders with the socket's value and one warning.
"""

from __future__ import annotations

import numpy as np

from ..core import texture
from ..core.scene import Material, NormalMap, Principled, TextureInput
from . import images
from .node_groups import is_bo2_material_node

_cache: dict[tuple, texture.Texture] = {}


def _image_key(image) -> tuple:
    return (image.name_full, image.filepath_raw, tuple(image.size),
            image.colorspace_settings.name, image.source, bool(image.is_float))


def load_image(image, extension: str, interpolation: str, warnings: list[str], where: str):
    """A Blender image as a mipmapped linear ``Texture``, or None (with a warning) if unusable."""
    if image is None:
        warnings.append(f"{where}: the Image Texture node has no image; its socket value is used")
        return None
    key = _image_key(image) + (extension, interpolation)
    if key in _cache and not image.is_dirty:
        return _cache[key]
    width, height = image.size
    if not image.has_data:
        try:
            image.pixels[0]  # loads the image from its file when it can be loaded
        except (IndexError, RuntimeError):
            pass
        width, height = image.size
    if width == 0 or height == 0 or not image.has_data:
        warnings.append(f"{where}: image '{image.name}' could not be loaded "
                        f"({image.filepath or 'no file'}); its socket value is used")
        return None
    pixels = images.image_pixels(image)
    # Byte images hold encoded values; float images are already scene-linear in memory.
    srgb = not image.is_float and image.colorspace_settings.name == "sRGB"
    tex = texture.make_texture(pixels, srgb=srgb, extension=extension,
                               interpolation=interpolation, name=image.name)
    _cache[key] = tex
    return tex


def _linked_node(socket):
    links = socket.links if socket is not None else ()
    return (links[0].from_node, links[0].from_socket) if links else (None, None)


def _texture_input(node, socket_name: str, material_name: str, warnings: list[str]):
    """A TextureInput when an Image Texture feeds the socket directly, else None (+ warning)."""
    sock = node.inputs.get(socket_name)
    src, out = _linked_node(sock)
    if src is None:
        return None
    where = f"Material '{material_name}'"
    if src.type != "TEX_IMAGE":
        warnings.append(f"{where}: node '{src.name}' ({src.bl_idname}) feeding "
                        f"'{socket_name}' is not supported; the socket's value is used")
        return None
    uv_src, _ = _linked_node(src.inputs.get("Vector"))
    if uv_src is not None and not (uv_src.type == "UVMAP" or
                                   (uv_src.type == "TEX_COORD")):
        warnings.append(f"{where}: node '{uv_src.name}' on the vector of '{src.name}' is not "
                        "supported; the active render UV map is used")
    tex = load_image(src.image, src.extension, src.interpolation, warnings,
                     f"{where}, node '{src.name}'")
    if tex is None:
        return None
    return TextureInput(tex, channel="alpha" if out.name == "Alpha" else "color")


def _value(node, name: str, default, material_name: str, warnings: list[str]):
    """A socket's texture input if any, else its constant: float or (3,) float32."""
    tex = _texture_input(node, name, material_name, warnings)
    if tex is not None:
        return tex
    sock = node.inputs.get(name)
    if sock is None:
        return default
    value = sock.default_value
    try:
        return np.array(value[:3], np.float32)
    except TypeError:
        return float(value)


def _normal_map(node, material_name: str, warnings: list[str]) -> NormalMap | None:
    src, _ = _linked_node(node.inputs.get("Normal"))
    if src is None:
        return None
    if src.type != "NORMAL_MAP" or src.space != "TANGENT":
        warnings.append(f"Material '{material_name}': node '{src.name}' on Normal is not a "
                        "tangent-space Normal Map; the surface normal is used")
        return None
    tex = _texture_input(src, "Color", material_name, warnings)
    if tex is None:
        return None
    return NormalMap(tex, strength=float(src.inputs["Strength"].default_value))


def _principled(node, name: str, warnings: list[str]) -> Material:
    def v(socket, default):
        return _value(node, socket, default, name, warnings)

    tint = node.inputs.get("Specular Tint")
    tint = (np.array(tint.default_value[:3], np.float32) if tint is not None
            and hasattr(tint.default_value, "__len__") else np.ones(3, np.float32))
    emission_strength = node.inputs.get("Emission Strength")
    return Material(
        name=name,
        principled=Principled(
            base_color=v("Base Color", np.full(3, 0.8, np.float32)),
            metallic=v("Metallic", 0.0),
            roughness=v("Roughness", 0.5),
            ior=float(node.inputs["IOR"].default_value) if "IOR" in node.inputs else 1.5,
            specular_level=v("Specular IOR Level", 0.5),
            specular_tint=tint,
            transmission=float(node.inputs["Transmission Weight"].default_value)
            if "Transmission Weight" in node.inputs else 0.0,
        ),
        emission=v("Emission Color", np.zeros(3, np.float32)),
        emission_strength=float(emission_strength.default_value) if emission_strength else 0.0,
        normal_map=_normal_map(node, name, warnings),
    )


def _check_alpha(node, name: str, warnings: list[str]) -> None:
    """Transparency is not rendered: say so once when a material asks for it."""
    sock = node.inputs.get("Alpha")
    if sock is not None and (sock.is_linked or float(sock.default_value) < 1.0):
        warnings.append(f"Material '{name}': Alpha is not supported by BO2 Lighting yet; "
                        "the surface renders opaque")


def _bo2_group(node, name: str, warnings: list[str]) -> Material:
    def v(socket, default):
        return _value(node, socket, default, name, warnings)

    strength = v("Emission Strength", 1.0)
    if isinstance(strength, TextureInput):
        warnings.append(f"Material '{name}': a texture on Emission Strength is not supported")
        strength = float(node.inputs["Emission Strength"].default_value)
    return Material(
        name=name,
        albedo=v("Albedo", np.full(3, 0.8, np.float32)),
        rf0=v("Specular Color", np.full(3, 0.04, np.float32)),
        gloss=v("Gloss", 0.5),
        emission=v("Emission", np.zeros(3, np.float32)),
        emission_strength=float(strength),
        normal_map=_normal_map(node, name, warnings),
    )


def _surface_node(material):
    tree = material.node_tree if material is not None else None
    if tree is None:
        return None
    outputs = [n for n in tree.nodes if n.type == "OUTPUT_MATERIAL"]
    active = [n for n in outputs if n.is_active_output] or outputs
    if not active:
        return None
    src, _ = _linked_node(active[0].inputs["Surface"])
    return src


def convert_material(material, warnings: list[str]) -> Material:
    """One Blender material (or None for an empty slot) -> ``core.scene.Material``."""
    if material is None:
        return Material(name="(empty slot)")
    name = material.name
    node = _surface_node(material)
    if node is not None and node.type == "BSDF_PRINCIPLED":
        result = _principled(node, name, warnings)
        _check_alpha(node, name, warnings)
    elif node is not None and is_bo2_material_node(node):
        result = _bo2_group(node, name, warnings)
        _check_alpha(node, name, warnings)
    elif node is not None and node.type == "EMISSION":
        result = Material(name=name, albedo=np.zeros(3, np.float32),
                          rf0=np.zeros(3, np.float32),
                          emission=_value(node, "Color", np.ones(3, np.float32), name, warnings),
                          emission_strength=float(node.inputs["Strength"].default_value))
    elif node is not None and node.type == "BSDF_DIFFUSE":
        result = Material(name=name, rf0=np.zeros(3, np.float32),
                          albedo=_value(node, "Color", np.full(3, 0.8, np.float32), name,
                                        warnings),
                          normal_map=_normal_map(node, name, warnings))
    else:
        kind = "no surface node" if node is None else f"node '{node.name}' ({node.bl_idname})"
        warnings.append(f"Material '{name}': {kind} is not supported; rendered as a grey "
                        "dielectric with the material's viewport colour")
        result = Material(name=name, albedo=np.array(material.diffuse_color[:3], np.float32))
    result.backface_culling = bool(getattr(material, "use_backface_culling", False))
    result.pass_index = int(material.pass_index)
    return result
