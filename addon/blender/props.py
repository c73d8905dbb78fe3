"""Settings stored in .blend files: one PropertyGroup per ID type (``scene.bo2``,
``object.bo2``, ``view_layer.bo2``); the scene's in one group per Render panel
(``scene.bo2.indirect``, ``.probes``, ``.lightmaps``, ``.viewport``, ``.lookdev``)."""

import bpy

from ..core.render import viewport
from ..core.scene import CHOICES


def _items(setting: str) -> list[tuple[str, str, str]]:
    """An EnumProperty's items: the core's ``CHOICES`` of ``setting``."""
    return [(c.id, c.label, c.description) for c in CHOICES[setting]]


# Renderers of the probes' captures (``scene.bo2.probes.backend``, the preferences' default)
_BACKENDS = [
    ("BO2", "BO2 Lighting", "The engine's own pipeline: direct light, shadows, the world and "
     "the previous bounce's probes (fast)"),
    ("CYCLES", "Cycles", "Cycles path tracing: full global illumination (slow)"),
]


class BO2IndirectSettings(bpy.types.PropertyGroup):
    """Indirect light of renders and bakes (``scene.bo2.indirect``; Render > BO2 Lighting
    > Indirect Light)."""

    use: bpy.props.BoolProperty(
        name="Indirect Light",
        description="Light surfaces by the world and the baked light probes (indirect diffuse "
        "from SH irradiance, indirect specular from prefiltered cube maps; slide 'Getting More "
        "Physical in Call of Duty: Black Ops II', Indirect Specular)",
        default=True,
    )
    normalization: bpy.props.EnumProperty(
        name="Normalization",
        description="Environment map normalization: how a reflection probe's cube map is "
        "fitted to the lighting at each pixel (slides 'Black Ops: environment map "
        "normalization', 'Improved normalization algorithm')",
        items=_items("normalization"),
        default="bo2",
    )
    prefilter: bpy.props.EnumProperty(
        name="Prefilter",
        description="Filter of the reflection probes' mip chains (both are baked)",
        items=_items("prefilter"),
        default="bo2",
    )
    env_brdf: bpy.props.EnumProperty(
        name="Environment BRDF",
        description="Environment BRDF that scales indirect specular (reflections); slides "
        "'Environment BRDF: old method' and 'new method'",
        items=_items("env_brdf"),
        default="bo2",
    )
    sky_directions: bpy.props.EnumProperty(
        name="World Occlusion",
        description="The world lights a point in proportion to the sky it sees: a dome of "
        "shadow maps, one per direction, occludes the world's light in renders and bakes "
        "(Off: the world reaches every point, as if nothing stood around it)",
        items=[("0", "Off", "The world's light reaches every point")]
        + [(str(n), f"{n} Directions", "") for n in (16, 32, 64, 128, 256)],
        default="32",
    )
    sky_resolution: bpy.props.EnumProperty(
        name="Occlusion Resolution",
        description="Size of each shadow map of the world's dome",
        items=[(str(n), f"{n} px", "") for n in (128, 256, 512)],
        default="256",
    )
    use_implicit_bounce: bpy.props.BoolProperty(
        name="Bounce Without Probes",
        description="A scene without a Volume light probe still gets the light that bounces "
        "off its surfaces (the ground under objects): a coarse volume over the scene, baked "
        "on the first frame of each content and kept",
        default=True,
    )
    use_wall_extrapolation: bpy.props.BoolProperty(
        name="Extrapolate to Walls",
        description="Past a Volume probe's outermost samples, up to its box's faces, "
        "extrapolate their light rather than hold it (a wall half a cell beyond the samples "
        "then gets the light at the wall, not the light a sample sees inside the room)",
        default=False,
    )
    use_visibility_test: bpy.props.BoolProperty(
        name="Visibility Test",
        description="Each sample of a Volume probe lights only the points it sees, as its "
        "bake measured the distances around it (samples beyond a wall give nothing to the "
        "room); bakes made before this test have none, and are looked up without it",
        default=True,
    )
    use_nearest_reflections: bpy.props.BoolProperty(
        name="Nearest Reflections",
        description="Beyond every Sphere probe's influence, where the world is hidden (World "
        "Occlusion), reflect the nearest Sphere probes rather than the world: a metal in a "
        "corner no probe reaches reflects the room, not the sky. Slower: the world's "
        "visibility is found for every such point",
        default=False,
    )
    use_ambient_occlusion: bpy.props.BoolProperty(
        name="Ambient Occlusion",
        description="Contact occlusion of probe and world light: the frame's own surfaces "
        "within Distance darken corners, contacts and what stands under furniture "
        "(ground-truth-based ambient occlusion)",
        default=True,
    )
    ao_distance: bpy.props.FloatProperty(
        name="Distance", description="How far surfaces occlude the indirect light",
        default=0.25, min=0.0, soft_max=5.0, subtype="DISTANCE", unit="LENGTH",
    )
    use_specular_occlusion: bpy.props.BoolProperty(
        name="Specular Occlusion",
        description="Occlude reflections as well, from the ambient occlusion, the view angle "
        "and the gloss (Lagarde and de Rousiers 2014)",
        default=True,
    )


