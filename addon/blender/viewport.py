"""The 3D viewport's Rendered shading: depsgraph updates -> ``core.render.viewport.Session``.

``changes()`` turns the depsgraph's updates into what changed for the core and forgets exactly
that in the extraction cache (a moved object keeps its mesh, an edited mesh is read again, a
material tweak compiles that material); ``Viewport`` keeps one viewport's cache, camera and
session; ``Drawing`` is the only code that needs a GPU, and the only code not run headless.
"""

from __future__ import annotations

import dataclasses
import sys
import traceback

import bpy
import numpy as np

from ..core import kernels
from ..core.bakes import bounce
from ..core.render import viewport
from ..core.render.job import Warnings
from ..core.scene import Camera
from ..gpu_backend import device as gpu_device
from ..gpu_backend import frame as gpu_frame
from ..gpu_backend import viewport as gpu_viewport
from . import extract, probes, studio, worlds
from . import settings as settings_of


def changes(updates, cache: extract.SceneCache) -> set[str]:
    """What the depsgraph ``updates`` (``Depsgraph.updates``, or records with the same ``id``
    and ``is_updated_*`` fields) changed, as ``core.render.viewport.CHANGES``; the extraction
    ``cache`` forgets what they made stale."""
    changed: set[str] = set()
    for update in updates:
        idb = update.id
        if isinstance(idb, bpy.types.Material):
            cache.forget_material(idb)
            changed.add("materials")
        elif isinstance(idb, bpy.types.NodeTree):
            if not idb.is_embedded_data:  # a node group: any material may use it
                cache.forget_materials()
                changed.add("materials")
        elif isinstance(idb, (bpy.types.Image, bpy.types.Texture)):
            cache.forget_materials()
            changed |= {"materials", "world"}
        elif isinstance(idb, bpy.types.Object):
            # shading alone: the scene was tagged, or a material changed (updated on its own)
            if not (update.is_updated_geometry or update.is_updated_transform):
                continue
            kind = idb.type
            if kind == "LIGHT":
                changed.add("lights")
            elif kind == "LIGHT_PROBE":
                changed.add("probes")
            elif kind != "CAMERA":  # meshes and the like, empties that instance them
                if update.is_updated_geometry:  # its mesh, modifiers or material slots
                    cache.forget_object(idb.name_full)
                changed.add("geometry")
        elif isinstance(idb, bpy.types.Light):
            changed.add("lights")
        elif isinstance(idb, bpy.types.LightProbe):
            changed.add("probes")
        elif isinstance(idb, bpy.types.World):
            changed |= {"world", "probes"}
        elif isinstance(idb, bpy.types.Collection):
            changed.add("geometry")  # visibility or contents: the instances are listed again
        elif isinstance(idb, bpy.types.Scene):
            changed.add("settings")
    return changed


def _key(value) -> tuple:
    """A comparable form of a core light or world (arrays by their bytes, textures by
    identity: the image cache hands out one texture per image and settings)."""
    if value is None:
        return ()
    out = []
    for f in dataclasses.fields(value):
        v = getattr(value, f.name)
        if isinstance(v, np.ndarray):
            out.append(v.tobytes())
        elif isinstance(v, (int, float, str, bool, tuple, type(None))):
            out.append(v)
        else:
            out.append(id(v))
    return tuple(out)


def _probes_key(probes) -> tuple:
    if probes is None:
        return ()
    return (probes.world_sh.tobytes(),
            tuple((p.name, p.position.tobytes(), p.sh.tobytes()) for p in probes.reflection),
            tuple((v.name, np.asarray(v.local_to_world).tobytes(), v.sh.tobytes())
                  for v in probes.volumes))


def _differences(old, new) -> set[str]:
    """What differs between two extractions that depsgraph updates may not name: instances
    shown or hidden (the cache hands back the very batches that did not change), lightmaps
    baked or dropped, the world, the lights, the probes (a bake written since)."""
    if old is None:
        return set(viewport.CHANGES)
    changed = set()
    # the very arrays of the batches the cache handed back, and their lightmaps (a batch with
    # a lightmap is a copy of the cached one: ``lightmaps.attach``)
    if [(id(m.positions), id(m.lightmap)) for m in old.meshes] != \
            [(id(m.positions), id(m.lightmap)) for m in new.meshes]:
        changed.add("geometry")
    if [_key(light) for light in old.lights] != [_key(light) for light in new.lights]:
        changed.add("lights")
    if _key(old.world) != _key(new.world):
        changed |= {"world", "probes"}
    if _probes_key(old.probes) != _probes_key(new.probes):
        changed.add("probes")
    return changed


