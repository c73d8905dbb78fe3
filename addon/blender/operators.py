"""The add-on's operators: light probe and lightmap bakes, Compare with Cycles, BO2 Material
nodes.

Light probes and lightmaps: Bake All, Bake Selected and Clear. Invoked from the UI, a bake is
modal: it runs one step (a capture, a block of texels) per timer tick, shows its progress in
the status bar (the window manager's progress cursor and the header text), and Esc or right
click cancels it cleanly (nothing written, previous bakes untouched). Run from a script
(``EXEC_DEFAULT``) it bakes to the end at once. Both report the time taken.
"""

from __future__ import annotations

import time

import bpy

from ..core.render.job import Warnings
from ..core.review import compare as core_compare
from ..core.review import report as core_report
from . import bake, bake_files, compare, convert, lightmaps, node_groups, probes, report, worlds

_MODES = [("ALL", "All", "Every Sphere and Volume light probe"),
          ("SELECTED", "Selected", "The selected light probes"),
          ("ACTIVE", "Active", "The active object, a light probe")]


def _objects(context, mode: str) -> list:
    """The light probes of ``mode``; raises BakeError when there are none."""
    if mode == "ACTIVE":
        obj = context.object
        if obj is None or obj.type != "LIGHT_PROBE":
            raise probes.BakeError("The active object is not a light probe")
        if obj.data.type not in probes.KINDS:
            raise probes.BakeError(f"Light probe '{obj.name}' is a {obj.data.type.title()} "
                                   "probe: BO2 Lighting bakes Sphere and Volume probes")
        return [obj]
    objs = probes.probe_objects(context.scene, selected_only=mode == "SELECTED")
    if not objs:
        raise probes.BakeError("No Sphere or Volume light probes"
                               + (" among the selected objects" if mode == "SELECTED" else ""))
    return objs


def _busy() -> str | None:
    """Why a bake cannot start now (a render or another bake is running), or None."""
    if bpy.app.is_job_running("RENDER"):
        return "A render is running: wait for it, or cancel it, before baking"
    if _ModalBake.running:
        return "A bake is running: wait for it, or press Esc to cancel it"
    return None


class _ModalBake:
    """A bake run a step per timer tick (Esc cancels, nothing written) or, from a script, to
    the end at once. Subclasses give ``what`` (messages) and ``_start(context)``: (the
    generator of progress fractions, the number of things baked); raising BakeError."""

    what = "light probes"

    _timer = None
    _steps = None
    _start_time = 0.0
    _count = 0

    running = False  # a modal bake is in progress (one at a time, of either kind)

    @classmethod
    def poll(cls, context):
        return context.scene is not None

    def _begin(self, context) -> bool:
        try:
            busy = _busy()
            if busy:
                raise probes.BakeError(busy)
            self._steps, self._count = self._start(context)
        except probes.BakeError as exc:
            self.report({"ERROR"}, str(exc))
            return False
        self._start_time = time.perf_counter()
        return True

    def _step(self) -> float | None:
        """Advance one step; the progress fraction, or None when done (``_count`` is then
        what the bake wrote)."""
        try:
            return next(self._steps)
        except StopIteration as done:
            if done.value is not None:
                self._count = done.value
            return None

    def _finished(self, context) -> None:
        context.scene.update_tag()  # viewports read the new bakes
        seconds = time.perf_counter() - self._start_time
        self.report({"INFO"}, f"Baked {self._count} {self.what} in {seconds:.1f} s")

    def execute(self, context):
        if not self._begin(context):
            return {"CANCELLED"}
        try:
            while self._step() is not None:
                pass
        except Exception as exc:  # noqa: BLE001 - one line in the UI
            self.report({"ERROR"}, f"Bake failed: {exc}; previous bakes kept")
            return {"CANCELLED"}
        self._finished(context)
        return {"FINISHED"}

    def invoke(self, context, event):
        if not self._begin(context):
            return {"CANCELLED"}
        wm = context.window_manager
        self._timer = wm.event_timer_add(0.01, window=context.window)
        wm.progress_begin(0, 1000)
        wm.modal_handler_add(self)
        _ModalBake.running = True
        return {"RUNNING_MODAL"}

    def _end(self, context) -> None:
        _ModalBake.running = False
        wm = context.window_manager
        if self._timer is not None:
            wm.event_timer_remove(self._timer)
            self._timer = None
        wm.progress_end()
        if context.area is not None:
            context.area.header_text_set(None)
        if context.workspace is not None:
            context.workspace.status_text_set(None)

    def cancel(self, context):
        """Blender ends the bake (a file loaded, the window closed): nothing is written."""
        self._steps.close()
        self._end(context)

    def modal(self, context, event):
        if event.type in {"ESC", "RIGHTMOUSE"}:
            self._steps.close()  # nothing is written
            self._end(context)
            self.report({"WARNING"}, "Bake cancelled; previous bakes kept")
            return {"CANCELLED"}
        if event.type != "TIMER":
            return {"PASS_THROUGH"}
        try:
            fraction = self._step()
        except Exception as exc:  # noqa: BLE001 - one line in the UI
            self._end(context)
            self.report({"ERROR"}, f"Bake failed: {exc}; previous bakes kept")
            return {"CANCELLED"}
        if fraction is None:
            self._end(context)
            self._finished(context)
            return {"FINISHED"}
        context.window_manager.progress_update(int(fraction * 1000))
        if context.workspace is not None:
            context.workspace.status_text_set(
                f"Baking {self.what}: {fraction * 100:.0f}%  (Esc to cancel)")
        return {"RUNNING_MODAL"}


