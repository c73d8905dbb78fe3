"""The BO2 Lighting render engine: F12, animations and headless ``blender -b ... -E BO2_LIGHTING``.

``render()`` extracts the evaluated scene, runs ``core.pipeline.render_frame`` with Blender's
progress and cancel callbacks, and writes the passes with ``foreach_set``. Any failure ends in
one ``error_set`` message, never a traceback in the UI.
"""

from __future__ import annotations

import sys
import time
import traceback

import bpy
import numpy as np

from ..core import pipeline
from ..core.scene import RenderSettings
from . import extract


def render_settings(scene) -> RenderSettings:
    """The engine's settings of a Blender scene as ``core.scene.RenderSettings``."""
    s = scene.bo2
    return RenderSettings(
        samples=int(s.samples),
        specular_model=str(s.specular_model),
        film_transparent=bool(scene.render.film_transparent),
    )


class BO2RenderEngine(bpy.types.RenderEngine):
    bl_idname = "BO2_LIGHTING"
    bl_label = "BO2 Lighting"
    bl_use_preview = False
    bl_use_postprocess = True

    def render(self, depsgraph):
        scene = depsgraph.scene
        start = time.perf_counter()
        try:
            self.update_stats("BO2 Lighting", "Reading scene")
            frame, warnings = extract.extract_scene(depsgraph, render_settings(scene))
            for message in warnings:
                self.report({"WARNING"}, message)
            ntris = sum(len(m.positions) for m in frame.meshes)
            self.update_stats("BO2 Lighting", f"Rendering {ntris:,} triangles")
            passes = pipeline.render_frame(
                frame, progress=self.update_progress, should_stop=self.test_break,
                warn=lambda message: self.report({"WARNING"}, message))
            self._write_result(passes, frame.camera.width, frame.camera.height)
        except pipeline.Cancelled:
            return
        except extract.SceneError as exc:
            self._fail(str(exc))
            return
        except Exception as exc:  # noqa: BLE001 - the UI gets one line, the console the trace
            traceback.print_exc(file=sys.stderr)
            self._fail(f"BO2 Lighting failed: {type(exc).__name__}: {exc}")
            return
        self.update_stats("BO2 Lighting", f"Done in {time.perf_counter() - start:.2f} s")

    def _fail(self, message: str) -> None:
        """Show one error: in the render window (``error_set``) and as the operator's report."""
        self.error_set(message)
        self.report({"ERROR"}, message)

    def _write_result(self, passes: dict, width: int, height: int) -> None:
        result = self.begin_result(0, 0, width, height)
        layer = result.layers[0]
        for name, image in passes.items():
            rp = layer.passes.find_by_name(name, "")
            if rp is None:
                continue
            # Blender's pixel rows run bottom to top; the core's run top to bottom.
            rp.rect.foreach_set(np.ascontiguousarray(image[::-1], np.float32).ravel())
        self.end_result(result)


CLASSES = [BO2RenderEngine]
