"""Settings stored in .blend files: one PropertyGroup per ID type (``scene.bo2``)."""

import bpy

from ..core import brdf

_SPECULAR_DESCRIPTIONS = {
    "reference": ("Reference", "The talk's terms: Blinn-Phong NDF, Schlick Fresnel, Schlick-Smith"),
    "bo2": ("BO2 optimized", "Black Ops II bonus slides: 2^(-10 l.h) Fresnel, fast visibility"),
    "none": ("No visibility", "Visibility term V = 1"),
    "cook_torrance": ("Cook-Torrance", "Cook-Torrance geometry term"),
    "kelemen": ("Kelemen/Szirmay-Kalos", "Kelemen and Szirmay-Kalos visibility approximation"),
}


class BO2SceneSettings(bpy.types.PropertyGroup):
    """Render settings of the BO2 Lighting engine (``scene.bo2``)."""

    samples: bpy.props.IntProperty(
        name="Samples",
        description="Anti-aliasing samples per pixel",
        default=4, min=1, max=1024, soft_max=64,
    )
    specular_model: bpy.props.EnumProperty(
        name="Direct Specular",
        description="Terms of the direct specular BRDF",
        items=[(m, *_SPECULAR_DESCRIPTIONS[m]) for m in brdf.MODELS],
        default="reference",
    )


CLASSES = [BO2SceneSettings]


def attach() -> None:
    """Add the pointer properties to the ID types."""
    bpy.types.Scene.bo2 = bpy.props.PointerProperty(type=BO2SceneSettings)


def detach() -> None:
    """Remove what ``attach()`` added."""
    del bpy.types.Scene.bo2
