"""Any world node tree as the engine's world: rendered once by Cycles into an equirect.

The engine reads a world of one colour, or one equirectangular Environment Texture (with a
Mapping node's rotation), directly (``extract.extract_world``). Any other tree (a Sky Texture,
a gradient, two HDRIs mixed, a strength driven by nodes) is rendered by Cycles into a
``WIDTH`` x ``WIDTH / 2`` equirectangular image (a panoramic camera in a scene of its own that
holds nothing but the world), once per content of the tree (``digest``: its nodes, their
settings and inputs, links, images and node groups), and that image is the world: the
captures, the frames and the viewport read it as they read an Environment Texture.

Blender renders one thing at a time, so the image is made at safe points (``ensure``): before
a bake, before each frame of the ``bo2`` command and of a comparison, from a timer after the
world changes in the viewport, and by the World panel's button. It is kept in memory and
written beside the bakes (``<bake folder>/world_<digest>.exr``, replaced atomically), where a
render started some other way (a farm's ``blender -b -f``) finds it.

A Sky Texture's sun disc (World > Sun Threshold above 0, EEVEE's setting) is not left in the
image, where its energy would be smeared over the sphere: the image is rendered without it, and
the disc alone (a small view of it rendered with and without it) gives the world's sun its exact
irradiance (``Rendered.sun``, ``core.lighting.world_sun``).

A tree Cycles cannot evaluate here (a Script node, an image that is missing) is not rendered:
the world's viewport colour stands in, with one warning.
"""

from __future__ import annotations

import contextlib
import hashlib
import json
import math
import tempfile
from pathlib import Path
from typing import NamedTuple

import bpy
import numpy as np
from mathutils import Vector

from ..core.files import exr
from ..core.formulas import texture
from ..core.scene import Light
from ..core.system.cache import Cache
from . import images, probes

__all__ = ["WIDTH", "Rendered", "WorldError", "digest", "direct", "ensure", "lookup",
           "problem"]

WIDTH = 1024  # of the equirect; its height is half
SAMPLES = 16
DISC_SKIES = {"NISHITA", "SINGLE_SCATTERING", "MULTIPLE_SCATTERING"}  # Sky Textures with a sun
PATCH = 64  # pixels across the view of a sun disc
PATCH_WIDTH = 4.0  # the view's angle, in the disc's diameters


class Rendered(NamedTuple):
    """A world tree rendered: its equirect, and the sun disc taken out of it (a "SUN" light)."""

    texture: texture.Texture
    sun: Light | None


_memory = Cache("rendered worlds", kept=4)  # digest -> Rendered


class WorldError(Exception):
    """The world's tree cannot be rendered; one-line message."""


def _output(tree):
    return next((n for n in tree.nodes if n.type == "OUTPUT_WORLD" and n.is_active_output),
                None)


def direct(world) -> bool:
    """Whether the engine reads ``world`` itself: no tree, or a Background node whose colour
    is its own or one equirectangular Environment Texture's, looked up along the view direction
    (a Texture Coordinate node, then a Mapping node's rotation, at most) and whose strength is
    its own."""
    tree = world.node_tree
    if tree is None or (bpy.app.version < (5, 0, 0) and not world.use_nodes):
        return True
    out = _output(tree)
    links = out.inputs["Surface"].links if out is not None else ()
    if not links:
        return True
    node = links[0].from_node
    if node.type != "BACKGROUND" or node.inputs["Strength"].is_linked:
        return False
    color = node.inputs["Color"].links
    if not color:
        return True
    src = color[0].from_node
    if src.type != "TEX_ENVIRONMENT" or src.projection != "EQUIRECTANGULAR":
        return False
    vec = src.inputs["Vector"].links
    if not vec:
        return True
    mapping = vec[0].from_node
    if _direction(vec[0]):
        return True
    if mapping.type != "MAPPING" or mapping.vector_type not in {"POINT", "VECTOR"}:
        return False
    inputs = mapping.inputs
    if any(s.is_linked for s in inputs if s.identifier != "Vector"):
        return False
    if mapping.vector_type == "POINT" and any(inputs["Location"].default_value):
        return False  # a moved look-up point is not a rotation
    scale = list(inputs["Scale"].default_value)
    if min(scale) <= 0.0 or max(scale) != min(scale):
        return False  # a non-uniform scale bends directions
    links = inputs["Vector"].links
    return not links or _direction(links[0])


