"""Panels: the engine's own render settings, plus Blender's stock panels that apply to it.

Stock panels opt in through their ``COMPAT_ENGINES`` set, the way other external engines do;
``disable_panels()`` removes exactly what ``enable_panels()`` added.
"""

import bpy
from bl_ui.properties_view_layer import (
    ViewLayerAOVPanelHelper,
    ViewLayerCryptomattePanelHelper,
    ViewLayerLightgroupsPanelHelper,
)

from ..core import kernels
from ..core.render import transparency
from ..core.render.passes import PASSES
from . import (
    adoption,
    convert,
    lightmaps,
    node_groups,
    object_panels,
    passes,
    probes,
    props,
    viewport,
    worlds,
)
from .panel import ENGINE_ID, BO2Panel, LightGroupPanel

_PASS_HEADINGS = {"data": "Data", "index": "Indexes", "light": "Light", "material": "Material"}

# Blender's panels that show settings this engine honours.
_STOCK_PANELS = (
    "RENDER_PT_format", "RENDER_PT_frame_range", "RENDER_PT_time_stretching",
    "RENDER_PT_color_management", "RENDER_PT_color_management_curves",
    "RENDER_PT_output", "RENDER_PT_encoding", "RENDER_PT_stamp", "RENDER_PT_post_processing",
    "DATA_PT_context_camera", "DATA_PT_lens", "DATA_PT_camera", "DATA_PT_camera_display",
    "DATA_PT_context_light", "DATA_PT_preview", "DATA_PT_light_animation",
    "DATA_PT_custom_props_light",
    "DATA_PT_context_mesh", "DATA_PT_normals", "DATA_PT_uv_texture", "DATA_PT_vertex_groups",
    "MATERIAL_PT_preview", "EEVEE_MATERIAL_PT_context_material", "MATERIAL_PT_viewport",
    "WORLD_PT_context_world", "WORLD_PT_preview", "VIEWLAYER_PT_layer",
    "DATA_PT_camera_dof", "DATA_PT_camera_dof_aperture",
    "DATA_PT_context_lightprobe", "DATA_PT_lightprobe_animation",
    "EEVEE_WORLD_PT_surface", "WORLD_PT_custom_props", "WORLD_PT_animation",
    "MATERIAL_PT_custom_props", "MATERIAL_PT_animation",
    "OBJECT_PT_shading",  # Light Linking and Shadow Linking (its other children are Cycles')
)
# Blender's Light and Probe panels are EEVEE's own (``DATA_PT_light`` draws only the type): the
# light and light probe tabs are this module's panels, each setting once.
_enabled: list[type] = []


def _redraw_properties():
    """Timer: redraw the Properties editors every half second while the kernels are being
    made ready (the Render tab says what is being done)."""
    for window in bpy.context.window_manager.windows:
        for area in window.screen.areas:
            if area.type == "PROPERTIES":
                area.tag_redraw()
    return 0.5 if kernels.status() else None


class RENDER_PT_bo2_settings(BO2Panel, bpy.types.Panel):
    bl_label = "BO2 Lighting"
    bl_context = "render"

    def draw(self, context):
        layout = self.split_layout()
        try:
            kernels.check()
        except kernels.KernelsUnavailable as exc:
            box = layout.box()
            box.alert = True
            box.label(text=str(exc), icon="ERROR")
        if kernels.status():
            layout.label(text=f"{kernels.status()}...", icon="TIME")
            if not bpy.app.timers.is_registered(_redraw_properties):
                bpy.app.timers.register(_redraw_properties, first_interval=0.5)
        settings = context.scene.bo2
        layout.prop(settings, "device")
        layout.prop(settings, "samples")
        layout.prop(settings, "shade_every_sample")
        layout.prop(context.scene.render, "filter_size", text="Filter Width")
        layout.prop(settings, "specular_model")
        layout.prop(settings, "use_layered_diffuse")
        layout.prop(settings, "shadow_resolution")
        layout.prop(context.scene.render, "film_transparent")
        layout.prop(settings, "blend_sort")
        col = layout.column(heading="Threads")
        col.prop(context.scene.render, "threads_mode", text="Threads")
        sub = col.column()
        sub.enabled = context.scene.render.threads_mode == "FIXED"
        sub.prop(context.scene.render, "threads")


class _RenderSubPanel(BO2Panel):
    """A sub-panel of Render > BO2 Lighting: it draws the settings group ``scene.bo2.<group>``."""

    bl_context = "render"
    bl_parent_id = "RENDER_PT_bo2_settings"
    group = ""

    def settings(self, context):
        return getattr(context.scene.bo2, self.group)