class BO2ProbeSettings(bpy.types.PropertyGroup):
    """How the light probes are baked (``scene.bo2.probes``; Render > BO2 Lighting
    > Light Probes)."""

    backend: bpy.props.EnumProperty(
        name="Bake With",
        description="Renderer of the probes' captures",
        items=[("DEFAULT", "Default", "The Default Capture Backend of the add-on's "
                "preferences"), *_BACKENDS],
        default="DEFAULT",
    )
    face_size: bpy.props.EnumProperty(
        name="Cube Size",
        description="Face size of the reflection probes' cube maps (slide 'Improved environment "
        "map pre-filtering': 128, the top mip tied to the largest specular power)",
        items=[(str(n), f"{n} px", "") for n in (32, 64, 128, 256, 512)],
        default="128",
    )
    volume_face_size: bpy.props.EnumProperty(
        name="Irradiance Cube Size",
        description="Face size of the captures at each irradiance volume sample (only their "
        "SH is kept, so small sizes suffice; slide 'Improved normalization algorithm', "
        "Offline)",
        items=[(str(n), f"{n} px", "") for n in (8, 16, 32, 64, 128)],
        default="32",
    )
    bounces: bpy.props.IntProperty(
        name="Bounces",
        description="Light bounces of the bake (BO2 backend): each bounce's captures are lit "
                    "by the previous bounce's probes, diffuse and specular. With the render's "
                    "own bounce, 3 matches Cycles' default of 4 diffuse bounces",
        default=3, min=1, max=16,
    )
    converge: bpy.props.BoolProperty(
        name="Converge Bounces",
        description="Add the bounces after the last, estimated from the last three as a "
                    "geometric series (3 bounces or more), at no extra bake time",
        default=False,
    )
    samples: bpy.props.IntProperty(
        name="Bake Samples",
        description="Anti-aliasing samples per pixel of the captures (BO2 backend; Cycles uses "
        "its own sample count)",
        default=4, min=1, max=64,
    )
    cycles_samples: bpy.props.IntProperty(
        name="Cycles Samples",
        description="Path-tracing samples per pixel of the captures (Cycles backend)",
        default=64, min=1, max=65536, soft_max=4096,
    )