def _direction(link) -> bool:
    """Whether ``link`` carries the view direction: a Texture Coordinate node's Generated or
    Object output (the world's own default)."""
    return link.from_node.type == "TEX_COORD" and link.from_socket.identifier in {
        "Generated", "Object"}


def _nodes_of(tree, seen=None):
    """Every node of ``tree`` and of the node groups it uses, once each."""
    seen = set() if seen is None else seen
    if tree.name_full in seen:
        return
    seen.add(tree.name_full)
    for node in tree.nodes:
        yield node
        if getattr(node, "node_tree", None) is not None:
            yield from _nodes_of(node.node_tree, seen)


def problem(world) -> str | None:
    """Why Cycles cannot render ``world``'s tree here, or None."""
    for node in _nodes_of(world.node_tree):
        if node.type == "SCRIPT":
            return f"node '{node.name}' is a Script node (OSL)"
        image = getattr(node, "image", None)
        if node.type in {"TEX_ENVIRONMENT", "TEX_IMAGE"} and not node.mute:
            if image is None:
                return f"node '{node.name}' has no image"
            if image.source == "FILE" and image.packed_file is None:
                path = Path(bpy.path.abspath(image.filepath, library=image.library))
                if not path.is_file():
                    return f"image '{image.name}' of node '{node.name}' is missing ({path})"
    return None


def _value(value, depth: int = 0):
    """A comparable form of a node's setting: values as they are, images by file, other
    data-blocks by name, a ramp's or a curve's points by their own settings."""
    if value is None or isinstance(value, (bool, int, float, str)):
        return value
    if isinstance(value, bpy.types.Image):
        path = Path(bpy.path.abspath(value.filepath, library=value.library))
        stamp = (path.stat().st_mtime_ns, path.stat().st_size) if path.is_file() else None
        return ["image", value.name_full, value.source, str(path), stamp,
                value.packed_file.size if value.packed_file else None,
                value.colorspace_settings.name, bool(value.is_dirty)]
    if isinstance(value, bpy.types.ID):
        return ["id", value.name_full]
    if depth > 4:
        return None
    if isinstance(value, bpy.types.bpy_struct):  # a colour ramp, a curve mapping, ...
        return [(p.identifier, _value(getattr(value, p.identifier, None), depth + 1))
                for p in value.bl_rna.properties if p.identifier not in {"rna_type", "select"}]
    with contextlib.suppress(TypeError):  # vectors, colours, collections
        return [_value(v, depth + 1) for v in value]
    return repr(value)


def digest(world) -> str:
    """A digest of what ``world``'s light depends on: every node of its tree and of the groups
    it uses (type, settings, unlinked inputs' values), the links, the images (file, date,
    size, colour space)."""
    parts = []
    for node in _nodes_of(world.node_tree):
        props = []
        for prop in node.bl_rna.properties:
            if prop.is_readonly and prop.type != "POINTER" or prop.identifier in {
                    "name", "label", "location", "width", "height", "select", "color",
                    "use_custom_color", "show_options", "show_preview", "show_texture",
                    "hide", "width_hidden", "location_absolute", "warning_propagation",
                    "parent"}:  # how the editor shows the node, not what it computes
                continue
            with contextlib.suppress(AttributeError, TypeError):
                props.append((prop.identifier, _value(getattr(node, prop.identifier))))
        inputs = [(s.identifier, None if s.is_linked or not hasattr(s, "default_value")
                   else _value(s.default_value)) for s in node.inputs]
        parts.append((node.id_data.name_full, node.name, node.bl_idname, props, inputs,
                      bool(node.mute)))
    parts.append(("sun disc taken out", world.sun_threshold > 0.0))
    trees = {n.id_data for n in _nodes_of(world.node_tree)}
    for tree in sorted(trees, key=lambda t: t.name_full):
        for link in tree.links:
            parts.append((tree.name_full, link.from_node.name, link.from_socket.identifier,
                          link.to_node.name, link.to_socket.identifier, bool(link.is_muted)))
    text = repr(parts).encode()
    return hashlib.blake2b(text, digest_size=12).hexdigest()


def _path(scene, key: str) -> Path | None:
    """Where the rendered world of digest ``key`` is kept: in the bake folder; None when the
    scene has none yet (an unsaved file with a relative folder: memory only)."""
    try:
        return probes.bake_folder(scene) / f"world_{key}.exr"
    except probes.BakeError:
        return None