class _Switched:
    """A sub-panel whose group is switched on and off by its ``use``, in the header."""

    def draw_header(self, context):
        self.layout.prop(self.settings(context), "use", text="")


class RENDER_PT_bo2_indirect(_Switched, _RenderSubPanel, bpy.types.Panel):
    bl_label = "Indirect Light"
    group = "indirect"

    def draw(self, context):
        layout = self.split_layout()
        settings = self.settings(context)
        col = layout.column()
        col.active = settings.use
        col.prop(settings, "normalization")
        col.prop(settings, "prefilter")
        col.prop(settings, "env_brdf")
        col.prop(settings, "sky_directions")
        sub = col.column()
        sub.active = settings.sky_directions != "0"
        sub.prop(settings, "sky_resolution", text="Resolution")
        col.prop(settings, "use_implicit_bounce")
        col.prop(settings, "use_wall_extrapolation")
        col.prop(settings, "use_visibility_test")
        col.prop(settings, "use_nearest_reflections")
        col.prop(settings, "use_ambient_occlusion")
        sub = col.column()
        sub.active = settings.use_ambient_occlusion
        sub.prop(settings, "ao_distance")
        sub.prop(settings, "use_specular_occlusion")


class RENDER_PT_bo2_bake(_RenderSubPanel, bpy.types.Panel):
    bl_label = "Light Probes"
    group = "probes"

    def draw(self, context):
        layout = self.split_layout()
        row = layout.row(align=True)
        row.operator("bo2.bake_probes", text="Bake All", icon="RENDER_STILL").mode = "ALL"
        row.operator("bo2.bake_probes", text="Bake Selected").mode = "SELECTED"
        layout.operator("bo2.clear_probes", text="Clear Bakes", icon="TRASH").mode = "ALL"
        layout.prop(context.scene.bo2, "bake_folder")  # (the lightmaps' too)
        row = layout.row(align=True)
        row.prop(context.scene.bo2, "bake_pack")
        row.operator("bo2.pack_bakes", text="", icon="PACKAGE")
        row.operator("bo2.unpack_bakes", text="", icon="UGLYPACKAGE")
        layout.prop(context.scene.bo2, "bake_on")  # (the lightmaps' too)
        if context.scene.bo2.bake_on == "CLUSTER":  # the preferences' address when empty
            layout.prop(context.scene.bo2, "scheduler",
                        placeholder=props.preferences().scheduler or "tcp://host:8786")
        if adoption.notices:  # the details are in the console
            count = len(adoption.notices)
            layout.label(text=f"{count} bake{'s' * (count != 1)} of an earlier version adopted "
                         "(see the console); save to keep", icon="INFO")
        settings = self.settings(context)
        layout.prop(settings, "backend")
        layout.prop(settings, "face_size")
        layout.prop(settings, "volume_face_size")
        backend = probes.capture_backend(context.scene)
        col = layout.column()
        col.active = backend == "BO2"
        col.prop(settings, "bounces")
        col.prop(settings, "converge")
        col.prop(settings, "samples")
        col = layout.column()
        col.active = backend == "CYCLES"
        col.prop(settings, "cycles_samples")


class RENDER_PT_bo2_lightmaps(_Switched, _RenderSubPanel, bpy.types.Panel):
    bl_label = "Lightmaps"
    group = "lightmaps"

    def draw(self, context):
        layout = self.split_layout()
        settings = self.settings(context)
        row = layout.row(align=True)
        row.operator("bo2.bake_lightmaps", text="Bake All", icon="RENDER_STILL").mode = "ALL"
        row.operator("bo2.bake_lightmaps", text="Bake Selected").mode = "SELECTED"
        layout.operator("bo2.clear_lightmaps", text="Clear Lightmaps", icon="TRASH").mode = "ALL"
        if context.scene.bo2.bake_on == "CLUSTER":  # (set in the Light Probes panel)
            layout.label(text="Bakes on a Dask cluster (Light Probes: Bake On)",
                         icon="NETWORK_DRIVE")
        for name in ("density", "max_resolution", "padding", "rays", "bounces", "directional",
                     "denoise"):
            layout.prop(settings, name)
        objs = lightmaps.lightmap_objects(context.scene)
        texels, size = lightmaps.estimate(context.scene, objs)
        col = layout.column(align=True)
        col.label(text=f"{len(objs)} static object{'s' * (len(objs) != 1)}, about "
                  f"{texels / 1e6:.2f} M texels", icon="INFO")
        col.label(text=f"About {size / 2**20:.1f} MiB in a frame")


