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
from . import extract, probes

# Blender's pass name -> (channels, channel ids, type, view layer flag or bo2 AOV flag).
PASS_LAYOUT = {
    "Depth": (1, "Z", "VALUE", "use_pass_z"),
    "Normal": (3, "XYZ", "VECTOR", "use_pass_normal"),
    "Position": (3, "XYZ", "VECTOR", "use_pass_position"),
    "UV": (3, "UVA", "VECTOR", "use_pass_uv"),
    "IndexMA": (1, "X", "VALUE", "use_pass_material_index"),
    "DiffDir": (3, "RGB", "COLOR", "use_pass_diffuse_direct"),
    "GlossDir": (3, "RGB", "COLOR", "use_pass_glossy_direct"),
    "DiffInd": (3, "RGB", "COLOR", "use_pass_diffuse_indirect"),
    "GlossInd": (3, "RGB", "COLOR", "use_pass_glossy_indirect"),
    "Emit": (3, "RGB", "COLOR", "use_pass_emit"),
    "Albedo": (3, "RGB", "COLOR", "bo2.use_pass_albedo"),
    "Specular Color": (3, "RGB", "COLOR", "bo2.use_pass_specular_color"),
    "Gloss": (1, "X", "VALUE", "bo2.use_pass_gloss"),
}


# Blender 5.0 renamed these built-in passes; the engine registers and writes every pass under the
# running Blender's name, as Cycles does, so that compositor set-ups work with both engines.
RENAMED_IN_5 = {"DiffDir": "Diffuse Direct", "GlossDir": "Glossy Direct", "Emit": "Emission",
                "IndexMA": "Material Index", "DiffInd": "Diffuse Indirect",
                "GlossInd": "Glossy Indirect"}


def blender_pass_name(name: str) -> str:
    """The running Blender's name of the pipeline's pass ``name`` (``pipeline.PASSES``)."""
    return RENAMED_IN_5.get(name, name) if bpy.app.version >= (5, 0, 0) else name


def pass_enabled(view_layer, flag: str) -> bool:
    owner = view_layer.bo2 if flag.startswith("bo2.") else view_layer
    return bool(getattr(owner, flag.removeprefix("bo2."), False))


def render_border(scene, width: int, height: int) -> tuple[int, int, int, int] | None:
    """Blender's render border as a pixel rectangle (x0, y0, x1, y1), top-left origin."""
    r = scene.render
    if not r.use_border:
        return None
    x0, x1 = int(r.border_min_x * width), int(np.ceil(r.border_max_x * width))
    y0, y1 = int((1.0 - r.border_max_y) * height), int(np.ceil((1.0 - r.border_min_y) * height))
    x0, y0 = max(0, min(x0, width - 1)), max(0, min(y0, height - 1))
    x1, y1 = max(x0 + 1, min(x1, width)), max(y0 + 1, min(y1, height))
    return x0, y0, x1, y1


def render_settings(scene) -> RenderSettings:
    """The engine's settings of a Blender scene as ``core.scene.RenderSettings``."""
    s = scene.bo2
    width, height = extract.resolution(scene)
    return RenderSettings(
        samples=int(s.samples),
        shade_every_sample=bool(s.shade_every_sample),
        filter_width=float(scene.render.filter_size),
        specular_model=str(s.specular_model),
        env_brdf=str(s.env_brdf),
        normalization=str(s.normalization),
        prefilter=str(s.prefilter),
        film_transparent=bool(scene.render.film_transparent),
        shadow_resolution=int(s.shadow_resolution),
        threads=int(scene.render.threads),  # Blender's Threads setting (Auto: one per core)
        border=render_border(scene, width, height),
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
            if scene.bo2.use_indirect:
                frame.probes = probes.load_probes(scene, frame.world, warnings)
            for message in warnings:
                self.report({"WARNING"}, message)
            ntris = sum(len(m.positions) for m in frame.meshes)
            self.update_stats("BO2 Lighting", f"Rendering {ntris:,} triangles")
            tiles = pipeline.render_tiles(
                frame, progress=self.update_progress, should_stop=self.test_break,
                warn=lambda message: self.report({"WARNING"}, message))
            for tile, passes in tiles:
                self._write_tile(tile, passes, frame, depsgraph.view_layer.name)
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

    def _write_tile(self, tile, passes: dict, frame, layer_name: str) -> None:
        x0, y0, x1, y1 = tile
        border = frame.settings.border
        # Blender's result rows run bottom to top, relative to the border when there is one.
        bx, by = (border[0], frame.camera.height - border[3]) if border else (0, 0)
        result = self.begin_result(x0 - bx, frame.camera.height - y1 - by, x1 - x0, y1 - y0,
                                   layer=layer_name)
        layer = result.layers[0]
        for name, image in passes.items():
            rp = layer.passes.find_by_name(blender_pass_name(name), "")
            if rp is not None:
                rp.rect.foreach_set(np.ascontiguousarray(image[::-1], np.float32).ravel())
        self.end_result(result)

    def update_render_passes(self, scene=None, renderlayer=None):
        self.register_pass(scene, renderlayer, "Combined", 4, "RGBA", "COLOR")
        for name, (channels, ids, kind, flag) in PASS_LAYOUT.items():
            if pass_enabled(renderlayer, flag):
                self.register_pass(scene, renderlayer, blender_pass_name(name), channels, ids,
                                   kind)


CLASSES = [BO2RenderEngine]