class BO2LightmapSettings(bpy.types.PropertyGroup):
    """Lightmaps of the scene's static objects (``scene.bo2.lightmaps``; Render > BO2 Lighting
    > Lightmaps)."""

    use: bpy.props.BoolProperty(
        name="Lightmaps",
        description="Static objects with a baked lightmap take their diffuse indirect light "
        "from it (and the BO2 normalization its irradiance); off: from the probes",
        default=True,
    )
    density: bpy.props.FloatProperty(
        name="Texels per Metre",
        description="Density of the lightmaps the bake lays out (an object can ask for its own)",
        default=20.0, min=0.1, max=1000.0, soft_max=200.0,
    )
    max_resolution: bpy.props.EnumProperty(
        name="Max Resolution",
        description="No lightmap is larger than this on a side; a larger object gets a lower "
        "density",
        items=[(str(n), f"{n} px", "") for n in (128, 256, 512, 1024, 2048, 4096)],
        default="1024",
    )
    padding: bpy.props.IntProperty(
        name="Padding",
        description="Texels between the charts of a layout the bake makes (the lightmap is "
        "dilated into them, so bilinear look-ups and mips do not bleed)",
        default=2, min=1, max=16,
    )
    rays: bpy.props.IntProperty(
        name="Rays",
        description="Rays per texel and bounce of the BO2 lightmap bake (more: less noise)",
        default=256, min=4, max=4096, soft_max=1024,
    )
    bounces: bpy.props.IntProperty(
        name="Bounces",
        description="Gathers of the lightmap bake: the first sees direct light, emission and "
        "the world; each further one adds a bounce, and the last also sees the bounces after "
        "it, estimated from the series of the ones before",
        default=4, min=1, max=16,
    )
    directional: bpy.props.BoolProperty(
        name="Directional",
        description="Store the L1 SH of the incoming light per texel (4 x RGB) so normal maps "
        "keep their relief under baked light (beyond the talk: as Bakery's SH and Godot's "
        "directional lightmaps)",
        default=False,
    )
    denoise: bpy.props.BoolProperty(
        name="Denoise",
        description="Filter each chart with an edge-avoiding filter guided by position, normal "
        "and the noise of each texel (it never crosses a chart's edge)",
        default=True,
    )


class BO2ViewportSettings(bpy.types.PropertyGroup):
    """The viewport's Rendered shading (``scene.bo2.viewport``; Render > BO2 Lighting
    > Viewport)."""

    samples: bpy.props.IntProperty(
        name="Viewport Samples",
        description="Anti-aliasing samples per pixel of the viewport's Rendered shading, "
        "added one at a time after a first image at a quarter of the resolution",
        default=8, min=1, max=1024, soft_max=64,
    )


class BO2LookDevSettings(bpy.types.PropertyGroup):
    """Comparisons with Cycles and the look-dev review (``scene.bo2.lookdev``; Render > BO2 Lighting
    > Look-Dev)."""

    compare_folder: bpy.props.StringProperty(
        name="Compare Folder",
        description="Folder of Compare with Cycles: both renders as EXR, the side-by-side, "
        "split and difference pictures and metrics.json ('//' is the .blend's folder)",
        default="//bo2_compare/",
        subtype="DIR_PATH",
        options={"PATH_SUPPORTS_BLEND_RELATIVE"},
    )
    report_source: bpy.props.EnumProperty(
        name="Review",
        description="What the look-dev review compares with Cycles",
        items=[
            ("SCENES", "This File's Scenes",
             "Render every scene of this file that has a camera, with both engines"),
            ("FOLDER", "Compare Folders",
             "Read back the Compare with Cycles (bo2 compare) folders inside a folder, "
             "without rendering"),
        ],
        default="SCENES",
    )
    report_source_folder: bpy.props.StringProperty(
        name="Compare Folders",
        description="A Compare with Cycles folder, or a folder of them, for the review",
        default="//",
        subtype="DIR_PATH",
        options={"PATH_SUPPORTS_BLEND_RELATIVE"},
    )
    report_old_methods: bpy.props.BoolProperty(
        name="Old Methods Too",
        description="Also render BO2 Lighting with the talk's old methods (BO1 environment "
        "BRDF, normalization and prefilter), for the page's old/new toggle",
        default=False,
    )
    report_folder: bpy.props.StringProperty(
        name="Report Folder",
        description="Folder of the look-dev review: index.html (open it in a web browser), "
        "report.json and each scene's renders and pictures ('//' is the .blend's folder)",
        default="//bo2_report/",
        subtype="DIR_PATH",
        options={"PATH_SUPPORTS_BLEND_RELATIVE"},
    )