@dataclasses.dataclass
class Update:
    """A depsgraph update copied out of its callback (``Depsgraph.updates`` is valid only
    during one): the evaluated ID and its flags."""

    id: object
    is_updated_geometry: bool = False
    is_updated_transform: bool = False
    is_updated_shading: bool = False

    @classmethod
    def copy(cls, update) -> Update:
        return cls(update.id.original, update.is_updated_geometry,
                   update.is_updated_transform, update.is_updated_shading)


STATE_COLORS = {"BAKED": (0.55, 0.85, 0.55, 1.0), "STALE": (0.95, 0.75, 0.3, 1.0),
                "MISSING": (0.95, 0.45, 0.4, 1.0), "DAMAGED": (0.95, 0.3, 0.3, 1.0)}


def probe_labels(scene) -> list[tuple]:
    """(object, text, RGBA) of every Sphere and Volume light probe: its bake state, as the
    viewport shows it beside the object."""
    labels = []
    for obj in probes.probe_objects(scene):
        state = probes.bake_state(obj).state
        labels.append((obj, f"BO2 bake: {state.lower()}", STATE_COLORS[state]))
    return labels


def probe_hint(scene) -> str:
    """One line for the status text when light probes need a (re-)bake, else ""."""
    objs = probes.probe_objects(scene)
    if not objs or not scene.bo2.indirect.use:
        return ""
    counts: dict[str, int] = {}
    for obj in objs:
        state = probes.bake_state(obj).state
        counts[state] = counts.get(state, 0) + 1
    parts = [f"{counts[s]} {s.lower()}" for s in ("STALE", "MISSING", "DAMAGED") if s in counts]
    if not parts:
        return ""
    return (f"Light probes: {', '.join(parts)}: re-bake (Render Properties > BO2 Lighting > "
            "Light Probes > Bake All)")


_live: set = set()  # every open Viewport, closed by ``close_all`` (unregister)


def close_all() -> None:
    """Stop every viewport's render thread."""
    for view in list(_live):
        view.close()


