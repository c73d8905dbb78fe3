"""The engine's panels of the Object and Object Data tabs: light probes, lights, the object's
visibility and its lightmap. Blender's Light and Probe panels are EEVEE's own (``DATA_PT_light``
draws only the type): these tabs are this module's panels, each setting once.
"""

import bpy

from . import bake_files, lightmaps, probes
from .panel import BO2Panel, LightGroupPanel

# Leak controls of a Volume light probe that the bake and the look-up honour (Blender's own).
_VOLUME_LEAK = ("dilation_threshold", "validity_threshold", "dilation_radius", "escape_bias",
                "normal_bias", "view_bias", "facing_bias")


class _LightProbePanel(BO2Panel):
    bl_context = "data"
    needs = "lightprobe"


class DATA_PT_bo2_lightprobe(_LightProbePanel, bpy.types.Panel):
    """The probe's settings that BO2 Lighting honours, each once (Blender's are EEVEE's)."""

    bl_label = "Probe"

    def draw(self, context):
        layout = self.split_layout()
        probe = context.lightprobe
        col = layout.column()
        if probe.type == "VOLUME":
            col.prop(probe, "influence_distance", text="Distance")
            sub = col.column(align=True)
            sub.prop(probe, "resolution_x", text="Resolution X")
            sub.prop(probe, "resolution_y", text="Y")
            sub.prop(probe, "resolution_z", text="Z")
            col = layout.column(heading="Leaks")
            for name in _VOLUME_LEAK:
                if hasattr(probe, name):
                    col.prop(probe, name)
            ignored = "Intensity, Falloff"
        elif probe.type == "SPHERE":
            col.prop(probe, "influence_type")
            col.prop(probe, "influence_distance",
                     text="Radius" if probe.influence_type == "ELIPSOID" else "Size")
            col.prop(probe, "falloff")
            ignored = "Intensity"
        else:
            col.label(text=f"{probe.type.title()} probes are not used by BO2 Lighting",
                      icon="INFO")
            return
        sub = layout.column(align=True)
        sub.prop(probe, "clip_start", text="Capture Clip Start")
        if "clip_end" in probe.bl_rna.properties:
            sub.prop(probe, "clip_end", text="End")
        _draw_ignored(layout, ignored.split(", "))


class DATA_PT_bo2_lightprobe_parallax(_LightProbePanel, bpy.types.Panel):
    """A sphere probe's parallax proxy (the bake's and the look-up's box or sphere)."""

    bl_label = "Custom Parallax"
    bl_options = {"DEFAULT_CLOSED"}

    @classmethod
    def poll(cls, context):
        return super().poll(context) and context.lightprobe.type == "SPHERE"

    def draw_header(self, context):
        self.layout.prop(context.lightprobe, "use_custom_parallax", text="")

    def draw(self, context):
        layout = self.split_layout()
        probe = context.lightprobe
        layout.active = probe.use_custom_parallax
        layout.prop(probe, "parallax_type")
        layout.prop(probe, "parallax_distance",
                    text="Radius" if probe.parallax_type == "ELIPSOID" else "Size")


class DATA_PT_bo2_lightprobe_display(_LightProbePanel, bpy.types.Panel):
    """How the probe draws in the viewport (Blender's settings)."""

    bl_label = "Viewport Display"
    bl_options = {"DEFAULT_CLOSED"}

    def draw(self, context):
        layout = self.split_layout()
        probe = context.lightprobe
        if probe.type in {"VOLUME", "SPHERE"}:
            row = layout.row(heading="Data")
            row.prop(probe, "use_data_display", text="")
            sub = row.row()
            sub.active = probe.use_data_display
            sub.prop(probe, "data_display_size", text="Size", slider=True)
            layout.prop(probe, "show_clip")
        layout.prop(probe, "show_influence")
        if probe.type == "SPHERE":
            sub = layout.column()
            sub.active = probe.use_custom_parallax
            sub.prop(probe, "show_parallax")