# Where frames are drawn (``scene.bo2.device``)
DEVICES = [
    ("AUTO", "Auto", "The GPU where this Blender has one (in background mode: checked once "
     "per session), else the CPU; a software rasterizer (llvmpipe) is left to the CPU "
     "kernels, which are faster there. A frame with what the GPU does not draw yet is "
     "rendered on the CPU, and the status line says why"),
    ("GPU", "GPU", "Draw the talk's model as shaders through Blender's GPU module; frames the "
     "GPU cannot draw fall back to the CPU with one message"),
    ("CPU", "CPU", "The engine's CPU kernels: the reference every GPU stage is tested "
     "against"),
]


class BO2SceneSettings(bpy.types.PropertyGroup):
    """Render settings of the BO2 Lighting engine (``scene.bo2``): the main panel's, where the
    bakes are kept, and one group per sub-panel."""

    device: bpy.props.EnumProperty(
        name="Device",
        description="Where the viewport and renders are drawn",
        items=DEVICES,
        default="AUTO",
    )

    samples: bpy.props.IntProperty(
        name="Samples",
        description="Anti-aliasing samples per pixel of a final render",
        default=4, min=1, max=1024, soft_max=64,
    )
    shade_every_sample: bpy.props.BoolProperty(
        name="Shade Every Sample",
        description="Shade each anti-aliasing sample on its own instead of once per pixel and "
        "triangle: supersamples textures, highlights and shadow edges, at the cost of speed",
        default=False,
    )
    blend_sort: bpy.props.EnumProperty(
        name="Blended Order",
        description="The order materials of Render Method Blended are composited in",
        items=_items("blend_sort"),
        default="pixel",
    )
    specular_model: bpy.props.EnumProperty(
        name="Direct Specular",
        description="Terms of the direct specular BRDF (slide 'Black Ops: Microfacet BRDF' and "
        "the bonus slides)",
        items=_items("specular_model"),
        default="reference",
    )
    use_layered_diffuse: bpy.props.BoolProperty(
        name="Layered Diffuse",
        description="Weight a Principled BSDF's diffuse by one less its specular's albedo "
        "toward the eye, as Cycles and EEVEE layer it (the talk adds the two; the BO2 "
        "Material group always adds them)",
        default=False,
    )
    shadow_resolution: bpy.props.EnumProperty(
        name="Shadow Resolution",
        description="Size of each shadow map: per cube face, spot map or sun cascade",
        items=[(str(n), f"{n} px", "") for n in (256, 512, 1024, 2048, 4096)],
        default="1024",
    )
    bake_folder: bpy.props.StringProperty(
        name="Bake Folder",
        description="Folder of the bakes: each .blend's go into a folder named after it "
        "inside, one OpenEXR file per probe or lightmap ('//' is the .blend's folder; empty: "
        "the Default Bake Folder of the add-on's preferences)",
        default="",
        subtype="DIR_PATH",
    )
    bake_pack: bpy.props.BoolProperty(
        name="Pack Bakes",
        description="Store new bakes (probes and lightmaps) inside the .blend, as EEVEE "
        "does, so that a saved file carries its light to another machine or a farm; off: "
        "only in the bake folder, declared as external files",
        default=True,
    )
    bake_on: bpy.props.EnumProperty(
        name="Bake On",
        description="Where the bakes (probes and lightmaps) run",
        items=[("LOCAL", "This Machine", "Bake in this Blender"),
               ("CLUSTER", "Dask Cluster", "Bake on the workers of a Dask scheduler (bo2 "
                "worker ADDRESS on each machine): the .blend is sent to them, packed, and the "
                "bakes written here")],
        default="LOCAL",
    )
    scheduler: bpy.props.StringProperty(
        name="Scheduler",
        description="Address of the Dask scheduler that bakes of this scene run on "
        "(tcp://host:8786); empty: the Dask Scheduler of the add-on's preferences",
        default="",
    )
    bakes_adopted: bpy.props.BoolProperty(
        name="Bakes Adopted",
        description="The bakes of earlier versions were looked for (once per scene)",
        default=False,
        options={"HIDDEN"},
    )
    indirect: bpy.props.PointerProperty(
        type=BO2IndirectSettings, name="Indirect Light",
        description="Indirect light of renders and bakes: the world, the probes, occlusion")
    probes: bpy.props.PointerProperty(
        type=BO2ProbeSettings, name="Light Probes",
        description="How the light probes are baked")
    lightmaps: bpy.props.PointerProperty(
        type=BO2LightmapSettings, name="Lightmaps",
        description="Lightmaps of the static objects: their use and their bake")
    viewport: bpy.props.PointerProperty(
        type=BO2ViewportSettings, name="Viewport",
        description="The viewport's Rendered shading")
    lookdev: bpy.props.PointerProperty(
        type=BO2LookDevSettings, name="Look-Dev",
        description="Comparisons with Cycles and the look-dev review")