class RENDER_PT_bo2_viewport(_RenderSubPanel, bpy.types.Panel):
    bl_label = "Viewport"
    group = "viewport"

    def draw(self, context):
        layout = self.split_layout()
        layout.prop(self.settings(context), "samples")
        layout.prop(context.scene.render, "preview_pixel_size", text="Pixel Size")
        self.note(layout, "Look-dev view: each viewport's header")


class RENDER_PT_bo2_lookdev(_RenderSubPanel, bpy.types.Panel):
    bl_label = "Look-Dev"
    group = "lookdev"

    def draw(self, context):
        layout = self.split_layout()
        settings = self.settings(context)
        layout.operator("bo2.compare_cycles", icon="IMAGE_REFERENCE")
        layout.prop(settings, "compare_folder")
        layout.separator()
        layout.prop(settings, "report_source")
        if settings.report_source == "FOLDER":
            layout.prop(settings, "report_source_folder")
        else:
            layout.prop(settings, "report_old_methods")
        layout.prop(settings, "report_folder")
        layout.operator("bo2.review_report", icon="DOCUMENTS")


class RENDER_PT_bo2_motion_blur(BO2Panel, bpy.types.Panel):
    """Render > Motion Blur: Blender's shutter settings, as Cycles reads them
    (``blender.motion``)."""

    bl_label = "Motion Blur"
    bl_context = "render"
    bl_options = {"DEFAULT_CLOSED"}

    def draw_header(self, context):
        self.layout.prop(context.scene.render, "use_motion_blur", text="")

    def draw(self, context):
        layout = self.split_layout()
        r = context.scene.render
        col = layout.column()
        col.active = r.use_motion_blur
        col.prop(r, "motion_blur_position", text="Position")
        col.prop(r, "motion_blur_shutter")
        cycles = getattr(context.scene, "cycles", None)
        if cycles is not None and hasattr(cycles, "rolling_shutter_type"):
            col.separator()
            col.prop(cycles, "rolling_shutter_type", text="Rolling Shutter")
            sub = col.column()
            sub.active = cycles.rolling_shutter_type != "NONE"
            sub.prop(cycles, "rolling_shutter_duration", text="Duration")
        self.note(layout, "In F12 and bo2 render, not the viewport")


class RENDER_PT_bo2_motion_blur_curve(BO2Panel, bpy.types.Panel):
    bl_label = "Shutter Curve"
    bl_context = "render"
    bl_parent_id = "RENDER_PT_bo2_motion_blur"
    bl_options = {"DEFAULT_CLOSED"}

    def draw(self, context):
        layout = self.layout
        r = context.scene.render
        layout.active = r.use_motion_blur
        layout.template_curve_mapping(r, "motion_blur_shutter_curve")
        row = layout.row(align=True)
        for shape, icon in (("SMOOTH", "SMOOTHCURVE"), ("ROUND", "SPHERECURVE"),
                            ("ROOT", "ROOTCURVE"), ("SHARP", "SHARPCURVE"),
                            ("LINE", "LINCURVE"), ("MAX", "NOCURVE")):
            row.operator("render.shutter_curve_preset", icon=icon, text="").shape = shape


class VIEWLAYER_PT_bo2_passes(BO2Panel, bpy.types.Panel):
    bl_label = "Passes"
    bl_context = "view_layer"

    def draw(self, context):
        layout = self.split_layout()
        view_layer = context.view_layer
        for group, heading in _PASS_HEADINGS.items():
            col = layout.column(heading=heading, align=True)
            for p in PASSES.values():
                if p.group == group:
                    passes.draw_flag(col, view_layer, p.name)


class VIEWLAYER_PT_bo2_passes_cryptomatte(BO2Panel, ViewLayerCryptomattePanelHelper,
                                          bpy.types.Panel):
    """Blender's Cryptomatte settings (``core.render.cryptomatte``), as Cycles shows them."""

    bl_label = "Cryptomatte"
    bl_context = "view_layer"
    bl_parent_id = "VIEWLAYER_PT_bo2_passes"


class VIEWLAYER_PT_bo2_passes_lightgroups(BO2Panel, ViewLayerLightgroupsPanelHelper,
                                          bpy.types.Panel):
    """The view layer's light groups: a ``Combined_<name>`` pass each (``light_groups``)."""

    bl_label = "Light Groups"
    bl_context = "view_layer"
    bl_parent_id = "VIEWLAYER_PT_bo2_passes"


