"""The engine's settings, built from the Blender properties in one place per consumer: the
renders' ``RenderSettings`` (``render_settings``, per purpose), the probe bakes'
(``bake_settings``) and the lightmap bakes' (``lightmap_settings``). Nothing patches them
afterwards; a review that renders with other methods says so through ``methods``, never by
writing into the scene.
"""

from __future__ import annotations

import contextlib
from collections.abc import Iterator
from dataclasses import dataclass

import numpy as np

from ..core import scene as cs
from ..core.lighting import lightmap
from ..core.render import viewport
from . import passes

__all__ = ["PURPOSES", "BakeSettings", "bake_settings", "lightmap_settings", "methods",
           "render_border", "render_settings", "resolution"]

# What a render is for: an F12 frame, a material/light/world preview, the viewport's image,
# a probe bake's captures, a lightmap bake's scene
PURPOSES = ("FINAL", "PREVIEW", "VIEWPORT", "PROBE_BAKE", "LIGHTMAP_BAKE")

_methods: dict[str, dict] = {}  # scene name -> the RenderSettings fields ``methods`` sets


@contextlib.contextmanager
def methods(scene, **fields) -> Iterator[None]:
    """While open, the renders of ``scene`` use these ``RenderSettings`` fields (e.g. the
    talk's old methods: ``env_brdf="bo1"``), whatever its properties say; its properties stay
    as they are."""
    unknown = set(fields) - set(cs.RenderSettings.__dataclass_fields__)
    if unknown:
        raise ValueError(f"not render settings: {', '.join(sorted(unknown))}")
    _methods[scene.name_full] = fields
    try:
        yield
    finally:
        _methods.pop(scene.name_full, None)


def render_settings(scene, purpose: str = "FINAL", view_layer=None) -> cs.RenderSettings:
    """The ``RenderSettings`` of a Blender scene for ``purpose`` (one of ``PURPOSES``).

    FINAL and PREVIEW search contact occlusion for the AO pass when ``view_layer`` has it on;
    a PREVIEW renders at a quick quality (four samples, 512 px shadow maps: a 128 px preview
    takes a fraction of a second); the VIEWPORT and the bakes render the whole view (no
    border) in the viewport's tiles or as captures; the bakes' captures see the world (an
    opaque film), a probe bake's at its Bake Samples.
    """
    if purpose not in PURPOSES:
        raise ValueError(f"purpose is one of {PURPOSES}, not {purpose!r}")
    s, r = scene.bo2, scene.render
    ind = s.indirect
    width, height = resolution(scene)
    samples, shadow_resolution = int(s.samples), int(s.shadow_resolution)
    if purpose == "PREVIEW":
        samples, shadow_resolution = min(samples, 4), min(shadow_resolution, 512)
    elif purpose == "PROBE_BAKE":
        samples = int(s.probes.samples)
    whole = purpose in ("VIEWPORT", "PROBE_BAKE", "LIGHTMAP_BAKE")
    bake = purpose in ("PROBE_BAKE", "LIGHTMAP_BAKE")
    fields = dict(
        samples=samples,
        shade_every_sample=bool(s.shade_every_sample),
        filter_width=float(r.filter_size),
        specular_model=str(s.specular_model),
        layered_diffuse=bool(s.use_layered_diffuse),
        env_brdf=str(ind.env_brdf),
        normalization=str(ind.normalization),
        prefilter=str(ind.prefilter),
        film_transparent=bool(r.film_transparent) and not bake,
        blend_sort=str(s.blend_sort),
        shadow_resolution=shadow_resolution,
        ambient_occlusion=bool(ind.use_ambient_occlusion),
        ao_distance=float(ind.ao_distance),
        specular_occlusion=bool(ind.use_specular_occlusion),
        sky_directions=int(ind.sky_directions),
        sky_resolution=int(ind.sky_resolution),
        implicit_bounce=bool(ind.use_implicit_bounce),
        volume_extrapolation=bool(ind.use_wall_extrapolation),
        volume_visibility=bool(ind.use_visibility_test),
        nearest_reflections=bool(ind.use_nearest_reflections),
        threads=int(r.threads),  # Blender's Threads setting (Auto: one per core)
        border=None if whole else render_border(scene, width, height),
    )
    if purpose in ("FINAL", "PREVIEW") and view_layer is not None:
        fields["ao_pass"] = passes.enabled(view_layer, "AO")
        fields["shadow_catcher_pass"] = passes.enabled(view_layer, "Shadow Catcher")
    if motion_blur(scene, purpose):
        fields["shutter_curve"] = shutter_curve(scene)
        fields["rolling_shutter"] = rolling_shutter(scene)
    if purpose == "FINAL" and view_layer is not None:
        fields["cryptomatte"] = passes.cryptomatte(view_layer)
        fields["cryptomatte_levels"] = int(view_layer.pass_cryptomatte_depth)
        fields["light_groups"] = tuple(group.name for group in view_layer.lightgroups)
        fields["aovs"] = passes.aovs(view_layer)
    if purpose == "VIEWPORT":
        fields["tile_size"] = viewport.TILE_SIZE
    fields.update(_methods.get(scene.name_full, {}))
    return cs.RenderSettings(**fields)