class BO2ObjectSettings(bpy.types.PropertyGroup):
    """Lightmap settings of one object and its bake (``object.bo2``)."""

    bake: bpy.props.PointerProperty(
        name="Bake",
        description="The image datablock that declares this object's bake file (a light "
        "probe's, or a mesh's lightmap): its path, or its packed bytes",
        type=bpy.types.Image,
    )
    lightmap_mode: bpy.props.EnumProperty(
        name="Lightmap",
        description="Whether the object gets a lightmap",
        items=[("AUTO", "Auto", "Static when it has no animation and no armature"),
               ("STATIC", "Static", "Baked into a lightmap"),
               ("DYNAMIC", "Dynamic", "Lit by the probes, no lightmap")],
        default="AUTO",
    )
    lightmap_uv: bpy.props.StringProperty(
        name="Lightmap UV",
        description="The object's UV map laid out for its lightmap (charts that do not "
        "overlap); empty: the map named LightmapUV, else a layout the bake makes (your UV "
        "maps stay as they are)",
        default="",
    )
    lightmap_density: bpy.props.FloatProperty(
        name="Texels per Metre",
        description="This object's lightmap density; 0: the scene's",
        default=0.0, min=0.0, max=1000.0, soft_max=200.0,
    )
    use_lightmap: bpy.props.BoolProperty(
        name="Use Lightmap",
        description="Render with its baked lightmap (off: the probes light it, as a dynamic "
        "object)",
        default=True,
    )


class BO2ViewLayerSettings(bpy.types.PropertyGroup):
    """Render passes of the BO2 Lighting engine beyond Blender's own (``view_layer.bo2``)."""

    use_pass_albedo: bpy.props.BoolProperty(
        name="Albedo", description="The talk's diffuse albedo after texture lookups")
    use_pass_specular_color: bpy.props.BoolProperty(
        name="Specular Color", description="The talk's rf0 after texture lookups")
    use_pass_gloss: bpy.props.BoolProperty(
        name="Gloss", description="Gloss after texture lookups (specular power 8192^gloss)")
    use_pass_lightmap: bpy.props.BoolProperty(
        name="Lightmap", description="The irradiance the baked lightmaps give (0 where an "
        "object has none)")
    use_pass_lightmap_texels: bpy.props.BoolProperty(
        name="Lightmap Texels", description="Each lightmap's texels as a checker of its own "
        "hue: their density on the surfaces")
    use_pass_shadow_catcher: bpy.props.BoolProperty(
        name="Shadow Catcher", description="On shadow catchers the share of the lights' light "
        "their shadows let through, 1 elsewhere: multiply a backplate by it (Cycles' pass)")