class DATA_PT_bo2_lightprobe_bake(_LightProbePanel, bpy.types.Panel):
    """The probe's bake: its state and the buttons (the settings are the scene's)."""

    bl_label = "BO2 Bake"

    @classmethod
    def poll(cls, context):
        return super().poll(context) and context.lightprobe.type in probes.KINDS

    def draw(self, context):
        layout = self.split_layout()
        obj = context.object
        state = probes.bake_state(obj)
        if state is not None:
            col = layout.column(align=True)
            icon = {"BAKED": "CHECKMARK", "STALE": "ERROR", "MISSING": "X",
                    "DAMAGED": "CANCEL"}[state.state]
            col.label(text=f"State: {state.state.title()}", icon=icon)
            if state.meta:
                col.label(text=f"Baked: {state.meta.get('bake_time', '?')}")
                col.label(text=f"Face size: {state.meta.get('face_size', '?')} px")
                if "invalid_samples" in state.meta:
                    col.label(text=f"Samples left out: {len(state.meta['invalid_samples'])}, "
                                   f"escaped: {state.meta.get('escaped_samples', 0)}")
            if bake_files.packed(obj):
                col.label(text="Packed in the .blend", icon="PACKAGE")
            elif bake_files.image(obj) is not None:
                col.label(text=f"File: {bake_files.image(obj).filepath}", icon="FILE")
            if state.message:
                col.label(text=state.message)
        row = layout.row(align=True)
        row.operator("bo2.bake_probes", text="Bake", icon="RENDER_STILL").mode = "ACTIVE"
        row.operator("bo2.clear_probes", text="Clear", icon="TRASH").mode = "ACTIVE"


class OBJECT_PT_bo2_lightgroup(LightGroupPanel, bpy.types.Panel):
    """The light group an object's light or emission is counted in (View Layer > Passes >
    Light Groups)."""

    bl_context = "object"
    bl_parent_id = "OBJECT_PT_shading"
    needs = "object"


class _LightPanel(BO2Panel):
    bl_context = "data"
    needs = "light"


class DATA_PT_bo2_light(_LightPanel, bpy.types.Panel):
    """The light as BO2 Lighting renders it (Blender's full Light panel is EEVEE's)."""

    bl_label = "Light"

    def draw(self, context):
        layout = self.layout
        light = context.light
        layout.row().prop(light, "type", expand=True)
        layout = self.split_layout()
        col = layout.column()
        row = col.column(align=True, heading="Temperature").row(align=True)
        row.prop(light, "use_temperature", text="")
        sub = row.row()
        sub.active = light.use_temperature
        sub.prop(light, "temperature", text="")
        col.prop(light, "color", text="Tint" if light.use_temperature else "Color")
        layout.separator()
        col = layout.column()
        col.prop(light, "energy")
        col.prop(light, "exposure")
        col.prop(light, "normalize")
        layout.separator()
        col = layout.column()
        if light.type in {"POINT", "SPOT"}:
            col.prop(light, "shadow_soft_size", text="Radius")
        elif light.type == "SUN":
            col.prop(light, "angle")
        elif light.type == "AREA":
            col.prop(light, "shape")
            sub = col.column(align=True)
            if light.shape in {"SQUARE", "DISK"}:
                sub.prop(light, "size")
            else:
                sub.prop(light, "size", text="Size X")
                sub.prop(light, "size_y", text="Y")
        _draw_ignored(layout, ignored_light_settings(light))


def ignored_light_settings(light) -> list[str]:
    """The names of a light's settings BO2 Lighting does not render, as its panel says."""
    names = ["Influence factors", "Custom Distance", "Light nodes"]
    if light.type in {"POINT", "SPOT"}:
        names.insert(0, "Soft Falloff")
    return names


def _draw_ignored(layout, names) -> None:
    """A greyed note under a panel: the settings of its data that BO2 Lighting does not use."""
    col = layout.column(align=True)
    col.active = False
    col.label(text="Not used by BO2 Lighting:", icon="INFO")
    for name in names:
        col.label(text=name, icon="BLANK1")


class DATA_PT_bo2_light_shadow(_LightPanel, bpy.types.Panel):
    bl_label = "Shadow"
    bl_parent_id = "DATA_PT_bo2_light"

    def draw_header(self, context):
        self.layout.prop(context.light, "use_shadow", text="")

    def draw(self, context):
        layout = self.split_layout()
        layout.active = context.light.use_shadow
        layout.prop(context.scene.bo2, "shadow_resolution", text="Resolution (Scene)")
        size = {"SUN": "Angle", "AREA": "Size"}.get(context.light.type, "Radius")
        self.note(layout, f"Penumbra from the light's {size}")


class DATA_PT_bo2_light_beam(_LightPanel, bpy.types.Panel):
    bl_label = "Beam Shape"
    bl_parent_id = "DATA_PT_bo2_light"

    @classmethod
    def poll(cls, context):
        return super().poll(context) and context.light.type == "SPOT"

    def draw(self, context):
        layout = self.split_layout()
        light = context.light
        layout.prop(light, "spot_size", text="Angle")
        layout.prop(light, "spot_blend", text="Blend", slider=True)
        layout.prop(light, "show_cone")


