"""The bakes' operators: light probes and lightmaps, Bake All, Bake Selected and Clear, and
packing the bakes into the .blend.

Invoked from the UI, a bake is modal: it runs one step (a capture, a block of texels) per timer
tick, shows its progress in the status bar (the window manager's progress cursor and the header
text), and Esc or right click cancels it cleanly (nothing written, previous bakes untouched).
Run from a script (``EXEC_DEFAULT``) it bakes to the end at once. Both report the time taken.
A scene whose Bake On is Dask Cluster bakes on the workers of its scheduler (``scheduler``):
the same steps, their captures and gathers tasks of the cluster (``cluster.session``).
"""

from __future__ import annotations

import time

import bpy

from ..core.render.job import Warnings
from . import bake, bake_files, lightmaps, probes, props

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


def scheduler(scene) -> str | None:
    """The address of the Dask scheduler that ``scene``'s bakes run on (``scene.bo2.bake_on``
    Dask Cluster: its Scheduler, else the preferences' Dask Scheduler), or None to bake here;
    BakeError when neither is set."""
    if scene.bo2.bake_on != "CLUSTER":
        return None
    address = scene.bo2.scheduler.strip() or props.preferences().scheduler.strip()
    if not address:
        raise probes.BakeError("Bake On is Dask Cluster but no scheduler is set: give its "
                               "address (tcp://host:8786) in the bake settings or in the "
                               "add-on's preferences")
    return address


def _on_cluster(address: str, ship: bool, steps):
    """``steps(cluster)`` on the Dask cluster at ``address`` (``cluster.session.Cluster``):
    connected at the second step (the first one lets the status bar say so), the open .blend
    sent to the workers when ``ship``; closed at the end, on an error and on cancel."""
    from ..cluster.session import Cluster

    yield 0.0
    cluster = Cluster(address)
    try:
        if ship:
            cluster.ship()
        return (yield from steps(cluster))
    finally:
        cluster.close()


def _busy() -> str | None:
    """Why a bake cannot start now (a render or another bake is running), or None."""
    if bpy.app.is_job_running("RENDER"):
        return "A render is running: wait for it, or cancel it, before baking"
    if _ModalBake.running:
        return "A bake is running: wait for it, or press Esc to cancel it"
    return None


class _ModalBake:
    """A bake run a step per timer tick (Esc cancels, nothing written) or, from a script, to
    the end at once. Subclasses give ``noun`` (messages), ``_objects(context)`` (what to bake;
    BakeError if nothing), ``_bake_steps(scene, objs, cluster)`` (the generator of progress
    fractions; ``cluster``: None, or the cluster the bake runs on) and ``ships`` (whether the
    cluster's workers need the .blend)."""

    noun = ""
    what = ""
    where = ""  # " on ADDRESS" for a bake on a cluster
    ships = True

    _timer = None
    _steps = None
    _start_time = 0.0
    _count = 0

    running = False  # a modal bake is in progress (one at a time, of either kind)

    def _warnings(self) -> Warnings:
        """The bake's warning sink: each message the operator's report."""
        return Warnings(lambda m: self.report({m.kind}, m.text))

    @classmethod
    def poll(cls, context):
        return context.scene is not None

    def _begin(self, context) -> bool:
        try:
            busy = _busy()
            if busy:
                raise probes.BakeError(busy)
            objs = self._objects(context)
            probes.writable_folder(context.scene)  # fail early: unsaved file, unwritable folder
            address = scheduler(context.scene)
            self.what = f"{self.noun}{'s' * (len(objs) != 1)}"
            scene = context.scene
            if address is None:
                self.where = ""
                self._steps = self._bake_steps(scene, objs, None)
            else:
                self._refuse_cluster(scene)
                self.where = f" on {address}"
                self._steps = _on_cluster(address, self.ships,
                                          lambda cluster: self._bake_steps(scene, objs, cluster))
            self._count = len(objs)
        except probes.BakeError as exc:
            self.report({"ERROR"}, str(exc))
            return False
        self._start_time = time.perf_counter()
        return True

    def _refuse_cluster(self, scene) -> None:
        """BakeError when this bake cannot run on a cluster."""

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
        self.report({"INFO"}, f"Baked {self._count} {self.what}{self.where} in {seconds:.1f} s")

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
        if context.workspace is not None and self.where:
            context.workspace.status_text_set(f"Baking {self.what}{self.where}: connecting")
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
                f"Baking {self.what}{self.where}: {fraction * 100:.0f}%  (Esc to cancel)")
        return {"RUNNING_MODAL"}


class BO2_OT_bake_probes(_ModalBake, bpy.types.Operator):
    """Bake the light probes for BO2 Lighting: SH irradiance and prefiltered cube maps"""

    bl_idname = "bo2.bake_probes"
    bl_label = "Bake Light Probes"
    bl_options = {"REGISTER", "UNDO"}  # they change the .blend's bake datablocks

    mode: bpy.props.EnumProperty(name="Probes", items=_MODES, default="ALL")

    noun = "light probe"

    def _objects(self, context):
        return _objects(context, self.mode)

    def _bake_steps(self, scene, objs, cluster):
        return bake.bake_steps(scene, objs, probes.capture_backend(scene), self._warnings(),
                               cluster=cluster)


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

    noun = "lightmap"
    ships = False  # the gathers need the texels and the scene's rays, not the .blend

    def _objects(self, context):
        return _lightmap_objects(context, self.mode)

    def _refuse_cluster(self, scene):
        if probes.capture_backend(scene) == "CYCLES":
            raise probes.BakeError("The Cycles backend bakes lightmaps on this machine only: "
                                   "set Bake On to This Machine, or bake them with the BO2 "
                                   "backend")

    def _bake_steps(self, scene, objs, cluster):
        return bake.lightmap_steps(scene, objs, self._warnings(),
                                   backend=probes.capture_backend(scene), cluster=cluster)


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


CLASSES = [BO2_OT_bake_probes, BO2_OT_clear_probes, BO2_OT_pack_bakes, BO2_OT_unpack_bakes,
           BO2_OT_bake_lightmaps, BO2_OT_clear_lightmaps]
