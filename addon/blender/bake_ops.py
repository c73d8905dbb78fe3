"""Operators: Bake All, Bake Selected and Clear of the BO2 light probes.

Invoked from the UI, a bake is modal: it runs one capture per timer tick, shows its progress
in the status bar (the window manager's progress cursor and the header text), and Esc or right
click cancels it cleanly (nothing written, previous bakes untouched). Run from a script
(``EXEC_DEFAULT``) it bakes to the end at once. Both report the time taken.
"""

from __future__ import annotations

import time

import bpy

from . import probes

_MODES = [("ALL", "All", "Every Sphere and Volume light probe"),
          ("SELECTED", "Selected", "The selected light probes")]


def _objects(context, mode: str) -> list:
    return probes.probe_objects(context.scene, selected_only=mode == "SELECTED")


class BO2_OT_bake_probes(bpy.types.Operator):
    """Bake the light probes for BO2 Lighting: SH irradiance and prefiltered cube maps"""

    bl_idname = "bo2.bake_probes"
    bl_label = "Bake Light Probes"
    bl_options = {"REGISTER"}

    mode: bpy.props.EnumProperty(name="Probes", items=_MODES, default="ALL")

    _timer = None
    _steps = None
    _start = 0.0
    _count = 0

    @classmethod
    def poll(cls, context):
        return context.scene is not None

    def _begin(self, context) -> bool:
        objs = _objects(context, self.mode)
        scene = context.scene
        try:
            if not objs:
                raise probes.BakeError("No Sphere or Volume light probes to bake"
                                       + (" among the selected objects"
                                          if self.mode == "SELECTED" else ""))
            probes.bake_folder(scene)  # fail early on an unsaved file
        except probes.BakeError as exc:
            self.report({"ERROR"}, str(exc))
            return False
        depsgraph = context.evaluated_depsgraph_get()
        self._steps = probes.bake_steps(scene, depsgraph, objs, scene.bo2.bake_backend,
                                        report=lambda m: self.report({"WARNING"}, m))
        self._start, self._count = time.perf_counter(), len(objs)
        return True

    def _step(self) -> float | None:
        """Advance one capture; the progress fraction, or None when done."""
        try:
            return next(self._steps)
        except StopIteration:
            return None

    def _finished(self) -> None:
        seconds = time.perf_counter() - self._start
        self.report({"INFO"}, f"Baked {self._count} light probe{'s' * (self._count != 1)} "
                    f"in {seconds:.1f} s")

    def execute(self, context):
        if not self._begin(context):
            return {"CANCELLED"}
        try:
            while self._step() is not None:
                pass
        except Exception as exc:  # noqa: BLE001 - one line in the UI
            self.report({"ERROR"}, f"Bake failed: {exc}; previous bakes kept")
            return {"CANCELLED"}
        self._finished()
        return {"FINISHED"}

    def invoke(self, context, event):
        if not self._begin(context):
            return {"CANCELLED"}
        wm = context.window_manager
        self._timer = wm.event_timer_add(0.01, window=context.window)
        wm.progress_begin(0, 1000)
        wm.modal_handler_add(self)
        return {"RUNNING_MODAL"}

    def _end(self, context) -> None:
        wm = context.window_manager
        if self._timer is not None:
            wm.event_timer_remove(self._timer)
            self._timer = None
        wm.progress_end()
        if context.area is not None:
            context.area.header_text_set(None)
        if context.workspace is not None:
            context.workspace.status_text_set(None)

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
            self._finished()
            return {"FINISHED"}
        context.window_manager.progress_update(int(fraction * 1000))
        if context.workspace is not None:
            context.workspace.status_text_set(
                f"Baking light probes: {fraction * 100:.0f}%  (Esc to cancel)")
        return {"RUNNING_MODAL"}


class BO2_OT_clear_probes(bpy.types.Operator):
    """Delete the baked files of the light probes (the world fallback lights them instead)"""

    bl_idname = "bo2.clear_probes"
    bl_label = "Clear Light Probe Bakes"
    bl_options = {"REGISTER"}

    mode: bpy.props.EnumProperty(name="Probes", items=_MODES, default="ALL")

    def invoke(self, context, event):
        return context.window_manager.invoke_confirm(self, event)

    def execute(self, context):
        try:
            count = probes.clear(context.scene, _objects(context, self.mode))
        except probes.BakeError as exc:
            self.report({"ERROR"}, str(exc))
            return {"CANCELLED"}
        self.report({"INFO"}, f"Deleted {count} bake file{'s' * (count != 1)}")
        return {"FINISHED"}


CLASSES = [BO2_OT_bake_probes, BO2_OT_clear_probes]