class BO2_OT_bake_probes(_ModalBake, bpy.types.Operator):
    """Bake the light probes for BO2 Lighting: SH irradiance and prefiltered cube maps"""

    bl_idname = "bo2.bake_probes"
    bl_label = "Bake Light Probes"
    bl_options = {"REGISTER", "UNDO"}  # they change the .blend's bake datablocks

    mode: bpy.props.EnumProperty(name="Probes", items=_MODES, default="ALL")

    def _start(self, context):
        scene = context.scene
        objs = _objects(context, self.mode)
        probes.writable_folder(scene)  # fail early: unsaved file, unwritable folder
        self.what = f"light probe{'s' * (len(objs) != 1)}"
        steps = bake.bake_steps(scene, objs, probes.capture_backend(scene),
                                Warnings(lambda m: self.report({m.kind}, m.text)))
        return steps, len(objs)


_LIGHTMAP_MODES = [("ALL", "All", "Every static mesh object"),
                   ("SELECTED", "Selected", "The selected static mesh objects")]


def _lightmap_objects(context, mode: str) -> list:
    """The static mesh objects of ``mode``; raises BakeError when there are none."""
    objs = lightmaps.lightmap_objects(context.scene, selected_only=mode == "SELECTED")
    if not objs:
        raise probes.BakeError("No static mesh objects"
                               + (" among the selected objects" if mode == "SELECTED" else "")
                               + " (Object > BO2 Lightmap sets what is static)")
    return objs


class BO2_OT_bake_lightmaps(_ModalBake, bpy.types.Operator):
    """Bake the lightmaps of static objects for BO2 Lighting: the diffuse indirect light of
    their surfaces, per texel"""

    bl_idname = "bo2.bake_lightmaps"
    bl_label = "Bake Lightmaps"
    bl_options = {"REGISTER", "UNDO"}  # they change the .blend's bake datablocks

    mode: bpy.props.EnumProperty(name="Objects", items=_LIGHTMAP_MODES, default="ALL")

    def _start(self, context):
        scene = context.scene
        objs = _lightmap_objects(context, self.mode)
        probes.writable_folder(scene)
        self.what = f"lightmap{'s' * (len(objs) != 1)}"
        steps = bake.lightmap_steps(scene, objs, Warnings(lambda m: self.report({m.kind}, m.text)),
                                    backend=probes.capture_backend(scene))
        return steps, len(objs)


