"""The add-on's operators but the bakes' (``bake_operators``): Compare with Cycles, the review
report, BO2 Material nodes, the world's evaluation.
"""

from __future__ import annotations

import time

import bpy

from ..core.review import compare as core_compare
from ..core.review import report as core_report
from . import (
    bake_operators,
    compare,
    convert,
    node_groups,
    report,
    worlds,
)


class BO2_OT_compare_cycles(bpy.types.Operator):
    """Compare with Cycles (the tooltip is ``bl_description``)."""

    bl_idname = "bo2.compare_cycles"
    bl_label = "Compare with Cycles"
    bl_description = ("Render the frame with BO2 Lighting and with Cycles and compare them: both "
                      "renders as EXR, side-by-side, split and difference pictures and metrics "
                      "in the Compare Folder")
    bl_options = {"REGISTER"}

    _job = None
    _watch = None
    _timer = None
    _queue: list = []
    _key = ""
    _start = 0.0

    @classmethod
    def poll(cls, context):
        return context.scene is not None and context.view_layer is not None and not (
            bpy.app.is_job_running("RENDER"))

    def _report_done(self, context, result: dict) -> None:
        self.report({"INFO"}, core_compare.headline(result))
        compare.show_images(context, result)

    def execute(self, context):
        scene = context.scene
        try:
            result = compare.run(scene, context.view_layer, compare.output_folder(scene))
        except compare.CompareError as exc:
            self.report({"ERROR"}, str(exc))
            return {"CANCELLED"}
        self._report_done(context, result)
        return {"FINISHED"}

    def invoke(self, context, event):
        if bpy.app.background or context.window is None:
            return self.execute(context)
        try:
            self._job = compare.Comparison(context.scene, context.view_layer,
                                           compare.output_folder(context.scene))
        except compare.CompareError as exc:
            self.report({"ERROR"}, str(exc))
            return {"CANCELLED"}
        self._queue = list(compare.ENGINES)
        if not self._start_next(context):
            return {"CANCELLED"}
        wm = context.window_manager
        self._timer = wm.event_timer_add(0.25, window=context.window)
        wm.modal_handler_add(self)
        return {"RUNNING_MODAL"}

    def _status(self, context, text: str | None) -> None:
        if context.workspace is not None:
            context.workspace.status_text_set(text)

    def _start_next(self, context) -> bool:
        """Start the next engine's render as Blender's render job."""
        self._key = self._queue.pop(0)
        self._job.begin(self._key)
        self._watch = compare.RenderWatch()
        label = compare.ENGINES[self._key][1]
        self._status(context, f"Compare with Cycles: rendering with {label} "
                     "(Esc in the render window cancels)")
        self._start = time.perf_counter()
        result = bpy.ops.render.render("INVOKE_DEFAULT", layer=self._job.layer)
        if not result & {"RUNNING_MODAL", "FINISHED"}:
            self._end(context)
            self.report({"ERROR"}, f"Compare with Cycles: the {label} render did not start")
            return False
        return True

    def _end(self, context) -> None:
        if self._timer is not None:
            context.window_manager.event_timer_remove(self._timer)
            self._timer = None
        if self._watch is not None:
            self._watch.remove()
        self._status(context, None)
        self._job.restore()

    def modal(self, context, event):
        if event.type != "TIMER" or bpy.app.is_job_running("RENDER"):
            return {"PASS_THROUGH"}
        watch, label = self._watch, compare.ENGINES[self._key][1]
        watch.remove()
        if watch.cancelled:
            self._end(context)
            self.report({"WARNING"}, f"Compare with Cycles: the {label} render was cancelled; "
                        f"{self._job.kept_text()}")
            return {"CANCELLED"}
        seconds = (watch.end if watch.completed else time.perf_counter()) - self._start
        try:
            self._job.finish(self._key, seconds)
            if self._queue:
                return {"RUNNING_MODAL"} if self._start_next(context) else {"CANCELLED"}
            self._status(context, "Compare with Cycles: comparing")
            result = self._job.analyse()
        except compare.CompareError as exc:
            self._end(context)
            self.report({"ERROR"}, f"Compare with Cycles: {exc}")
            return {"CANCELLED"}
        self._end(context)
        self._report_done(context, result)
        return {"FINISHED"}


