"""Interactive rendering: a scene rendered progressively on a worker thread.

The host (Blender's viewport) hands ``Session.update`` a new ``Scene`` and what changed in it;
the worker renders a first image at reduced resolution, then the full resolution one sample at
a time up to the viewport's sample count, and publishes each image. A newer update cancels the
work in progress within one tile (the render's ``should_stop``). Work is kept where the change
allows it: a camera move only projects again, a material tweak rebuilds the material tables,
a light change the shadow maps; only geometry changes prepare the frame anew.

Look-dev views (``VIEWS``) show one pass instead of the image, as game engines' buffer
visualisations; switching the view re-derives the image from the last passes, no render.
"""

from __future__ import annotations

import dataclasses
import threading
import traceback
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from .. import kernels
from ..lighting import world_probes
from ..scene import Camera, Scene
from . import pipeline
from .buffers import Frame, blend_order, with_camera, with_materials
from .job import Cancelled, RenderJob, Warnings
from .passes import EMPTY_DEPTH
from .shadow_maps import build_shadow_maps, drawn_on_gpu, shadow_map_count
from .visibility import sample_offsets

# What ``Session.update`` may be told changed.
CHANGES = frozenset({"geometry", "materials", "lights", "camera", "settings", "world", "probes"})
PREVIEW_DIVIDER = 4  # the first image after a change: this many times smaller per axis
# Tile size of viewport renders: small tiles keep both cores busy on a small image, and their
# raster set-ups are kept across renders (``Frame.tiles``), so their count costs little.
TILE_SIZE = 128


@dataclass(frozen=True)
class View:
    """A look-dev view: ``source`` a pass name or one of the probe views; ``data`` True for
    values shown as they are (no display transform)."""

    label: str
    source: str
    data: bool
    description: str


VIEWS: dict[str, View] = {
    "COMBINED": View("Combined", "Combined", False, "The rendered image"),
    "ALBEDO": View("Albedo", "Albedo", False, "The talk's diffuse albedo"),
    "SPECULAR_COLOR": View("Specular Color", "Specular Color", False,
                           "The talk's rf0, the specular colour at normal incidence"),
    "GLOSS": View("Gloss", "Gloss", True, "Gloss in [0, 1] (specular power 8192^gloss)"),
    "NORMAL": View("Normal", "Normal", True, "World-space shading normal as 0.5 n + 0.5"),
    "DIFFUSE_DIRECT": View("Diffuse Direct", "DiffDir", False, "Lambert from the lights"),
    "GLOSSY_DIRECT": View("Glossy Direct", "GlossDir", False,
                          "The microfacet specular from the lights"),
    "DIFFUSE_INDIRECT": View("Diffuse Indirect", "DiffInd", False,
                             "SH irradiance from the volumes and the world"),
    "GLOSSY_INDIRECT": View("Glossy Indirect", "GlossInd", False,
                            "Prefiltered cube maps times the environment BRDF"),
    "REFLECTION_PROBES": View("Reflection Probe Influence", "reflection", True,
                              "Which reflection probe lights each pixel (grey: the world)"),
    "IRRADIANCE_VOLUMES": View("Irradiance Volume Influence", "volumes", True,
                               "Which irradiance volume lights each pixel (grey: the world)"),
    # new views go last: files store a view by its number
    "AMBIENT_OCCLUSION": View("Ambient Occlusion", "AO", True,
                              "Contact occlusion of probe and world light (1: open)"),
    "LIGHTMAP": View("Lightmap", "Lightmap", False,
                     "The irradiance of the baked lightmaps (black: no lightmap)"),
    "LIGHTMAP_TEXELS": View("Lightmap Texels", "Lightmap Texels", True,
                            "Each lightmap's texels as a checker of its own hue: their density "
                            "(black: no lightmap)"),
}

# Distinct colours for probes 0, 1, ... (repeating), and the world's grey.
PALETTE = np.array([[0.90, 0.25, 0.20], [0.20, 0.65, 0.90], [0.30, 0.80, 0.30],
                    [0.95, 0.75, 0.15], [0.70, 0.35, 0.85], [0.15, 0.80, 0.75],
                    [0.95, 0.50, 0.65], [0.55, 0.45, 0.25]], np.float32)