def _keep(key: str, rendered: Rendered) -> Rendered:
    _memory.put(key, rendered)
    return rendered


def _sun_light(sun: dict | None) -> Light | None:
    """The world's sun from its record ({"direction": towards it, "irradiance", "angle"})."""
    if not sun:
        return None
    towards = np.asarray(sun["direction"], np.float64)
    return Light("SUN", np.asarray(sun["irradiance"], np.float32), direction=-towards,
                 radius=float(sun["angle"]), name="World sun")


def _texture(pixels: np.ndarray, name: str) -> texture.Texture:
    return texture.make_texture(pixels, srgb=False, extension="REPEAT",
                                interpolation="Linear", name=name)


def lookup(scene, world) -> Rendered | None:
    """The rendered equirect of ``world``'s tree as it is now and its sun, from memory or from
    the bake folder; None when it was not rendered (``ensure``)."""
    key = digest(world)
    if key in _memory:
        return _memory.get(key)
    path = _path(scene, key)
    if path is None or not path.is_file():
        return None
    try:
        part = exr.read(path)[0]
        pixels = part.channels["RGB"]
        sun = json.loads(part.header.get("bo2.sun", "null"))
    except (exr.ExrError, KeyError, ValueError):  # a damaged file: rendered again by ``ensure``
        return None
    if pixels.ndim != 3 or pixels.shape[2] != 3:
        return None
    return _keep(key, Rendered(_texture(pixels, f"{world.name} (rendered)"), _sun_light(sun)))


def _write(path: Path, pixels: np.ndarray, key: str, sun: dict | None) -> None:
    exr.write(path, [exr.Part("", {"RGB": pixels}, {"bo2.world": key,
                                                   "bo2.sun": json.dumps(sun)})])


@contextlib.contextmanager
def _stage(world):
    """A scene of its own holding nothing but ``world`` and a camera, rendered by Cycles on
    the CPU with the Standard view; yields (scene, camera object), removed afterwards."""
    scene = bpy.data.scenes.new("BO2 World")
    cam_data = bpy.data.cameras.new("BO2 World")
    cam = bpy.data.objects.new("BO2 World", cam_data)
    try:
        scene.world = world
        scene.collection.objects.link(cam)
        scene.camera = cam
        r = scene.render
        r.engine = "CYCLES"
        r.resolution_percentage = 100
        r.filter_size = 1.0
        scene.cycles.samples = SAMPLES
        scene.cycles.device = "CPU"
        scene.view_settings.view_transform = "Standard"
        yield scene, cam
    finally:
        bpy.data.objects.remove(cam)
        bpy.data.cameras.remove(cam_data)
        bpy.data.scenes.remove(scene)


def _shoot(scene, width: int, height: int) -> np.ndarray:
    """(height, width, 3) float32 radiance of ``scene``'s render, non-finite values 0."""
    scene.render.resolution_x, scene.render.resolution_y = width, height
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "world.exr"
        bpy.ops.render.render(scene=scene.name)
        images.save_render_result(scene, path, "OPEN_EXR", "32")
        pixels = images.read_file(path)[..., :3]
    return np.nan_to_num(pixels, nan=0.0, posinf=0.0, neginf=0.0).astype(np.float32)


def _discs(world) -> list:
    """The Sky Texture nodes of ``world``'s own tree that draw a sun disc where their
    parameters say (their Vector input left to the view direction)."""
    return [n for n in world.node_tree.nodes
            if n.type == "TEX_SKY" and not n.mute and n.sky_type in DISC_SKIES
            and n.sun_disc and not any(s.is_linked for s in n.inputs)]