class VIEWLAYER_PT_bo2_passes_aov(BO2Panel, ViewLayerAOVPanelHelper, bpy.types.Panel):
    """The view layer's shader AOVs: a pass each, what the AOV Output nodes give
    (``RenderSettings.aovs``)."""

    bl_label = "Shader AOV"
    bl_context = "view_layer"
    bl_parent_id = "VIEWLAYER_PT_bo2_passes"


class WORLD_PT_bo2_lightgroup(LightGroupPanel, bpy.types.Panel):
    """The light group the world's light, its sun and the background are counted in."""

    bl_context = "world"
    bl_parent_id = "WORLD_PT_bo2_light"
    needs = "world"


class MATERIAL_PT_bo2_surface(BO2Panel, bpy.types.Panel):
    bl_label = "Surface"
    bl_context = "material"
    needs = "object"

    def draw(self, context):
        layout = self.layout
        mat = context.material
        layout.operator("material.bo2_new", icon="ADD")
        if mat is None:
            return
        try:
            tree, output, node = convert.surface_node(mat)
        except convert.ConvertError as exc:
            layout.label(text=str(exc)[0].upper() + str(exc)[1:], icon="INFO")
            return
        if node.type == "BSDF_PRINCIPLED":
            self.draw_talk_values(layout, node)
            layout.operator("material.bo2_convert", text="Convert to BO2 Material",
                            icon="SHADING_RENDERED").direction = "TO_BO2"
        elif node_groups.is_bo2_material_node(node):
            layout.operator("material.bo2_convert", text="Convert to Principled BSDF",
                            icon="NODE_MATERIAL").direction = "TO_PRINCIPLED"
        layout.template_node_view(tree, output, output.inputs["Surface"])

    @staticmethod
    def draw_talk_values(layout, node) -> None:
        """The Principled BSDF in the talk's parameters, read-only."""
        box = layout.box()
        box.label(text="In the talk's parameters (as rendered)")
        values = convert.talk_values(node)
        if values is None:
            box.label(text="Textured: they vary over the surface")
            return
        col = box.column(align=True)
        for label, key in (("Albedo", "albedo"), ("Specular Color (rf0)", "rf0")):
            r, g, b = values[key]
            col.label(text=f"{label}: {r:.3f}, {g:.3f}, {b:.3f}")
        col.label(text=f"Gloss: {values['gloss']:.3f}  (power {8192 ** values['gloss']:.0f})")


class MATERIAL_PT_bo2_settings(BO2Panel, bpy.types.Panel):
    """The material settings BO2 Lighting honours."""

    bl_label = "Settings"
    bl_context = "material"
    needs = "material"

    def draw(self, context):
        layout = self.split_layout()
        mat = context.material
        layout.prop(mat, "pass_index")
        col = layout.column(heading="Backface Culling")
        col.prop(mat, "use_backface_culling", text="Camera")
        layout.prop(mat, "surface_render_method", text="Render Method")
        if mat.surface_render_method == "BLENDED":
            layout.prop(mat, "use_transparency_overlap", text="Transparency Overlap")
            order = ("per pixel" if context.scene.bo2.blend_sort == "pixel"
                     else "by object origin")
            self.note(layout, f"Sorted {order}, {transparency.BLEND_LAYERS} layers deep")
            self.note(layout, "Shadows: dithered")
        else:
            self.note(layout, "Dithered, as EEVEE's")
        self.note(layout, "Glass: seen through, no refraction")


class WORLD_PT_bo2_light(BO2Panel, bpy.types.Panel):
    """How BO2 Lighting reads the world: directly, or rendered by Cycles (any nodes)."""

    bl_label = "World Light"
    bl_context = "world"
    needs = "world"

    def draw(self, context):
        layout = self.layout
        scene, world = context.scene, context.world
        self.draw_sun(layout, world)
        if worlds.direct(world):
            layout.label(text="Read directly: a colour or an equirect HDRI", icon="CHECKMARK")
            return
        reason = worlds.problem(world)
        if reason is not None:
            box = layout.box()
            box.alert = True
            box.label(text=f"Cannot be evaluated: {reason}", icon="ERROR")
            box.label(text="The viewport colour lights the scene")
            return
        ready = worlds.lookup(scene, world) is not None
        layout.label(text="Nodes rendered by Cycles into an equirect" if ready else
                     "Changed since it was rendered: the viewport colour stands in",
                     icon="CHECKMARK" if ready else "INFO")
        layout.operator("bo2.evaluate_world", icon="WORLD")

    @staticmethod
    def draw_sun(layout, world):
        """EEVEE's own World > Sun settings: the same world gives both engines one sun."""
        layout.use_property_split = True
        col = layout.column()
        col.prop(world, "sun_threshold", text="Sun Threshold")
        sub = col.column()
        sub.active = world.sun_threshold > 0.0
        sub.prop(world, "sun_angle", text="Sun Angle")
        sub.prop(world, "use_sun_shadow", text="Sun Shadow")