class BO2_OT_review_report(bpy.types.Operator):
    """The look-dev review page (the tooltip is ``bl_description``)."""

    bl_idname = "bo2.review_report"
    bl_label = "Review Report"
    bl_description = ("Compare this file's scenes (or Compare with Cycles folders) with Cycles "
                      "on one web page in the Report Folder: ranked by FLIP, with an A/B wipe, "
                      "difference and FLIP maps and per-pass metrics. Esc stops after the "
                      "current scene and keeps the scenes done")
    bl_options = {"REGISTER"}

    _steps: list = []
    _errors: list = []
    _page = None
    _timer = None
    _done = 0

    @classmethod
    def poll(cls, context):
        return context.scene is not None and not bpy.app.is_job_running("RENDER")

    def _start(self, context) -> bool:
        try:
            self._page, self._steps = report.plan(context)
        except compare.CompareError as exc:
            self.report({"ERROR"}, str(exc))
            return False
        self._done = 0
        return True

    def _step(self) -> str | None:
        """Run the next scene; an error line, or None (the page lists the scenes that fail)."""
        name, step = self._steps[self._done]
        self._done += 1
        try:
            step()
        except Exception as exc:  # noqa: BLE001 - one line per scene, the review goes on
            text = str(exc) if isinstance(exc, compare.CompareError) else (
                f"{type(exc).__name__}: {exc}")
            self._page.fail(name, text)
            return f"{name}: {text}"
        return None

    def _finish(self, context, errors: list[str], stopped: bool = False) -> set:
        page = self._page
        if not page.entries:
            self.report({"ERROR"}, "Review Report: no scene could be compared"
                        + (f" ({errors[0]})" if errors else ""))
            return {"CANCELLED"}
        path = page.write([n for n, _ in self._steps[self._done:]])
        for line in errors:
            self.report({"WARNING"}, f"Review Report: {line}")
        worst = core_report.ranked(page.entries)[0]
        score = core_report.score(worst)
        verb = "stopped after" if stopped else "compared"
        self.report({"INFO"}, f"Review Report: {verb} {len(page.entries)} scene"
                    f"{'s' * (len(page.entries) != 1)}; worst {worst['name']}"
                    + (f" (mean FLIP {score:.3f})" if score is not None else "")
                    + f"; {path}")
        if not bpy.app.background and context.window_manager is not None:
            try:  # a system without a web browser: the page is written all the same
                bpy.ops.wm.url_open(url=path.as_uri())
            except RuntimeError:
                pass
        return {"FINISHED"}

    def execute(self, context):
        if not self._start(context):
            return {"CANCELLED"}
        errors = [e for e in (self._step() for _ in self._steps) if e]
        try:
            return self._finish(context, errors)
        except (OSError, ValueError) as exc:
            self.report({"ERROR"}, f"Review Report: the page cannot be written ({exc})")
            return {"CANCELLED"}

    def invoke(self, context, event):
        if bpy.app.background or context.window is None:
            return self.execute(context)
        if not self._start(context):
            return {"CANCELLED"}
        self._errors = []
        wm = context.window_manager
        wm.progress_begin(0, len(self._steps))
        self._timer = wm.event_timer_add(0.1, window=context.window)
        wm.modal_handler_add(self)
        self._status(context)
        return {"RUNNING_MODAL"}

    def _status(self, context, text: str | None = "") -> None:
        if context.workspace is None:
            return
        if text == "":
            name = self._steps[self._done][0]
            text = (f"Review Report: scene {self._done + 1} of {len(self._steps)}, {name} "
                    "(Esc stops after it)")
        context.workspace.status_text_set(text)

    def _end(self, context) -> None:
        wm = context.window_manager
        if self._timer is not None:
            wm.event_timer_remove(self._timer)
            wm.progress_end()
            self._timer = None
        self._status(context, None)

    def modal(self, context, event):
        stop = event.type == "ESC" and event.value == "PRESS"
        if not stop and event.type != "TIMER":
            return {"PASS_THROUGH"}
        try:
            if not stop:
                error = self._step()
                if error:
                    self._errors.append(error)
                context.window_manager.progress_update(self._done)
                if self._done < len(self._steps):
                    self._status(context)
                    return {"RUNNING_MODAL"}
        except BaseException:
            self._end(context)
            raise
        self._end(context)
        try:
            return self._finish(context, self._errors, stopped=stop)
        except (OSError, ValueError) as exc:
            self.report({"ERROR"}, f"Review Report: the page cannot be written ({exc})")
            return {"CANCELLED"}

    def cancel(self, context):
        self._end(context)


def _target_tree(context):
    """The shader tree to add to: the Shader Editor's, else the active object's material's."""
    space = context.space_data
    if space is not None and space.type == "NODE_EDITOR":
        tree = space.edit_tree
        ok = (space.tree_type == node_groups.SHADER_TREE and space.shader_type == "OBJECT"
              and tree is not None and tree.is_editable)
        return tree if ok else None
    obj = context.object
    mat = obj.active_material if obj is not None else None
    return mat.node_tree if mat is not None else None