def _tag_scene(self, context) -> None:
    """A setting changed: tag the scene, so the viewport's depsgraph update sees it."""
    self.id_data.update_tag()


def _tagging(cls):
    """``cls`` with every property calling ``_tag_scene`` on change."""
    for name, prop in cls.__annotations__.items():
        cls.__annotations__[name] = prop.function(**{**prop.keywords, "update": _tag_scene})
    return cls


_tagging(BO2IndirectSettings)
_tagging(BO2ProbeSettings)
_tagging(BO2LightmapSettings)
_tagging(BO2ViewportSettings)
_tagging(BO2LookDevSettings)
_tagging(BO2SceneSettings)
_tagging(BO2ObjectSettings)

_PACKAGE = __package__.rpartition(".")[0].rpartition(".")[0]  # the extension's module name


class BO2Preferences(bpy.types.AddonPreferences):
    """The add-on's preferences: defaults of new scenes."""

    bl_idname = _PACKAGE

    bake_folder: bpy.props.StringProperty(
        name="Default Bake Folder",
        description="Bake folder of scenes whose own Bake Folder is empty ('//' is the "
        ".blend's folder)",
        default="//bo2_bake/",
        subtype="DIR_PATH",
    )
    bake_backend: bpy.props.EnumProperty(
        name="Default Capture Backend",
        description="Renderer of the probes' captures in scenes whose Bake With is Default",
        items=_BACKENDS,
        default="BO2",
    )
    scheduler: bpy.props.StringProperty(
        name="Dask Scheduler",
        description="Address of the studio's Dask scheduler (tcp://host:8786) that scenes "
        "whose Bake On is Dask Cluster bake on, when their own Scheduler is empty",
        default="",
    )

    def draw(self, context):
        layout = self.layout
        layout.use_property_split = True
        layout.prop(self, "bake_folder")
        layout.prop(self, "bake_backend")
        layout.prop(self, "scheduler")


class _Defaults:
    """The preferences' defaults, when the add-on is not enabled through Preferences (a
    script that calls ``register()`` itself)."""

    bake_folder = "//bo2_bake/"
    bake_backend = "BO2"
    scheduler = ""


def preferences():
    """The add-on's preferences (``BO2Preferences``), or their defaults."""
    addon = bpy.context.preferences.addons.get(_PACKAGE)
    return addon.preferences if addon is not None and addon.preferences is not None \
        else _Defaults


# Settings that files of earlier versions keep flat in ``scene.bo2``: name -> (group, name)
MOVED = {
    "use_indirect": ("indirect", "use"),
    "normalization": ("indirect", "normalization"),
    "prefilter": ("indirect", "prefilter"),
    "env_brdf": ("indirect", "env_brdf"),
    "sky_directions": ("indirect", "sky_directions"),
    "sky_resolution": ("indirect", "sky_resolution"),
    "use_implicit_bounce": ("indirect", "use_implicit_bounce"),
    "use_ambient_occlusion": ("indirect", "use_ambient_occlusion"),
    "ao_distance": ("indirect", "ao_distance"),
    "use_specular_occlusion": ("indirect", "use_specular_occlusion"),
    "bake_backend": ("probes", "backend"),
    "bake_face_size": ("probes", "face_size"),
    "bake_volume_face_size": ("probes", "volume_face_size"),
    "bake_bounces": ("probes", "bounces"),
    "bake_samples": ("probes", "samples"),
    "bake_cycles_samples": ("probes", "cycles_samples"),
    "use_lightmaps": ("lightmaps", "use"),
    "lightmap_density": ("lightmaps", "density"),
    "lightmap_max_resolution": ("lightmaps", "max_resolution"),
    "lightmap_padding": ("lightmaps", "padding"),
    "lightmap_rays": ("lightmaps", "rays"),
    "lightmap_bounces": ("lightmaps", "bounces"),
    "lightmap_directional": ("lightmaps", "directional"),
    "lightmap_denoise": ("lightmaps", "denoise"),
    "viewport_samples": ("viewport", "samples"),
    "compare_folder": ("lookdev", "compare_folder"),
    "report_source": ("lookdev", "report_source"),
    "report_source_folder": ("lookdev", "report_source_folder"),
    "report_old_methods": ("lookdev", "report_old_methods"),
    "report_folder": ("lookdev", "report_folder"),
}