class Viewport:
    """One viewport's rendering: the extraction cache, the view's camera and the session.

    on_image: called on the render thread after each new image (ask for a redraw)
    """

    def __init__(self, on_image=None):
        _live.add(self)
        self.cache = extract.SceneCache()
        self.warnings = Warnings()  # the extractions' and the renders'
        self.session = viewport.Session(on_image=on_image, warnings=self.warnings)
        self.scene = None  # the last extraction, with a placeholder camera
        self.camera = None
        self.error: str | None = None  # an extraction's failure, until the next update
        self.hint = ""
        self._state = None  # the settings of the last render
        self._unsent: set[str] = set()  # changes of a failed extraction
        self.shading = studio.SCENE  # the viewport's Scene World and Scene Lights toggles
        self._shading_key: tuple = ()  # ``studio.key`` of the toggles last seen
        self._world_light = False  # the studio light's world alone lights the scene
        self._sent_camera = None  # the camera of the last update sent to the session
        self.device = "AUTO"  # the scene's Device setting
        self.gpu = None  # ``gpu_viewport.ViewportDrawing``, made on the first GPU draw
        self.gpu_failure: str | None = None  # why the GPU could not draw (until a change)
        self.auto_refusal: str | None = None  # why Auto leaves the viewport to the CPU

    def sync(self, depsgraph, updates=None) -> set[str]:
        """Read what ``updates`` changed (None: everything) and render anew; returns the
        changes sent to the session (empty when nothing that renders changed)."""
        if updates is None or self.scene is None:
            changed = set(viewport.CHANGES)
            if updates is None:
                self.cache = extract.SceneCache()
        else:
            changed = changes(updates, self.cache) | self._unsent
        blender_scene = depsgraph.scene
        settings = blender_scene.bo2
        indirect = settings.indirect.use
        if not changed:
            return set()
        render = settings_of.render_settings(blender_scene, "VIEWPORT")
        studio_world = self.shading.world
        try:
            scene, warnings = extract.extract_scene(
                depsgraph, render, camera=False,
                indirect=indirect and studio_world is None, cache=self.cache)
        except extract.SceneError as exc:
            self.error, self._unsent = str(exc), changed  # sent with the next update
            return set()
        # the bounce without probes once a render has baked it for this content
        scene = bounce.attach(scene, bake_missing=False)
        # the studio light replaces the world and the probes (made on the render thread)
        self._world_light = studio_world is not None and indirect
        if studio_world is not None:
            scene = dataclasses.replace(scene, world=studio_world, probes=None)
            warnings = [w for w in warnings if not w.startswith("World ")]
        if not self.shading.lights:
            scene = dataclasses.replace(scene, lights=[])
            warnings = [w for w in warnings if not w.startswith("The scene has no lights")]
        self.error, self._unsent = None, set()
        self.warnings.extend(warnings)
        changed |= _differences(self.scene, scene)
        state = (render, int(settings.viewport.samples), indirect, str(settings.device))
        if changed == {"settings"} and state == self._state:
            self.scene = scene
            return set()  # e.g. the look-dev view alone: shown from the last passes
        self._state = state
        self.session.samples = int(settings.viewport.samples)
        self.device = str(settings.device)
        self.gpu_failure = None  # a change: the GPU may take it
        # the GPU draws in view_draw, which a window has (background mode: the CPU's images);
        # Auto leaves a software rasterizer to the CPU kernels, which are faster
        self.auto_refusal = None
        if self.device == "AUTO" and not bpy.app.background:
            self.auto_refusal = gpu_device.auto_refusal(_renderer())
        gpu_draws = self.device != "CPU" and not bpy.app.background and not self.auto_refusal
        self.session.drawer = self._gpu_refusal if gpu_draws else None
        if changed & {"probes", "settings", "world"} or self.scene is None:
            self.hint = probe_hint(blender_scene)
        world = blender_scene.world
        if "world" in changed and world is not None and not worlds.direct(world) \
                and worlds.lookup(blender_scene, world) is None:
            worlds.schedule(blender_scene)  # rendered by Cycles once the edits rest
        self.scene = scene
        self._submit(changed)
        return changed

    def set_shading(self, depsgraph, space) -> bool:
        """Follow the Scene World and Scene Lights toggles of the viewport ``space``
        (``studio.shading``), rendering anew when they changed; True when they did. A studio
        light that cannot be read shows its error until the toggles change again."""
        wanted = studio.key(space)
        if wanted == self._shading_key:
            return False
        self._shading_key = wanted
        try:
            self.shading = studio.shading(space)
        except extract.SceneError as exc:
            self.error = str(exc)
            return False
        self._unsent |= {"world", "probes", "lights"}
        self.sync(depsgraph, ())
        return True

    def set_camera(self, camera) -> bool:
        """Render through ``camera`` (``core.render.viewport.view_camera``) when it differs from the
        last one; True when it did. The GPU draws the frame it has through any camera: the
        session is told only when it renders."""
        if self.camera is not None and viewport.same_camera(self.camera, camera):
            return False
        self.camera = camera
        if self.session.frame() is None or self.gpu_failure:
            self._submit({"camera"})
        return True

    def _submit(self, changed) -> None:
        if self.scene is not None and self.camera is not None:
            changed = set(changed)
            if self._sent_camera is not None and not viewport.same_camera(self._sent_camera,
                                                                          self.camera):
                changed.add("camera")  # moved while the GPU drew
            self._sent_camera = self.camera
            self.session.update(dataclasses.replace(self.scene, camera=self.camera), changed,
                                world_light=self._world_light)

    def set_view(self, view: str) -> None:
        """Show look-dev view ``view``; a view the GPU does not draw (or one it draws, after
        one it did not) renders the frame again on the right side."""
        if view == self.session.view:
            return
        was = self.session.view in gpu_viewport.VIEWS
        self.session.set_view(view)
        if self.device != "CPU" and was != (view in gpu_viewport.VIEWS):
            self._submit({"settings"})  # the frame kept: only who draws it changes

    def _gpu_refusal(self, frame) -> str | None:
        """On the session's worker: why the GPU cannot draw ``frame`` in this viewport's view,
        or None."""
        if self.gpu_failure:
            return self.gpu_failure
        if self.session.view not in gpu_viewport.VIEWS:
            return f"the {viewport.VIEWS[self.session.view].label} view"
        return gpu_frame.unsupported(frame)

    def draw_gpu(self, camera):
        """Draw the session's frame on the GPU (one more sample): the view's texture, or None
        when the session renders on the CPU. A failure (a shader that does not compile, GPU
        memory) is kept as ``gpu_failure`` and the frame is rendered on the CPU instead."""
        drawn = self.session.frame()
        if drawn is None or self.gpu_failure:
            return None
        if self.gpu is None:
            self.gpu = gpu_viewport.ViewportDrawing()
        try:
            return self.gpu.draw(drawn[0], camera, self.session.view, self.session.samples)
        except Exception as exc:  # noqa: BLE001 - the frame goes to the CPU, the cause shown
            traceback.print_exc(file=sys.stderr)
            self.gpu_failure = _failure(exc)
            self.gpu = None
            self._submit({"settings"})  # the frame kept, rendered on the CPU
            return None

    @property
    def gpu_busy(self) -> bool:
        """The GPU draws and has samples to add."""
        drawn = self.session.frame()
        return (drawn is not None and not self.gpu_failure and self.gpu is not None
                and self.gpu.samples(drawn[0]) < self.session.samples)

    def status(self) -> str:
        """The viewport's status text: the error, or the samples done, the probe hint and
        the newest of the warnings (each warning once since the viewport opened)."""
        error = self.error or self.session.error
        if error:
            return f"Error: {error}"
        image = self.session.image()
        drawn = self.session.frame()
        on_gpu = drawn is not None and not self.gpu_failure
        if on_gpu:
            done = 0 if self.gpu is None else self.gpu.samples(drawn[0])
            parts = [f"GPU: sample {done}/{self.session.samples}"]
        elif image is None:
            parts = [kernels.status() or "Preparing"]
        elif image.samples == 0:
            parts = ["Preview"]
        else:
            parts = [f"Sample {image.samples}/{self.session.samples}"]
        if not on_gpu and self.device != "CPU":
            if self.auto_refusal:
                parts.insert(0, f"CPU ({self.auto_refusal})")
            elif self.gpu_failure:
                parts.insert(0, f"CPU ({self.gpu_failure})")
            elif self.session.refusal:
                parts.insert(0, f"CPU (the GPU does not draw {self.session.refusal} yet)")
        if self.hint:
            parts.append(self.hint)
        if self.warnings:
            count = len(self.warnings)
            parts.append(f"{count} warning{'s' * (count > 1)}: {self.warnings.texts()[-1]}")
        return "  |  ".join(parts)

    def close(self) -> None:
        """Stop the render thread; the last viewport closed lets go of the GPU memory kept
        for the next frame."""
        self.session.close()
        _live.discard(self)
        self.gpu = None
        if not _live:
            gpu_frame.release()