CLASSES = [RENDER_PT_bo2_settings, RENDER_PT_bo2_indirect, RENDER_PT_bo2_bake,
           RENDER_PT_bo2_lightmaps, RENDER_PT_bo2_viewport, RENDER_PT_bo2_lookdev,
           RENDER_PT_bo2_motion_blur, RENDER_PT_bo2_motion_blur_curve,
           VIEWLAYER_PT_bo2_passes, VIEWLAYER_PT_bo2_passes_cryptomatte,
           VIEWLAYER_PT_bo2_passes_lightgroups, VIEWLAYER_PT_bo2_passes_aov,
           *object_panels.CLASSES,
           MATERIAL_PT_bo2_surface, MATERIAL_PT_bo2_settings, WORLD_PT_bo2_light,
           WORLD_PT_bo2_lightgroup]


def draw_render_menu(self, context):
    """Render menu entry: Compare with Cycles, when BO2 Lighting is the render engine."""
    if context.engine == ENGINE_ID:
        self.layout.separator()
        self.layout.operator("bo2.compare_cycles", icon="IMAGE_REFERENCE")


def draw_view3d_header(self, context):
    """3D viewport header: the look-dev view, in Rendered shading with BO2 Lighting."""
    space = context.space_data
    if context.engine == ENGINE_ID and space is not None and space.type == "VIEW_3D" \
            and space.shading.type == "RENDERED":
        self.layout.prop(space.shading, "bo2_lookdev_view", text="")


def draw_probe_states() -> None:
    """3D viewport overlay (POST_PIXEL): each light probe's bake state beside it, when BO2
    Lighting is the render engine and the viewport shows its overlays
    (``viewport.probe_labels``)."""
    import blf
    from bpy_extras.view3d_utils import location_3d_to_region_2d

    context = bpy.context
    if context.engine != ENGINE_ID or context.region_data is None:
        return
    space = context.space_data
    if space is not None and not space.overlay.show_overlays:  # drawn as an overlay is
        return
    for obj, text, color in viewport.probe_labels(context.scene):
        if not obj.visible_get():
            continue
        xy = location_3d_to_region_2d(context.region, context.region_data,
                                      obj.matrix_world.translation)
        if xy is not None:
            blf.size(0, 12)
            blf.color(0, *color)
            blf.position(0, xy.x + 14.0, xy.y - 14.0, 0.0)
            blf.draw(0, text)


_MENUS = (("TOPBAR_MT_render", draw_render_menu), ("VIEW3D_HT_header", draw_view3d_header))
_handlers: list = []


def append_menus() -> None:
    """Add the Render menu entry, the viewport header's look-dev view selector and the
    viewport's probe state overlay."""
    for name, draw in _MENUS:
        menu = getattr(bpy.types, name, None)
        if menu is not None:
            menu.append(draw)
    _handlers.append(bpy.types.SpaceView3D.draw_handler_add(draw_probe_states, (), "WINDOW",
                                                            "POST_PIXEL"))


def remove_menus() -> None:
    """Undo ``append_menus()``."""
    for handle in _handlers:
        bpy.types.SpaceView3D.draw_handler_remove(handle, "WINDOW")
    _handlers.clear()
    for name, draw in _MENUS:
        menu = getattr(bpy.types, name, None)
        if menu is not None:
            menu.remove(draw)


def enable_panels() -> None:
    """Add this engine to the ``COMPAT_ENGINES`` of the stock panels listed above."""
    for name in _STOCK_PANELS:
        panel = getattr(bpy.types, name, None)
        engines = getattr(panel, "COMPAT_ENGINES", None)
        if engines is not None and ENGINE_ID not in engines:
            engines.add(ENGINE_ID)
            _enabled.append(panel)


def disable_panels() -> None:
    """Undo ``enable_panels()``."""
    for panel in _enabled:
        panel.COMPAT_ENGINES.discard(ENGINE_ID)
    _enabled.clear()
