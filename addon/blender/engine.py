"""The BO2 Lighting render engine: F12, animations and headless ``blender -b ... -E BO2_LIGHTING``.

``render()`` extracts the evaluated scene, runs ``core.render.pipeline.render_tiles`` with Blender's
progress and cancel callbacks, and writes the passes with ``foreach_set``. Any failure ends in
one ``error_set`` message, never a traceback in the UI. The same ``render()`` draws Blender's
material, light and world previews (``is_preview``) in the talk's model.
"""

from __future__ import annotations

import contextlib
import sys
import time
import traceback
from collections.abc import Iterator

import bpy
import numpy as np

from ..core import kernels
from ..core.bakes import bounce
from ..core.render import cryptomatte, memory, pipeline
from ..core.render.job import Cancelled, Message, RenderJob, Warnings
from ..core.render.passes import PASSES, group_pass
from ..core.render.viewport import VIEWS
from . import extract, gpu_frames, interrupt, motion, passes, render_graph, viewport
from . import settings as settings_of


class BO2RenderEngine(bpy.types.RenderEngine):
    bl_idname = "BO2_LIGHTING"
    bl_label = "BO2 Lighting"
    bl_use_preview = True  # material, light and world previews: rendered by BO2 itself
    bl_use_postprocess = True
    bl_use_eevee_viewport = True  # Material Preview shading: EEVEE renders the BO2 groups
    bl_use_shading_nodes_custom = False  # Blender's shader node trees: the Shader Editor works
    # F12 in a window draws on the GPU (``gpu_frames``); in background mode the context is
    # opened only after a child process showed it can be (a Blender without one aborts)
    bl_use_gpu_context = not bpy.app.background

    def __init__(self, *args, **kwargs):
        super().__init__(*args, **kwargs)
        self._viewport = None
        self._drawing = None

    def __del__(self):
        try:
            view = self._viewport
        except (AttributeError, ReferenceError):  # 4.5 may free the struct first
            return
        if view is not None:
            view.close()

    # ---- the viewport's Rendered shading (``blender/viewport.py``) ------------------------

    def view_update(self, context, depsgraph):
        try:
            if self._viewport is None:
                kernels.check()  # compiling, when needed, happens on the render thread
                self._viewport = viewport.Viewport()
                self._viewport.sync(depsgraph)
            else:
                self._viewport.sync(depsgraph, depsgraph.updates)
        except kernels.KernelsUnavailable as exc:
            self.update_stats("BO2 Lighting", str(exc))
        except Exception as exc:  # noqa: BLE001 - the viewport shows one line, the console the trace
            traceback.print_exc(file=sys.stderr)
            if self._viewport is not None:
                self._viewport.error = f"{type(exc).__name__}: {exc}"
        self.tag_redraw()

    def view_draw(self, context, depsgraph):
        view = self._viewport
        if view is None:
            return
        region, space = context.region, context.space_data
        try:
            view.set_shading(depsgraph, space)  # the Scene World / Scene Lights toggles
        except Exception as exc:  # noqa: BLE001 - the viewport shows one line, the console the trace
            traceback.print_exc(file=sys.stderr)
            view.error = f"{type(exc).__name__}: {exc}"
        view.set_view(getattr(space.shading, "bo2_lookdev_view", "COMBINED"))
        scale = viewport.pixel_size(depsgraph.scene, context.preferences)
        camera = viewport.region_camera(region, context.region_data, scale)
        viewer = depsgraph.scene.camera
        if context.region_data.view_perspective == "CAMERA" and viewer is not None \
                and viewer.type == "CAMERA" and camera.aperture is None:
            camera.aperture = extract.aperture(viewer.evaluated_get(depsgraph), None)
        view.set_camera(camera)
        busy = view.session.busy  # before the image: a last sample landing now is redrawn
        if self._drawing is None:
            self._drawing = viewport.Drawing()
        texture = None if view.error else view.draw_gpu(camera)
        if texture is not None:
            data = VIEWS[view.session.view].data
            self._drawing.draw_texture(self, depsgraph.scene, texture, data, region.width,
                                       region.height)
            busy = busy or view.gpu_busy
        else:
            image = view.session.image()
            if image is not None and not (view.error or view.session.error):
                self._drawing.draw(self, depsgraph.scene, image, region.width, region.height)
        self.update_stats("BO2 Lighting", view.status())
        if busy:
            self.tag_redraw()  # poll until the refinement is done

    def render(self, depsgraph):
        if render_graph.serve(depsgraph):  # a bake reading the scene as renders evaluate it
            return
        scene = depsgraph.scene
        start = time.perf_counter()
        frame = None
        sink = Warnings(self._forward)
        try:
            kernels.load(lambda message: self.update_stats("BO2 Lighting", message),
                         kernels.FRAME_MODULES)
            self.update_stats("BO2 Lighting", "Reading scene")
            settings = settings_of.render_settings(
                scene, "PREVIEW" if self.is_preview else "FINAL", depsgraph.view_layer)
            should_stop = lambda: self.test_break() or interrupt.requested()  # noqa: E731
            frame, _ = extract.extract_scene(depsgraph, settings, indirect=scene.bo2.indirect.use,
                                             should_stop=should_stop, warnings=sink)
            if settings_of.motion_blur(scene, "PREVIEW" if self.is_preview else "FINAL"):
                self.update_stats("BO2 Lighting", "Reading the motion over the shutter")
                frame = motion.attach(self, depsgraph, frame, sink, should_stop)
            if not self.is_preview:
                self.update_stats("BO2 Lighting", "Baking the bounce without probes")
                frame = bounce.attach(frame, should_stop)
            ntris = sum(len(m.positions) for m in frame.meshes)
            self.update_stats("BO2 Lighting", f"Rendering {ntris:,} triangles")
            job = RenderJob(frame, progress=self.update_progress, should_stop=should_stop,
                            warnings=sink)
            prepared = None
            if not self.is_preview:
                prepared, device = self._render_gpu(job, depsgraph)
                if device == "GPU":
                    seconds = time.perf_counter() - start
                    self._rendered(seconds, "GPU")
                    return
            for tile, layers in pipeline.render_tiles(job, frame=prepared):
                self._write_tile(tile, layers, frame, depsgraph.view_layer.name)
            self._stamp_cryptomatte(frame, depsgraph.view_layer.name, job.warn)
        except Cancelled:
            return
        except (extract.SceneError, kernels.KernelsUnavailable) as exc:
            self._fail(str(exc))
            return
        except MemoryError as exc:
            self._fail(memory.out_of_memory(frame, exc))  # (frame None: while it was read)
            return
        except Exception as exc:  # noqa: BLE001 - the UI gets one line, the console the trace
            traceback.print_exc(file=sys.stderr)
            self._fail(f"BO2 Lighting failed: {type(exc).__name__}: {exc}")
            return
        self._rendered(time.perf_counter() - start, "CPU")

    def _rendered(self, seconds: float, device: str) -> None:
        for listener in list(_listeners):
            listener.add(f"{'Preview' if self.is_preview else 'Frame'} rendered in "
                         f"{seconds:.3f} s", "INFO")
        self.update_stats("BO2 Lighting", f"Done in {seconds:.2f} s ({device})")

    def _render_gpu(self, job, depsgraph) -> tuple[object, str]:
        """Draw the job's frame on the GPU where the Device setting and this session allow:
        (the prepared frame or None, "GPU" when drawn and written, else "CPU"). Why it was not
        drawn there is said once per render in the Auto device's case (as INFO), and always
        when GPU was chosen (as WARNING); a failure on the GPU goes to the CPU the same way."""
        scene = depsgraph.scene
        why = gpu_frames.refusal(scene)
        if why and scene.bo2.device == "CPU":
            return None, "CPU"
        prepared = None
        if not why:
            try:
                self.update_stats("BO2 Lighting", "Drawing on the GPU")
                prepared, drawn = gpu_frames.render(job, depsgraph.view_layer)
            except Cancelled:
                raise
            except Exception as exc:  # noqa: BLE001 - the frame goes to the CPU, the cause said
                traceback.print_exc(file=sys.stderr)  # (memory too: the CPU's is another)
                drawn = f"a GPU failure: {type(exc).__name__}: {exc}"
            if isinstance(drawn, dict):
                cam = job.scene.camera
                border = job.scene.settings.border or (0, 0, cam.width, cam.height)
                x0, y0, x1, y1 = border
                self._write_tile(border, {name: image[y0:y1, x0:x1]
                                          for name, image in drawn.items()},
                                 job.scene, depsgraph.view_layer.name)
                self._stamp_cryptomatte(job.scene, depsgraph.view_layer.name, job.warn)
                job.warn(f"Rendered on the GPU ({gpu_frames.renderer()})", "INFO")
                return prepared, "GPU"
            why = drawn
        kind = "WARNING" if scene.bo2.device == "GPU" else "INFO"
        job.warn(f"Rendered on the CPU: {why}" if why.startswith(("no GPU", "a GPU failure",
                                                                  "the GPU is"))
                 else f"Rendered on the CPU: the GPU does not draw {why} yet", kind)
        return prepared, "CPU"

    def _forward(self, message: Message) -> None:
        """A render's message: the operator's report (not a preview's), and every listener's
        sink (``listening``)."""
        if not self.is_preview:
            self.report({message.kind}, message.text)
        for listener in list(_listeners):
            listener.add(message.text, message.kind)

    def _fail(self, message: str) -> None:
        """Show one error: in the render window (``error_set``) and as the operator's report."""
        self.error_set(message)
        self.report({"ERROR"}, message)

    def _write_tile(self, tile, layers: dict, frame, layer_name: str) -> None:
        x0, y0, x1, y1 = tile
        border = frame.settings.border
        # Blender's result rows run bottom to top, relative to the border when there is one.
        bx, by = (border[0], frame.camera.height - border[3]) if border else (0, 0)
        result = self.begin_result(x0 - bx, frame.camera.height - y1 - by, x1 - x0, y1 - y0,
                                   layer=layer_name)
        layer = result.layers[0]
        for name, image in layers.items():
            rp = layer.passes.find_by_name(passes.blender_name(name), "")
            if rp is not None:
                rp.rect.foreach_set(np.ascontiguousarray(image[::-1], np.float32).ravel())
        self.end_result(result)

    def _stamp_cryptomatte(self, frame, layer_name: str, warn) -> None:
        """The render's Cryptomatte metadata: the names the Cryptomatte node lists; ``warn``
        (text, kind) says which of them clash."""
        if not frame.settings.cryptomatte:
            return
        result = self.get_result()
        for kind in frame.settings.cryptomatte:
            names = cryptomatte.manifest(frame, kind)
            for a, b in cryptomatte.clashes(names):
                warn(f"Cryptomatte {kind}: '{a}' and '{b}' have the same id, so one matte "
                     "picks both; rename one", "WARNING")
            for key, value in cryptomatte.metadata(layer_name, kind, names).items():
                result.stamp_data_add_field(key, value)

    def update_render_passes(self, scene=None, renderlayer=None):
        self.register_pass(scene, renderlayer, "Combined", 4, "RGBA", "COLOR")
        for name, p in PASSES.items():
            if name != "Combined" and passes.enabled(renderlayer, name):
                self.register_pass(scene, renderlayer, passes.blender_name(name), p.channels,
                                   p.ids, p.kind)
        for name in passes.cryptomatte_passes(renderlayer):
            self.register_pass(scene, renderlayer, name, 4, "rgba", "COLOR")  # as Cycles
        for group in renderlayer.lightgroups:
            self.register_pass(scene, renderlayer, group_pass(group.name), 3, "RGB", "COLOR")
        for name, kind in passes.aovs(renderlayer):  # as Cycles registers them
            self.register_pass(scene, renderlayer, name, 4 if kind == "COLOR" else 1,
                               "RGBA" if kind == "COLOR" else "X", kind)


_listeners: list[Warnings] = []  # the sinks ``listening`` holds open


@contextlib.contextmanager
def listening(sink: Warnings | None = None) -> Iterator[Warnings]:
    """While open, ``sink`` (a new one by default) receives every message of every render
    (previews too), and an INFO message "Frame (Preview) rendered in S s" after each: how
    ``bo2 render`` reads a render's warnings (Blender's own report printing is silenced
    there) and how a test or a script learns what a render said."""
    sink = Warnings() if sink is None else sink
    _listeners.append(sink)
    try:
        yield sink
    finally:
        _listeners.remove(sink)

CLASSES = [BO2RenderEngine]
