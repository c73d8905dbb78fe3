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
    shade_every_sample: bpy.props.BoolProperty(
        name="Shade Every Sample",
        description="Shade each anti-aliasing sample on its own instead of once per pixel and "
        "triangle: supersamples textures, highlights and shadow edges, at the cost of speed",
        default=False,
    )
    shadow_resolution: bpy.props.EnumProperty(
        name="Shadow Resolution",
        description="Size of each shadow map: per cube face, spot map or sun cascade",
        items=[(str(n), f"{n} px", "") for n in (256, 512, 1024, 2048, 4096)],
        default="1024",
    )
    specular_model: bpy.props.EnumProperty(
        name="Direct Specular",
        description="Terms of the direct specular BRDF",
        items=[(m, *_SPECULAR_DESCRIPTIONS[m]) for m in brdf.MODELS],
        default="reference",
    )


class BO2ViewLayerSettings(bpy.types.PropertyGroup):
    """Render passes of the BO2 Lighting engine beyond Blender's own (``view_layer.bo2``)."""

    use_pass_albedo: bpy.props.BoolProperty(
        name="Albedo", description="The talk's diffuse albedo after texture lookups")
    use_pass_specular_color: bpy.props.BoolProperty(
        name="Specular Color", description="The talk's rf0 after texture lookups")
    use_pass_gloss: bpy.props.BoolProperty(
        name="Gloss", description="Gloss after texture lookups (specular power 8192^gloss)")


CLASSES = [BO2SceneSettings, BO2ViewLayerSettings]


def attach() -> None:
    """Add the pointer properties to the ID types."""
    bpy.types.Scene.bo2 = bpy.props.PointerProperty(type=BO2SceneSettings)
    bpy.types.ViewLayer.bo2 = bpy.props.PointerProperty(type=BO2ViewLayerSettings)


def detach() -> None:
    """Remove what ``attach()`` added."""
    del bpy.types.Scene.bo2
    del bpy.types.ViewLayer.bo2