def upgrade(scene) -> int:
    """Move the settings an earlier version kept flat in ``scene.bo2`` (``MOVED``) into their
    groups, keeping their values; returns how many moved. Linked scenes are left as they are."""
    if scene.library is not None:
        return 0
    stored = scene.bo2  # item access reads the group's stored values, set or not by RNA
    moved = 0
    for old, (group, name) in MOVED.items():
        if old in stored.keys():
            value = stored[old]  # an enum is stored as its item's number, which is kept
            del stored[old]
            if name not in getattr(stored, group).keys():
                getattr(stored, group)[name] = value
            moved += 1
    return moved


def set_setting(scene, path: str, value) -> None:
    """Set the setting of ``scene.bo2`` at a dotted ``path`` ("samples", "indirect.env_brdf"); a
    flat name of an earlier version (``MOVED``) is taken to its group. AttributeError if there
    is no such setting."""
    group, _, name = path.rpartition(".")
    if not group and path in MOVED:
        group, name = MOVED[path]
    owner = getattr(scene.bo2, group) if group else scene.bo2
    if name not in owner.bl_rna.properties or name == "rna_type":
        raise AttributeError(f"BO2 Lighting has no scene setting '{path}'")
    setattr(owner, name, value)


@bpy.app.handlers.persistent
def on_load(_filepath="") -> None:
    """``load_post`` handler: upgrade the settings of every scene of the file just opened."""
    for scene in bpy.data.scenes:
        try:
            upgrade(scene)
        except (TypeError, KeyError, AttributeError) as exc:  # a handler must not stop the load
            print(f"BO2 Lighting: the settings of scene '{scene.name}' were not upgraded: {exc}")


CLASSES = [BO2IndirectSettings, BO2ProbeSettings, BO2LightmapSettings, BO2ViewportSettings,
           BO2LookDevSettings, BO2SceneSettings, BO2ObjectSettings, BO2ViewLayerSettings,
           BO2Preferences]


def _redraw_view(self, context) -> None:
    """The look-dev view changed: the viewport shows the new pass at its next draw."""
    if context is not None and context.area is not None:
        context.area.tag_redraw()


def lookdev_property():
    """The look-dev view of one 3D viewport (``SpaceView3D.shading.bo2_lookdev_view``): kept
    with the viewport, as EEVEE's Render Pass, and not in the scene."""
    return bpy.props.EnumProperty(
        name="Look-Dev View",
        description="What this viewport's Rendered shading shows: the image or one of its "
        "passes (the talk's material parameters, the light by kind, which probe lights a "
        "pixel)",
        items=[(key, view.label, view.description, k)
               for k, (key, view) in enumerate(viewport.VIEWS.items())],
        default="COMBINED", update=_redraw_view,
    )


def attach() -> None:
    """Add the pointer properties to the ID types and the look-dev view to each viewport."""
    bpy.types.Scene.bo2 = bpy.props.PointerProperty(type=BO2SceneSettings)
    bpy.types.Object.bo2 = bpy.props.PointerProperty(type=BO2ObjectSettings)
    bpy.types.ViewLayer.bo2 = bpy.props.PointerProperty(type=BO2ViewLayerSettings)
    bpy.types.View3DShading.bo2_lookdev_view = lookdev_property()


def detach() -> None:
    """Remove what ``attach()`` added."""
    del bpy.types.Scene.bo2
    del bpy.types.Object.bo2
    del bpy.types.ViewLayer.bo2
    del bpy.types.View3DShading.bo2_lookdev_view