WORLD_GREY = np.float32(0.2)


def view_pixels(passes: dict, view: str, scene: Scene) -> np.ndarray:
    """(H, W, 4) float32 RGBA of look-dev view ``view`` (a key of ``VIEWS``) from a render's
    passes (``pipeline.render_frame``, row 0 at the top); RGB of 0 where nothing is seen."""
    source = VIEWS[view].source
    depth = passes["Depth"][..., 0]
    h, w = depth.shape
    out = np.zeros((h, w, 4), np.float32)
    out[..., 3] = 1.0
    if source == "Combined":
        return np.ascontiguousarray(passes["Combined"], np.float32)
    if source in ("reflection", "volumes"):
        seen = depth < EMPTY_DEPTH
        out[seen, :3] = probe_influence(scene, passes["Position"][seen], source)
        return out
    value = passes[source]
    if source == "Normal":
        seen = depth < EMPTY_DEPTH
        out[seen, :3] = 0.5 * value[seen] + 0.5
    elif value.shape[-1] == 1:
        out[..., :3] = value
    else:
        out[..., :3] = value[..., :3]
    return out


def probe_influence(scene: Scene, points: np.ndarray, kind: str) -> np.ndarray:
    """(N, 3) colours of the probes that light world points (N, 3): each probe's ``PALETTE``
    colour by its weight, the world's grey where the probes leave weight (``kind``
    "reflection" or "volumes")."""
    probes = scene.probes
    items = [] if probes is None else getattr(probes, kind)
    color = np.zeros((len(points), 3), np.float32)
    total = np.zeros(len(points), np.float32)
    for k, probe in enumerate(items):
        wk = probe.weight(points)
        color += wk[:, None] * PALETTE[k % len(PALETTE)]
        total += wk
    over = total > 1.0
    color[over] /= total[over, None]
    color += (np.maximum(1.0 - total, 0.0) * WORLD_GREY)[:, None]
    return color


@dataclass(frozen=True)
class Image:
    """One published image of a session.

    pixels:  (H, W, 4) float32 RGBA, row 0 at the BOTTOM (as a GPU texture takes it)
    data:    show the values as they are (no display transform)
    samples: samples averaged (0 for the reduced-resolution preview)
    final:   no refinement follows
    update:  the number of the update it shows (``Session.update`` returns it)
    """

    pixels: np.ndarray
    data: bool
    samples: int
    final: bool
    update: int


