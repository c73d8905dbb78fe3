"""The viewport's Scene World and Scene Lights toggles in Rendered shading.

With Scene World off, the scene is lit by the viewport's studio HDRI instead of its world and
probes, as Cycles does: the HDRI's rotation and strength light it, its blur and opacity show in
the background. The HDRI's texture is read once per file version (``_textures``); its SH and
prefiltered chain are computed once per HDRI and rotation (``core.lighting.world_probes``).
"""

from __future__ import annotations

import math
import os
from dataclasses import dataclass, field

import numpy as np

from ..core import scene as cs
from ..core.files import exr
from ..core.formulas import texture
from ..core.system.cache import Cache, stamp
from . import extract, images
from .lights import euler_xyz

_textures = Cache("studio lights", kept=4)  # (path, file stamp) -> Texture


@dataclass(frozen=True)
class Shading:
    """What a viewport's shading toggles ask of the scene.

    world:  the studio HDRI's world (None: the scene's own world and probes)
    lights: the scene's lights are used
    key:    equal for equal shading (a new key renders anew)
    """

    world: cs.World | None = None
    lights: bool = True
    key: tuple = field(default=())


SCENE = Shading()


def studio_texture(path: str) -> texture.Texture:
    """The studio HDRI at ``path`` as an equirectangular texture, read once per file version.
    Raises ``OSError`` or the reader's error for a missing or unreadable file."""
    def read() -> texture.Texture:
        if path.lower().endswith(".exr"):
            pixels = exr.rgb(path)
        else:  # a user's own studio light (.hdr, ...): read by Blender
            pixels = images.read_file(path, linear=True)[..., :3]
        return texture.make_texture(pixels, srgb=False, extension="REPEAT",
                                    interpolation="Linear", name=os.path.basename(path))

    return _textures.get_or_make((path, stamp(path)), read)


def key(space) -> tuple:
    """What decides ``shading(space)``, read without loading anything: equal keys, equal
    shading."""
    view = getattr(space, "shading", None)
    if view is None or view.type != "RENDERED":
        return ()
    lights = bool(view.use_scene_lights_render)
    if view.use_scene_world_render:
        return () if lights else (False,)
    light = view.selected_studio_light
    return (lights, light.path if light is not None else "",
            float(view.studiolight_rotate_z), float(view.studiolight_intensity),
            float(view.studiolight_background_blur), float(view.studiolight_background_alpha))


def shading(space) -> Shading:
    """The toggles of a 3D viewport ``space`` (``SpaceView3D``) in Rendered shading; ``SCENE``
    when it shows the scene as it is. Raises ``extract.SceneError`` when the studio light
    cannot be read."""
    wanted = key(space)
    if len(wanted) < 2:
        return Shading(lights=not wanted, key=wanted) if wanted else SCENE
    lights, path, rotate, strength, blur, alpha = wanted
    if not path:
        raise extract.SceneError("No studio light is selected for the viewport's world")
    try:
        tex = studio_texture(path)
    except Exception as exc:  # noqa: BLE001 - a missing or damaged HDRI: its name, once
        raise extract.SceneError(f"The studio light {os.path.basename(path)} cannot be read "
                                 f"({type(exc).__name__}: {exc})") from None
    levels = max(1.0, math.log2(max(tex.size[0], 1)) - 1.0)
    world = cs.World(color=np.ones(3, np.float32) * strength, texture=tex, strength=strength,
                     rotation=euler_xyz(0.0, 0.0, rotate),
                     background_lod=blur * levels, background_alpha=alpha)
    return Shading(world=world, lights=lights, key=wanted)