def shutter_curve(scene) -> tuple[float, ...]:
    """Render > Motion Blur > Shutter Curve as ``RenderSettings.shutter_curve``: its values at
    33 times over the shutter, () when it is flat (the default)."""
    curve = scene.render.motion_blur_shutter_curve
    curve.initialize()
    values = tuple(float(curve.evaluate(curve.curves[0], x)) for x in np.linspace(0, 1, 33))
    return () if max(values) - min(values) < 1e-6 else values


def rolling_shutter(scene) -> float | None:
    """Render > Motion Blur > Rolling Shutter (Cycles' setting, read where Cycles is enabled)
    as ``RenderSettings.rolling_shutter``: its Duration when Top-Bottom, else None."""
    cycles = getattr(scene, "cycles", None)
    if getattr(cycles, "rolling_shutter_type", "NONE") != "TOP":
        return None
    return float(cycles.rolling_shutter_duration)


def motion_blur(scene, purpose: str) -> bool:
    """Whether a render of ``purpose`` (``settings.PURPOSES``) draws motion blur: final
    renders with Render > Motion Blur on, as Cycles (the viewport and previews do not)."""
    r = scene.render
    return purpose == "FINAL" and r.use_motion_blur and r.motion_blur_shutter > 0.0


@dataclass(frozen=True)
class BakeSettings:
    """A probe bake's settings (Render > Light Probes).

    backend:          "BO2" or "CYCLES": who renders the captures
    face_size:        texels of a reflection probe's cube face
    volume_face_size: texels of a volume sample's capture face
    bounces:          bounces of the BO2 backend (Cycles' captures hold them all: 1)
    converge:         the bounces after the last estimated (``core.bakes.series``)
    cycles_samples:   samples of the Cycles backend's captures
    """

    backend: str
    face_size: int
    volume_face_size: int
    bounces: int
    cycles_samples: int
    converge: bool = False


def bake_settings(scene, backend: str) -> BakeSettings:
    """The probe bake settings of a Blender scene, for ``backend`` ("BO2" or "CYCLES")."""
    s = scene.bo2.probes
    return BakeSettings(backend=backend, face_size=int(s.face_size),
                        volume_face_size=int(s.volume_face_size),
                        bounces=1 if backend == "CYCLES" else max(1, int(s.bounces)),
                        cycles_samples=int(s.cycles_samples),
                        converge=backend == "BO2" and bool(s.converge))


def lightmap_settings(scene) -> lightmap.Settings:
    """The lightmap bake settings of a Blender scene (Render > Lightmaps)."""
    s = scene.bo2.lightmaps
    return lightmap.Settings(
        texels_per_metre=float(s.density), max_resolution=int(s.max_resolution),
        padding=int(s.padding), rays=int(s.rays), bounces=int(s.bounces),
        directional=bool(s.directional), denoise=bool(s.denoise))


def resolution(scene) -> tuple[int, int]:
    """Output (width, height) in pixels after the resolution percentage."""
    r = scene.render
    scale = r.resolution_percentage / 100.0
    return max(1, int(r.resolution_x * scale)), max(1, int(r.resolution_y * scale))


def render_border(scene, width: int, height: int) -> tuple[int, int, int, int] | None:
    """Blender's render border as a pixel rectangle (x0, y0, x1, y1), top-left origin: its
    edges as Blender places them (each fraction times the size in float32, truncated), so the
    tiles fill the result Blender made for it."""
    r = scene.render
    if not r.use_border:
        return None

    def edge(fraction: float, size: int) -> int:  # Blender's: float32 product, truncated
        return int(np.float32(fraction) * np.float32(size))

    x0, x1 = edge(r.border_min_x, width), edge(r.border_max_x, width)
    y0, y1 = height - edge(r.border_max_y, height), height - edge(r.border_min_y, height)
    x0, y0 = max(0, min(x0, width - 1)), max(0, min(y0, height - 1))
    x1, y1 = max(x0 + 1, min(x1, width)), max(y0 + 1, min(y1, height))
    return x0, y0, x1, y1
