"""What every panel of the engine shares: the engine's id and the base class that shows a
panel only when BO2 Lighting renders."""

ENGINE_ID = "BO2_LIGHTING"


class BO2Panel:
    """Properties-editor panel shown when BO2 Lighting is the render engine."""

    bl_space_type = "PROPERTIES"
    bl_region_type = "WINDOW"
    COMPAT_ENGINES = {ENGINE_ID}
    needs = ""  # the context member the panel draws ("object", "light", ...), if any

    @classmethod
    def poll(cls, context):
        return context.engine in cls.COMPAT_ENGINES and (
            not cls.needs or getattr(context, cls.needs, None) is not None)

    def split_layout(self):
        """The panel's layout with labels beside the values, as Blender's own panels."""
        layout = self.layout
        layout.use_property_split = True
        layout.use_property_decorate = False
        return layout

    @staticmethod
    def note(layout, text: str) -> None:
        """A greyed line of information under a panel's settings."""
        row = layout.row()
        row.active = False
        row.label(text=text, icon="INFO")


class LightGroupPanel(BO2Panel):
    """The Light Group of the context's ``needs`` (an object or the world), picked from the
    view layer's groups, with the button that adds a typed name as a group (as Cycles draws
    it)."""

    bl_label = "Light Group"

    def draw(self, context):
        owner, view_layer = getattr(context, self.needs), context.view_layer
        row = self.layout.row(align=True)
        row.use_property_split = True
        row.use_property_decorate = False
        row.prop_search(owner, "lightgroup", view_layer, "lightgroups", text="Light Group",
                        results_are_suggestions=True)
        sub = row.column(align=True)
        sub.enabled = bool(owner.lightgroup) and not any(
            group.name == owner.lightgroup for group in view_layer.lightgroups)
        sub.operator("scene.view_layer_add_lightgroup", icon="ADD", text="").name = \
            owner.lightgroup