def _renderer() -> str:
    """The GPU's name (the window's context)."""
    import gpu

    try:
        return gpu.platform.renderer_get()
    except Exception:  # noqa: BLE001 - no name: taken for a hardware GPU
        return ""


def _failure(exc: Exception) -> str:
    """One line on why the GPU failed to draw."""
    if isinstance(exc, MemoryError) or "memory" in str(exc).lower():
        return f"the GPU ran out of memory: {exc}"
    return str(exc) if str(exc) else type(exc).__name__


def pixel_size(scene, preferences) -> int:
    """Viewport pixels per rendered pixel: the scene's Pixel Size (``preview_pixel_size``, as
    Cycles reads it); Automatic follows the interface's pixel size (HiDPI displays)."""
    size = scene.render.preview_pixel_size
    if size == "AUTO":
        return max(1, round(float(preferences.system.pixel_size)))
    return int(size)


def region_camera(region, region_data, scale: int = 1) -> Camera:
    """The camera of a 3D viewport region (its view and window matrices), one rendered pixel
    per ``scale`` x ``scale`` viewport pixels (``pixel_size``)."""
    return viewport.view_camera(region_data.view_matrix, region_data.window_matrix,
                                max(1, -(-region.width // scale)),
                                max(1, -(-region.height // scale)),
                                perspective=region_data.is_perspective)


class Drawing:
    """The GPU side: one texture upload per new image (or the GPU's own image), drawn over the
    region through Blender's display transform (data views drawn as they are)."""

    def __init__(self):
        self._image = None
        self._texture = None

    def draw(self, engine, scene, image: viewport.Image, width: int, height: int) -> None:
        import gpu

        if image is not self._image:
            h, w = image.pixels.shape[:2]
            buffer = gpu.types.Buffer("FLOAT", w * h * 4, image.pixels.ravel())
            self._texture = gpu.types.GPUTexture((w, h), format="RGBA16F", data=buffer)
            self._image = image
        self.draw_texture(engine, scene, self._texture, image.data, width, height)

    @staticmethod
    def draw_texture(engine, scene, texture, data: bool, width: int, height: int) -> None:
        """Draw ``texture`` (scene-linear RGBA, or ``data`` shown as it is) over the region."""
        import gpu
        from gpu_extras.presets import draw_texture_2d

        gpu.state.blend_set("ALPHA_PREMULT")
        if not data:
            engine.bind_display_space_shader(scene)
        draw_texture_2d(texture, (0, 0), width, height)
        if not data:
            engine.unbind_display_space_shader()
        gpu.state.blend_set("NONE")