class Session:
    """A progressive renderer on one worker thread.

    samples:  samples per pixel of the finished image (the scene's settings give the threads)
    on_image: called on the worker thread after each new image (e.g. to ask for a redraw)
    warnings: the sink of the renders' warnings (``job.Warnings``; a new one by default)

    With ``drawer`` set (a function of a prepared ``Frame`` giving None when another backend
    draws it, else why not), the worker prepares each update's frame and, where the drawer
    takes it, publishes it (``frame``) instead of rendering samples: the GPU draws it
    through any camera, so camera moves need no update at all.
    """

    def __init__(self, samples: int = 8, on_image: Callable[[], None] | None = None,
                 warnings: Warnings | None = None):
        self.samples = max(1, int(samples))
        self.on_image = on_image
        self.warnings = Warnings() if warnings is None else warnings
        self.view = "COMBINED"
        self.stats = {"prepares": 0, "material_tables": 0, "projections": 0, "renders": 0}
        self._cond = threading.Condition()
        self._publishing = threading.Lock()  # one image derived and stored at a time
        self._updates = 0
        self._pending: tuple | None = None  # (scene, changed) not taken by the worker yet
        self._busy = False
        self._closed = False
        self._image: Image | None = None
        self._passes: tuple | None = None  # (passes, scene, samples, final, update)
        self._error: str | None = None
        self._frame: Frame | None = None
        self._preview: Frame | None = None
        self.drawer: Callable[[Frame], str | None] | None = None
        self._drawn: tuple | None = None  # (frame, update number) published for the drawer
        self._refusal: str | None = None  # why the drawer did not take the last frame
        self._thread = threading.Thread(target=self._run, name="bo2-viewport", daemon=True)
        self._thread.start()

    # ---- the host's side (any thread) --------------------------------------------------

    def update(self, scene: Scene, changed, world_light: bool = False) -> int:
        """Render ``scene`` anew; ``changed`` names what differs from the last update (a subset
        of ``CHANGES``; anything on the first update). With ``world_light``, the scene is lit
        by its world alone: the world's probes (``world_probes.world_probes``, about a second for a
        new HDRI) are made on the render thread, not the caller's. Returns the update's
        number."""
        changed = frozenset(changed)
        unknown = changed - CHANGES
        if unknown:
            raise ValueError(f"unknown changes {sorted(unknown)}; expected some of "
                             f"{sorted(CHANGES)}")
        with self._cond:
            if self._pending is not None:  # not started yet: both changes apply
                changed |= self._pending[1]
            self._updates += 1
            self._pending = (scene, changed, world_light)
            self._error = None
            self._cond.notify_all()
            return self._updates

    def set_view(self, view: str) -> None:
        """Show look-dev view ``view`` (a key of ``VIEWS``): re-derived from the last passes."""
        if view not in VIEWS:
            raise ValueError(f"unknown view {view!r}; expected one of {sorted(VIEWS)}")
        if view == self.view:  # every redraw asks: no lock when nothing changes
            return
        with self._publishing:
            with self._cond:
                if view == self.view:
                    return
                self.view = view
                kept = self._passes
            if kept is not None:
                self._store(*kept)

    @property
    def updates(self) -> int:
        """The number of the last update."""
        with self._cond:
            return self._updates

    def image(self) -> Image | None:
        """The newest image, or None before the first one."""
        with self._cond:
            return self._image

    def frame(self) -> tuple | None:
        """(the newest prepared frame for the drawer, its update's number), or None when the
        newest update was rendered here (or none was prepared yet)."""
        with self._cond:
            return self._drawn

    @property
    def refusal(self) -> str | None:
        """Why the drawer did not take the newest frame (rendered here instead), or None."""
        with self._cond:
            return self._refusal

    @property
    def error(self) -> str | None:
        """The message of the last update's failure, or None."""
        with self._cond:
            return self._error

    @property
    def busy(self) -> bool:
        """True while an update is waiting or being rendered."""
        with self._cond:
            return self._busy or self._pending is not None

    def wait(self, timeout: float | None = None) -> bool:
        """Wait until every update is rendered in full (or failed); False on timeout."""
        with self._cond:
            return self._cond.wait_for(
                lambda: self._closed or not self._busy and self._pending is None, timeout)

    def wait_for(self, predicate: Callable[[Image], bool], timeout: float | None = None) -> bool:
        """Wait until the newest image satisfies ``predicate``; False on timeout."""
        with self._cond:
            return self._cond.wait_for(
                lambda: self._image is not None and predicate(self._image) or self._closed,
                timeout)

    def close(self) -> None:
        """Stop the worker (the render in progress stops within one tile) and wait for it."""
        with self._cond:
            self._closed = True
            self._cond.notify_all()
        if self._thread is not threading.current_thread():
            self._thread.join()

    # ---- the worker --------------------------------------------------------------------

    def _run(self) -> None:
        while True:
            with self._cond:
                self._cond.wait_for(lambda: self._closed or self._pending is not None)
                if self._closed:
                    return
                (scene, changed, world_light), self._pending = self._pending, None
                number, self._busy = self._updates, True
            try:
                kernels.load(None, kernels.FRAME_MODULES)  # (waits for ``kernels.prepare``'s)
                if world_light:
                    lit = world_probes.world_probes(scene.world)
                    scene = dataclasses.replace(scene, probes=lit)
                self._render(scene, changed, number)
            except Cancelled:
                with self._cond:  # what this update changed still waits to be applied
                    if self._pending is not None:
                        self._pending = (self._pending[0], self._pending[1] | changed,
                                         self._pending[2])
            except Exception as exc:  # noqa: BLE001 - shown in the viewport, the trace logged
                traceback.print_exc()
                self._frame = None  # the next update starts afresh
                with self._cond:
                    if self._updates == number:
                        self._error = f"{type(exc).__name__}: {exc}"
                if self.on_image is not None:
                    self.on_image()
            finally:
                with self._cond:
                    self._busy = False
                    self._cond.notify_all()

    def _stale(self, number: int) -> bool:
        return self._closed or self._updates != number

    def _prepared(self, scene: Scene, changed: frozenset, should_stop,
                  preview: Callable[[Frame], None], on_gpu: bool) -> Frame:
        """The frame of ``scene``, keeping what ``changed`` leaves valid. When the shadow maps
        must be built again, ``preview`` is first called with a frame that has the previous
        ones (the first image after a change comes before the slow part). ``on_gpu``: a
        drawer takes the frame, and draws its shadow maps' depths too."""
        old = self._frame
        rebuild = old is None or bool(changed & {"geometry", "lights"}) or (
            not on_gpu and drawn_on_gpu(old.shadow_maps))
        if not rebuild and changed & {"materials", "settings"}:
            new, was = scene.settings, old.scene.settings
            if (new.shadow_resolution, new.sky_directions, new.sky_resolution) != (
                    was.shadow_resolution, was.sky_directions, was.sky_resolution):
                rebuild = True
        frame = None
        if not rebuild and "materials" in changed:
            frame = with_materials(old, scene)
            if frame is None:
                rebuild = True
            else:
                self.stats["material_tables"] += 1
        if rebuild:
            self._frame = None
            maps = [None] * shadow_map_count(scene)
            if old is not None and len(old.shadow_maps) == len(maps) and (
                    on_gpu or not drawn_on_gpu(old.shadow_maps)):
                maps = old.shadow_maps
            job = self._job(scene, should_stop)
            quick = pipeline.prepare(job, shadow_maps=maps)
            quick.tiles = {}  # the raster set-ups of each tile, kept for the next renders
            preview(quick)  # with the previous shadow maps (none at first): the slow part next
            # the dome towards every direction: a world turned or lit anew keeps it
            frame = dataclasses.replace(quick, shadow_maps=build_shadow_maps(
                job, quick, fit_shadows=False, every_direction=True, on_gpu=on_gpu))
            self.stats["prepares"] += 1
        else:
            if frame is None:
                frame = dataclasses.replace(old, scene=dataclasses.replace(
                    scene, camera=old.scene.camera))
                if frame.blends is not None:  # (the Blended Order may be what changed)
                    frame = dataclasses.replace(frame, blend_rank=blend_order(
                        frame.scene, frame.obj, frame.world_to_object))
            if "camera" in changed:
                frame = with_camera(frame, scene.camera)
                self.stats["projections"] += 1
            preview(frame)
        self._frame = frame
        return frame

    def _job(self, scene: Scene, should_stop: Callable[[], bool]) -> RenderJob:
        """A render job of ``scene`` for the session's worker, into its warnings."""
        return RenderJob(scene, should_stop=should_stop, warnings=self.warnings)

    def _preview_of(self, frame: Frame) -> Frame:
        """``frame`` through its camera at ``1 / PREVIEW_DIVIDER`` of the resolution; the last
        preview's projection and raster set-ups are kept while the geometry, the camera and
        the culled faces are the same."""
        cam = frame.scene.camera
        small = dataclasses.replace(cam, width=cam.width // PREVIEW_DIVIDER,
                                    height=cam.height // PREVIEW_DIVIDER)
        old = self._preview
        if old is not None and old.positions is frame.positions and same_camera(
                old.scene.camera, small) and _same_cull(old.cull, frame.cull):
            preview = dataclasses.replace(frame, scene=dataclasses.replace(frame.scene,
                                                                           camera=small),
                                          clip=old.clip, tiles=old.tiles)
        else:
            preview = with_camera(frame, small)
        self._preview = preview
        return preview

    def _render(self, scene: Scene, changed: frozenset, number: int) -> None:
        def should_stop() -> bool:
            return self._stale(number)

        samples = self.samples
        offsets = sample_offsets(samples, scene.settings.filter_width)

        def preview(frame: Frame) -> None:
            cam = frame.scene.camera
            if min(cam.width, cam.height) < 2 * PREVIEW_DIVIDER:
                return
            small = self._preview_of(frame)
            passes = pipeline.render_frame(self._job(small.scene, should_stop), frame=small,
                                           offsets=offsets[:1])
            self.stats["renders"] += 1
            self._publish(passes, small.scene, 0, False, number)

        drawer = self.drawer
        frame = self._prepared(scene, changed, should_stop,
                               preview if drawer is None else lambda frame: None,
                               drawer is not None)
        if drawer is not None:
            refusal = drawer(frame)
            with self._cond:
                if self._stale(number):
                    return
                self._refusal = refusal
                self._drawn = None if refusal else (frame, number)
                self._cond.notify_all()
            if refusal is None:
                if self.on_image is not None:
                    self.on_image()
                return
            if drawn_on_gpu(frame.shadow_maps):  # rendered here: the depths built here
                frame = dataclasses.replace(frame, shadow_maps=build_shadow_maps(
                    self._job(scene, should_stop), frame, fit_shadows=False,
                    every_direction=True))
                self._frame = frame
        else:
            with self._cond:
                self._drawn, self._refusal = None, None
        total = None
        for k in range(samples):
            passes = pipeline.render_frame(self._job(scene, should_stop), frame=frame,
                                           offsets=offsets[k:k + 1], first_sample=k)
            self.stats["renders"] += 1
            if total is None:
                total = mean = passes
            else:  # new arrays: the published ones stay as they are
                total = {name: image if name in ("Depth", "IndexMA")  # the first sample's
                         else image + passes[name] for name, image in total.items()}
                mean = {name: image if name in ("Depth", "IndexMA") else image / (k + 1)
                        for name, image in total.items()}
            self._publish(mean, scene, k + 1, k + 1 == samples, number)

    def _publish(self, passes: dict, scene: Scene, samples: int, final: bool,
                 number: int) -> None:
        with self._publishing:
            self._store(passes, scene, samples, final, number)
        if self.on_image is not None:
            self.on_image()

    def _store(self, passes: dict, scene: Scene, samples: int, final: bool,
               number: int) -> None:
        """The image of the current view from ``passes``, stored unless stale; with the
        ``_publishing`` lock held, so a view switch and a new sample never interleave."""
        with self._cond:
            if self._stale(number):
                return
            view = self.view
        pixels = np.ascontiguousarray(view_pixels(passes, view, scene)[::-1], np.float32)
        image = Image(pixels, VIEWS[view].data, samples, final, number)
        with self._cond:
            if self._stale(number):
                return
            self._image = image
            self._passes = (passes, scene, samples, final, number)
            self._cond.notify_all()


def same_camera(a: Camera, b: Camera) -> bool:
    """True when cameras ``a`` and ``b`` see the same image (matrices bit for bit, size,
    aperture)."""
    return (a.width, a.height, a.orthographic, a.aperture) == (
        b.width, b.height, b.orthographic, b.aperture) and (
        np.array_equal(a.world_to_camera, b.world_to_camera)
        and np.array_equal(a.projection, b.projection))


def _same_cull(a, b) -> bool:
    return (a is None and b is None) or (a is not None and b is not None
                                         and np.array_equal(a, b))


def view_camera(view_matrix, window_matrix, width: int, height: int,
                perspective: bool = True) -> Camera:
    """The camera of a 3D viewport from its view (world -> view) and window (OpenGL-style
    projection) matrices, (4, 4) each, and its size in pixels."""
    return Camera(world_to_camera=np.array(view_matrix, np.float64),
                  projection=np.array(window_matrix, np.float64),
                  width=max(1, int(width)), height=max(1, int(height)),
                  orthographic=not perspective)


__all__ = ["CHANGES", "PREVIEW_DIVIDER", "TILE_SIZE", "VIEWS", "Image", "Session", "View",
           "probe_influence", "same_camera", "view_camera", "view_pixels"]