class NODE_OT_bo2_add_material(bpy.types.Operator):
    """Add a BO2 Lighting node group (BO2 Material by default) to the material's node tree"""

    bl_idname = node_groups.ADD_OPERATOR
    bl_label = "Add BO2 Node Group"
    bl_options = {"REGISTER", "UNDO"}

    group: bpy.props.EnumProperty(
        name="Group",
        description="The node group to add",
        items=[(name, name, "") for name in (*node_groups.GROUP_NAMES[1:],
                                             node_groups.GROUP_NAMES[0])],
        default=node_groups.MATERIAL_GROUP,
    )

    use_transform: bpy.props.BoolProperty(
        name="Use Transform",
        description="Move the new node with the mouse after adding it",
        default=False,
        options={"SKIP_SAVE"},
    )

    @classmethod
    def poll(cls, context):
        return _target_tree(context) is not None

    def invoke(self, context, event):
        space = context.space_data
        in_editor = space is not None and space.type == "NODE_EDITOR"
        if in_editor and context.region is not None and context.region.type == "WINDOW":
            space.cursor_location_from_region(event.mouse_region_x, event.mouse_region_y)
        result = self.execute(context)
        if in_editor and self.use_transform and "FINISHED" in result:
            bpy.ops.node.translate_attach_remove_on_cancel("INVOKE_DEFAULT")
        return result

    def execute(self, context):
        tree = _target_tree(context)
        if tree is None:
            self.report({"ERROR"}, "No shader node tree to add to: select a material")
            return {"CANCELLED"}
        space = context.space_data
        in_editor = space is not None and space.type == "NODE_EDITOR"
        location = tuple(space.cursor_location) if in_editor else (0.0, 0.0)
        try:
            node_groups.add_material_node(tree, location, self.group)
        except ValueError as ex:
            self.report({"ERROR"}, str(ex))
            return {"CANCELLED"}
        return {"FINISHED"}


class MATERIAL_OT_bo2_new(bpy.types.Operator):
    """Create a BO2 Material on the active object (in its active slot)"""

    bl_idname = "material.bo2_new"
    bl_label = "New BO2 Material"
    bl_options = {"REGISTER", "UNDO"}

    def execute(self, context):
        obj = context.object
        if obj is None:
            self.report({"ERROR"}, "New BO2 Material: no active object")
            return {"CANCELLED"}
        if obj.type not in node_groups.MATERIAL_OBJECT_TYPES:
            self.report({"ERROR"}, f"New BO2 Material: the active object '{obj.name}' "
                        f"({obj.type}) cannot have materials")
            return {"CANCELLED"}
        mat = node_groups.new_material(node_groups.MATERIAL_GROUP)
        if len(obj.material_slots) == 0:
            obj.data.materials.append(mat)
        else:
            obj.active_material = mat
        return {"FINISHED"}


class MATERIAL_OT_bo2_convert(bpy.types.Operator):
    """Convert the material's Principled BSDF to a BO2 Material, or a BO2 Material back to a
    Principled BSDF, with the mapping of docs/engine.md"""

    bl_idname = "material.bo2_convert"
    bl_label = "Convert Material"
    bl_options = {"REGISTER", "UNDO"}

    direction: bpy.props.EnumProperty(
        name="Direction",
        items=[("TO_BO2", "To BO2 Material", "Principled BSDF -> BO2 Material (through BO2 "
                "Principled to Talk: textures stay connected)"),
               ("TO_PRINCIPLED", "To Principled BSDF", "BO2 Material -> Principled BSDF")],
        default="TO_BO2",
    )

    @classmethod
    def poll(cls, context):
        return getattr(context, "material", None) is not None

    def execute(self, context):
        mat = getattr(context, "material", None)
        if mat is None:
            self.report({"ERROR"}, "Convert Material: no active material")
            return {"CANCELLED"}
        try:
            if self.direction == "TO_BO2":
                for message in convert.to_bo2(mat):
                    self.report({"WARNING"}, message)
            else:
                convert.to_principled(mat)
        except (convert.ConvertError, ValueError) as exc:
            self.report({"ERROR"}, f"Convert Material: {exc}")
            return {"CANCELLED"}
        return {"FINISHED"}


class BO2_OT_evaluate_world(bpy.types.Operator):
    """Render the world's nodes with Cycles into the equirect BO2 Lighting reads (done by
    itself before bakes, after edits in the viewport and before renders of the bo2 command)"""

    bl_idname = "bo2.evaluate_world"
    bl_label = "Evaluate World"
    bl_options = {"REGISTER"}

    @classmethod
    def poll(cls, context):
        return context.scene.world is not None

    def execute(self, context):
        scene = context.scene
        if not worlds.ensure(scene):
            self.report({"ERROR"}, f"World '{scene.world.name}' cannot be evaluated "
                        f"({worlds.problem(scene.world) or 'Cycles failed'})")
            return {"CANCELLED"}
        scene.world.update_tag()
        self.report({"INFO"}, f"World '{scene.world.name}' evaluated")
        return {"FINISHED"}


CLASSES = [*bake_operators.CLASSES, BO2_OT_compare_cycles, BO2_OT_review_report,
           BO2_OT_evaluate_world, NODE_OT_bo2_add_material, MATERIAL_OT_bo2_new,
           MATERIAL_OT_bo2_convert]