def _disc_sun(scene, cam, node) -> dict | None:
    """The sun of Sky Texture ``node`` (its disc on in the staged world): its direction from
    the node's elevation and rotation, its irradiance the sum over a view of the disc of
    (radiance with the disc - without) times each pixel's solid angle. None when no light of
    it reaches the sky (below the horizon)."""
    elevation, rotation = node.sun_elevation, node.sun_rotation
    towards = np.array([math.sin(rotation) * math.cos(elevation),
                        math.cos(rotation) * math.cos(elevation), math.sin(elevation)])
    angle = max(float(node.sun_size), 1e-3)
    cam.data.type = "PERSP"
    cam.data.sensor_fit = "AUTO"
    cam.data.angle = PATCH_WIDTH * angle
    cam.rotation_mode = "QUATERNION"
    cam.rotation_quaternion = Vector(towards.tolist()).to_track_quat("-Z", "Y")
    with_disc = _shoot(scene, PATCH, PATCH)
    node.sun_disc = False
    without = _shoot(scene, PATCH, PATCH)
    half = math.tan(cam.data.angle / 2.0)
    x = ((np.arange(PATCH) + 0.5) / PATCH * 2.0 - 1.0) * half
    r2 = x[None, :] ** 2 + x[:, None] ** 2
    d_omega = (2.0 * half / PATCH) ** 2 / (1.0 + r2) ** 1.5
    irradiance = ((with_disc - without) * d_omega[..., None]).sum(axis=(0, 1))
    if not (irradiance > 0.0).any():
        return None
    return {"direction": towards.tolist(), "irradiance": np.maximum(irradiance, 0.0).tolist(),
            "angle": float(node.sun_size)}


def render(world, width: int = WIDTH) -> tuple[np.ndarray, dict | None]:
    """``world``'s tree rendered by Cycles in a scene of its own: (width / 2, width, 3) float32
    radiance, Environment Texture mapping (row 0 at the top, ``sh.equirect_directions``), and
    its sun ({"direction": (3,) towards it, "irradiance": (3,) W/m^2, "angle": radians}) or
    None. With World > Sun Threshold above 0, the first Sky Texture that draws a
    sun disc is rendered without it and its disc is the sun. Not during a render (Blender
    renders one thing at a time)."""
    reason = problem(world)
    if reason is not None:
        raise WorldError(reason)
    copy = world.copy() if world.sun_threshold > 0.0 and _discs(world) else None
    sun = None
    try:
        with _stage(world if copy is None else copy) as (scene, cam):
            if copy is not None:
                node = _discs(copy)[0]
                sun = _disc_sun(scene, cam, node)
            cam.data.type = "PANO"
            if hasattr(cam.data, "panorama_type"):
                cam.data.panorama_type = "EQUIRECTANGULAR"
            else:  # Blender 4.5 keeps it in Cycles' settings
                cam.data.cycles.panorama_type = "EQUIRECTANGULAR"
            # Cycles' equirect camera looks along its local -Z: this rotation lines its image
            # up with an Environment Texture's (azimuth from +X towards +Y, left to right
            # reversed)
            cam.rotation_mode = "XYZ"
            cam.rotation_euler = (math.pi / 2, 0.0, -math.pi / 2)
            pixels = _shoot(scene, width, width // 2)
    finally:
        if copy is not None:
            bpy.data.worlds.remove(copy)
    return np.ascontiguousarray(np.maximum(pixels, 0.0), np.float32), sun


def ensure(scene) -> bool:
    """Render ``scene``'s world when the engine cannot read it itself and its tree as it is
    now was not rendered yet; returns whether an image is ready (or not needed). A tree that
    cannot be rendered is left to ``extract.extract_world``, which says why."""
    world = scene.world
    if world is None or direct(world):
        return True
    if lookup(scene, world) is not None:
        return True
    try:
        pixels, sun = render(world)
    except (WorldError, images.ImageError, RuntimeError):
        return False
    key = digest(world)
    _keep(key, Rendered(_texture(pixels, f"{world.name} (rendered)"), _sun_light(sun)))
    path = _path(scene, key)
    if path is not None:
        with contextlib.suppress(OSError):  # the memory copy serves this session
            _write(path, pixels, key, sun)
    return True


_pending: dict[str, object] = {}  # scene name -> its timer function


def schedule(scene, delay: float = 0.5) -> None:
    """Render ``scene``'s world ``delay`` seconds after its last change (the viewport: a slider
    dragged renders once it rests), then tag the world so that the viewport reads it."""
    name = scene.name_full
    old = _pending.pop(name, None)
    if old is not None and bpy.app.timers.is_registered(old):
        bpy.app.timers.unregister(old)

    def run():
        _pending.pop(name, None)
        target = bpy.data.scenes.get(name)
        if target is not None and target.world is not None and ensure(target):
            target.world.update_tag()
        return None

    _pending[name] = run
    bpy.app.timers.register(run, first_interval=delay)