class OBJECT_PT_bo2_visibility(BO2Panel, bpy.types.Panel):
    """The object's visibility as BO2 Lighting renders it."""

    bl_label = "Visibility"
    bl_context = "object"
    bl_options = {"DEFAULT_CLOSED"}
    needs = "object"

    def draw(self, context):
        layout = self.split_layout()
        obj = context.object
        layout.prop(obj, "hide_select", text="Selectable", toggle=False, invert_checkbox=True)
        col = layout.column(heading="Show In")
        col.prop(obj, "hide_viewport", text="Viewports", toggle=False, invert_checkbox=True)
        col.prop(obj, "hide_render", text="Renders", toggle=False, invert_checkbox=True)
        if obj.type in _GEOMETRY:
            col = layout.column(heading="Ray Visibility")
            col.prop(obj, "visible_camera", text="Camera", toggle=False)
            col.prop(obj, "visible_shadow", text="Shadow", toggle=False)
            col = layout.column(heading="Light Probes")
            col.prop(obj, "hide_probe_volume", text="Volume", toggle=False, invert_checkbox=True)
            col.prop(obj, "hide_probe_sphere", text="Sphere", toggle=False, invert_checkbox=True)
            col = layout.column(heading="Mask")
            col.prop(obj, "is_shadow_catcher")
            col.prop(obj, "is_holdout")


_GEOMETRY = {"MESH", "CURVE", "SURFACE", "META", "FONT", "CURVES", "POINTCLOUD"}


class OBJECT_PT_bo2_motion_blur(BO2Panel, bpy.types.Panel):
    """Object > Motion Blur: the object's own toggles, as Cycles reads them."""

    bl_label = "Motion Blur"
    bl_context = "object"
    bl_options = {"DEFAULT_CLOSED"}
    needs = "object"

    @classmethod
    def poll(cls, context):
        obj = context.object
        return (super().poll(context) and getattr(obj, "cycles", None) is not None
                and obj.type in _GEOMETRY | {"CAMERA", "EMPTY"})

    def draw_header(self, context):
        self.layout.prop(context.object.cycles, "use_motion_blur", text="")

    def draw(self, context):
        layout = self.split_layout()
        own = context.object.cycles
        layout.active = context.scene.render.use_motion_blur and own.use_motion_blur
        if context.object.type != "CAMERA":
            layout.prop(own, "use_deform_motion", text="Deformation")


class OBJECT_PT_bo2_lightmap(BO2Panel, bpy.types.Panel):
    """The object's lightmap: static or not, its UV map, density and bake."""

    bl_label = "BO2 Lightmap"
    bl_context = "object"
    needs = "object"

    @classmethod
    def poll(cls, context):
        return super().poll(context) and context.object.type == "MESH"

    def draw_header(self, context):
        self.layout.prop(context.object.bo2, "use_lightmap", text="")

    def draw(self, context):
        layout = self.split_layout()
        obj = context.object
        settings = obj.bo2
        layout.prop(settings, "lightmap_mode")
        static = lightmaps.is_static(obj)
        col = layout.column()
        col.active = static
        col.prop_search(settings, "lightmap_uv", obj.data, "uv_layers", text="UV Map")
        col.prop(settings, "lightmap_density")
        if not static:
            layout.label(text="Dynamic: the probes light it", icon="INFO")
            return
        uv = lightmaps.uv_map(obj)
        col.label(text=f"Layout: UV map '{uv}'" if uv else "Layout: made by the bake",
                  icon="UV")
        state, text = lightmaps.state(obj, context.scene)
        row = layout.row()
        row.alert = state == "DAMAGED"
        row.label(text=f"Baked: {text}" if state == "BAKED" else f"Lightmap: {text}",
                  icon="CHECKMARK" if state == "BAKED" else "ERROR")
        if bake_files.packed(obj):
            layout.label(text="Packed in the .blend", icon="PACKAGE")
        elif bake_files.image(obj) is not None:
            layout.label(text=f"File: {bake_files.image(obj).filepath}", icon="FILE")


CLASSES = [OBJECT_PT_bo2_visibility, OBJECT_PT_bo2_motion_blur, OBJECT_PT_bo2_lightmap,
           OBJECT_PT_bo2_lightgroup,
           DATA_PT_bo2_light,
           DATA_PT_bo2_light_shadow, DATA_PT_bo2_light_beam, DATA_PT_bo2_lightprobe,
           DATA_PT_bo2_lightprobe_parallax, DATA_PT_bo2_lightprobe_display,
           DATA_PT_bo2_lightprobe_bake]