class BO2_OT_clear_lightmaps(bpy.types.Operator):
    """Delete the lightmap files of static objects (the probes light them instead)"""

    bl_idname = "bo2.clear_lightmaps"
    bl_label = "Clear Lightmaps"
    bl_options = {"REGISTER", "UNDO"}  # they change the .blend's bake datablocks

    mode: bpy.props.EnumProperty(name="Objects", items=_LIGHTMAP_MODES, default="ALL")

    def execute(self, context):
        try:
            if _busy():
                raise probes.BakeError(_busy().replace("baking", "clearing lightmaps"))
            count = bake.clear(context.scene, _lightmap_objects(context, self.mode))
        except probes.BakeError as exc:
            self.report({"ERROR"}, str(exc))
            return {"CANCELLED"}
        context.scene.update_tag()
        self.report({"INFO"}, f"Deleted {count} lightmap file{'s' * (count != 1)}")
        return {"FINISHED"}


class BO2_OT_clear_probes(bpy.types.Operator):
    """Delete the baked files of the light probes (the world fallback lights them instead)"""

    bl_idname = "bo2.clear_probes"
    bl_label = "Clear Light Probe Bakes"
    bl_options = {"REGISTER", "UNDO"}  # they change the .blend's bake datablocks

    mode: bpy.props.EnumProperty(name="Probes", items=_MODES, default="ALL")

    def invoke(self, context, event):
        return context.window_manager.invoke_confirm(self, event)

    def execute(self, context):
        try:
            busy = _busy()
            if busy:
                raise probes.BakeError(busy.replace("baking", "clearing bakes"))
            count = bake.clear(context.scene, _objects(context, self.mode))
        except probes.BakeError as exc:
            self.report({"ERROR"}, str(exc))
            return {"CANCELLED"}
        context.scene.update_tag()  # viewports fall back to the world
        self.report({"INFO"}, f"Deleted {count} bake file{'s' * (count != 1)}")
        return {"FINISHED"}


def _baked_objects(scene) -> list:
    """The scene's light probes and static mesh objects (whose bakes Pack and Unpack move)."""
    return probes.probe_objects(scene) + lightmaps.lightmap_objects(scene)


class BO2_OT_pack_bakes(bpy.types.Operator):
    """Store the scene's bakes (light probes and lightmaps) inside the .blend, so that the
    saved file carries its light"""

    bl_idname = "bo2.pack_bakes"
    bl_label = "Pack Bakes"
    bl_options = {"REGISTER", "UNDO"}

    def execute(self, context):
        try:
            count = bake_files.pack(_baked_objects(context.scene))
        except probes.BakeError as exc:
            self.report({"ERROR"}, str(exc))
            return {"CANCELLED"}
        self.report({"INFO"}, f"Packed {count} bake{'s' * (count != 1)} into the .blend "
                    "(save the file to keep them)")
        return {"FINISHED"}


class BO2_OT_unpack_bakes(bpy.types.Operator):
    """Write the scene's packed bakes back to their files in the bake folder, and keep them
    there rather than in the .blend"""

    bl_idname = "bo2.unpack_bakes"
    bl_label = "Unpack Bakes"
    bl_options = {"REGISTER", "UNDO"}

    def execute(self, context):
        try:
            count = bake_files.unpack(context.scene, _baked_objects(context.scene))
        except probes.BakeError as exc:
            self.report({"ERROR"}, str(exc))
            return {"CANCELLED"}
        self.report({"INFO"}, f"Wrote {count} packed bake{'s' * (count != 1)} to the bake "
                    "folder")
        return {"FINISHED"}


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


CLASSES = [BO2_OT_bake_probes, BO2_OT_clear_probes, BO2_OT_pack_bakes, BO2_OT_unpack_bakes,
           BO2_OT_bake_lightmaps,
           BO2_OT_clear_lightmaps, BO2_OT_compare_cycles, BO2_OT_review_report,
           BO2_OT_evaluate_world,
           NODE_OT_bo2_add_material, MATERIAL_OT_bo2_new, MATERIAL_OT_bo2_convert]
