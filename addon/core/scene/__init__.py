"""Plain data that the core renders: camera, meshes, materials, lights, world.

The Blender host (``addon/blender/extract.py``) translates a depsgraph into these objects; the
core knows nothing of Blender. Conventions (``docs/engine.md``): world space is
Blender's (Z up, right-handed, metres), colours are scene-linear float32 RGB, light values are
Blender's units (W for point, spot and area lights; W/m^2 irradiance for sun).

A surface is a program (``program``) of operations, each declared once (``nodes``), evaluated
at the shaded points by ``material``, with Blender's node arithmetic in ``node_math`` and deep
graphs evaluated within a bounded stack by ``recursion``.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np

from ..formulas import affine
from ..formulas.texture import Texture
from . import linking
from .program import Program, talk_program

if TYPE_CHECKING:  # the lighting floor, above this one, holds the probes
    from ..lighting.probes import Probes

LIGHT_KINDS = ("POINT", "SPOT", "SUN", "AREA")


@dataclass(frozen=True)
class Aperture:
    """A thin lens's aperture, as Cycles models depth of field (Camera > Depth of Field).

    radius:   metres: the focal length over twice the f-stop
    focus:    distance along the view axis that is sharp, metres
    blades:   sides of a polygonal aperture (0: a disc)
    rotation: the polygon's rotation, radians
    ratio:    anamorphic ratio: the aperture's width is divided by it
    """

    radius: float
    focus: float
    blades: int = 0
    rotation: float = 0.0
    ratio: float = 1.0


@dataclass
class Camera:
    """A pinhole or orthographic camera, or a thin lens (``aperture``).

    world_to_camera: (4, 4) float64 view matrix; the camera looks down its -Z axis, Y up
    projection:      (4, 4) float64 OpenGL-style projection (camera space -> clip space)
    width, height:   output resolution in pixels
    orthographic:    True for an orthographic camera (view direction is constant)
    aperture:        depth of field (``render.depth_of_field``), perspective cameras only;
                     None: a pinhole
    motion:          (S, 4, 4) float64 world_to_camera at S evenly spaced times from the
                     shutter's opening to its closing (``render.motion_blur``), or None: still
    """

    world_to_camera: np.ndarray
    projection: np.ndarray
    width: int
    height: int
    orthographic: bool = False
    aperture: Aperture | None = None
    motion: np.ndarray | None = None

    @classmethod
    def look_at(cls, eye, target, fov_y: float, width: int, height: int,
                near: float = 0.1, far: float = 100.0) -> Camera:
        """A perspective camera at ``eye`` (3,) looking at ``target`` (3,), Z up.

        fov_y: vertical field of view, radians; near, far: clip distances, metres
        """
        eye, target = np.asarray(eye, np.float64), np.asarray(target, np.float64)
        forward = (target - eye) / np.linalg.norm(target - eye)
        right = np.cross(forward, [0.0, 0.0, 1.0])
        right /= np.linalg.norm(right)
        view = np.eye(4)
        view[0, :3], view[1, :3], view[2, :3] = right, np.cross(right, forward), -forward
        view[:3, 3] = -view[:3, :3] @ eye
        t = 1.0 / np.tan(fov_y / 2.0)
        proj = np.array([[t * height / width, 0.0, 0.0, 0.0], [0.0, t, 0.0, 0.0],
                         [0.0, 0.0, (far + near) / (near - far), 2.0 * far * near / (near - far)],
                         [0.0, 0.0, -1.0, 0.0]])
        return cls(world_to_camera=view, projection=proj, width=width, height=height)

    @property
    def camera_to_world(self) -> np.ndarray:
        """(4, 4) float64 inverse of ``world_to_camera``."""
        return affine.inverse(self.world_to_camera)

    @property
    def position(self) -> np.ndarray:
        """(3,) float64 camera origin in world space."""
        return self.camera_to_world[:3, 3]

    @property
    def forward(self) -> np.ndarray:
        """(3,) float64 unit viewing direction (the camera's -Z axis) in world space."""
        f = -self.camera_to_world[:3, 2]
        return f / np.linalg.norm(f)

    def rays(self, x: np.ndarray, y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """World-space camera rays through window positions.

        x, y:    (N,) float pixel coordinates from the image's top-left corner (pixel (r, c)
                 spans x in [c, c + 1), y in [r, r + 1))
        returns: origins (N, 3) on the near plane and unit directions (N, 3), float32
        """
        from ..kernels import shading

        inv = affine.inverse(self.projection @ self.world_to_camera)
        # Clip-space points on the near (z = -1) and a middle (z = 0) plane, as affine functions
        # of the pixel position: p(x, y) = a x + b y + c. Not the far plane: with far / near
        # large it is at infinity in float32 (the projection's z row rounds to -1).
        planes = np.stack([(2.0 / self.width) * inv[:, 0], (-2.0 / self.height) * inv[:, 1],
                           inv @ np.array([-1.0, 1.0, -1.0, 1.0]),
                           inv @ np.array([-1.0, 1.0, 0.0, 1.0])])
        x = np.ascontiguousarray(np.asarray(x, np.float64).reshape(-1))
        y = np.ascontiguousarray(np.asarray(y, np.float64).reshape(-1))
        origins, directions = (np.empty((len(x), 3), np.float32) for _ in range(2))
        shading.rays(x, y, planes, origins, directions)
        return origins, directions


@dataclass
class Material:
    """A surface: its compiled node tree (``core.scene.program.Program``) and its settings.

    program: what the surface is at each point (``program.talk_program()``: a grey dielectric)
    backface_culling: cull faces seen from behind
    pass_index: the material's index in the IndexMA pass (Blender's Material > Pass Index)
    blended: where it is transparent it is composited over what lies behind (Blender's Render
               Method: Blended; ``render.transparency.blend``), not dithered
    transparency_overlap: a blended surface shows every layer of its object; False: only the
               nearest (EEVEE's Transparency Overlap)
    """

    name: str = "Material"
    program: Program = field(default_factory=talk_program)
    backface_culling: bool = False
    pass_index: int = 0
    blended: bool = False
    transparency_overlap: bool = True

    @classmethod
    def talk(cls, name: str = "Material", albedo=(0.8, 0.8, 0.8), rf0=(0.04, 0.04, 0.04),
             gloss: float = 0.5, emission=(0.0, 0.0, 0.0), emission_strength: float = 1.0,
             **settings) -> Material:
        """A constant material in the talk's parameters: albedo, rf0 (3,) linear, gloss in
        [0, 1], emission (3,) times ``emission_strength``, W/(m^2 sr)."""
        return cls(name, talk_program(albedo, rf0, gloss, emission, emission_strength),
                   **settings)


@dataclass
class MeshBatch:
    """Triangles of one evaluated object instance, already in world space.

    positions: (T, 3, 3) float32 corner positions, metres
    normals:   (T, 3, 3) float32 unit corner normals (smooth, flat or custom split normals)
    material:  (T,) int32 index into ``Scene.materials``
    uvs:       (T, 3, 2) float32 corner UVs of the active render UV map, or None
    name:      the object's name, for messages
    holdout:   the object cuts a hole: alpha 0 and no colour where it is visible
    camera:    the camera sees it (False: it still casts shadows and is in the probes'
               captures, as Blender's Camera ray visibility)
    shadow:    it casts shadows (Blender's Shadow ray visibility)
    sphere_probes, volume_probes: the captures of Sphere, of Volume probes see it (Blender's
               Object > Visibility > Light Probes; False: it still casts shadows there)
    attributes: corner values the materials read (``program.Program.requires``), by key:
               ("uv", map) (T, 3, 2); ("attribute", name) (T, 3, 4) RGBA (a float f as
               (f, f, f, 1), a vector as (x, y, z, 1)); ("tangent", map) (T, 3, 4) world
               MikkTSpace tangent and bitangent sign. Map or name "" is the active render one
    world_to_object: (4, 4) float64 (Object texture coordinates); identity when None; or
               (I, 4, 4), one per instance, for I instances of one mesh (geometry-nodes
               instances read at once): the triangles are then instance by instance, T / I
               each
    texspace:  (2, 3) Generated coordinates are (p_object - texspace[0]) / texspace[1]
    lightmap:  its baked ``lightmap.Lightmap`` (the diffuse indirect light of its surface), or
               None: the probes light it
    asset:     the name of its object's topmost parent ("" for none: its own), for the
               Cryptomatte Asset pass
    group:     the light group its emission is counted in ("": none)
    shadow_catcher: it shows only the shadows it receives (Blender's Shadow Catcher,
               ``render.shading``)
    light_sets, shadow_sets: the light and shadow linking sets it belongs to, bit k for set k
               (``linking``): the lights of receiver set k light it, it blocks the lights of
               blocker set k; every bit by default
    motion:    (S, T, 3, 3) float32 corner positions at S evenly spaced times from the
               shutter's opening to its closing (``render.motion_blur``; ``positions`` are
               the frame's own time), or None: it does not move
    """

    positions: np.ndarray
    normals: np.ndarray
    material: np.ndarray
    uvs: np.ndarray | None = None
    name: str = ""
    holdout: bool = False
    camera: bool = True
    shadow: bool = True
    sphere_probes: bool = True
    volume_probes: bool = True
    attributes: dict = field(default_factory=dict)
    world_to_object: np.ndarray | None = None
    texspace: np.ndarray | None = None
    lightmap: object | None = None
    asset: str = ""
    group: str = ""
    shadow_catcher: bool = False
    light_sets: int = linking.EVERY
    shadow_sets: int = linking.EVERY
    motion: np.ndarray | None = None


@dataclass
class Light:
    """One light in Blender's units.

    kind:      "POINT", "SPOT", "SUN" or "AREA"
    color:     (3,) linear colour times power: W (point, spot, area) or W/m^2 (sun)
    position:  (3,) world position, metres (unused for sun)
    direction: (3,) unit direction the light shines along (the object's -Z axis)
    radius:    point/spot radius in metres, or the sun's angular diameter in radians
    spot_size: full cone angle in radians (spot only)
    spot_blend: softness of the cone edge in [0, 1] (spot only)
    size:      (2,) area light extent in metres along its local X and Y
    shadow:    whether the light casts shadows
    receivers: its light linking set (``linking``): it lights only the meshes of that set
               (``MeshBatch.light_sets``); 0, every mesh
    blockers:  its shadow linking set: only the meshes of that set shadow it
               (``MeshBatch.shadow_sets``); 0, every caster
    group:     the light group its light is counted in (``RenderSettings.light_groups``;
               "": none)
    """

    kind: str
    color: np.ndarray
    position: np.ndarray = field(default_factory=lambda: np.zeros(3))
    direction: np.ndarray = field(default_factory=lambda: np.array([0.0, 0.0, -1.0]))
    radius: float = 0.0
    spot_size: float = np.pi / 4
    spot_blend: float = 0.15
    size: np.ndarray = field(default_factory=lambda: np.ones(2))
    shadow: bool = True
    name: str = ""
    receivers: int = 0
    blockers: int = 0
    group: str = ""

    def __post_init__(self) -> None:
        if not (0 <= self.receivers < linking.SETS and 0 <= self.blockers < linking.SETS):
            raise ValueError(f"a light's linking sets are 0 to {linking.SETS - 1}")
        if self.kind not in LIGHT_KINDS:
            raise ValueError(f"unknown light kind {self.kind!r}; expected one of {LIGHT_KINDS}")


@dataclass
class World:
    """The background seen by the camera.

    color:    (3,) constant radiance, W/(m^2 sr), used when there is no texture
    texture:  optional equirectangular ``core.formulas.texture.Texture`` (Blender's Environment
              Texture mapping), radiance = texture * strength
    strength: multiplier of the texture
    rotation: (3, 3) world-to-texture rotation (a Mapping node's rotation), identity by default
    background_lod: mip level of the texture the camera sees (a viewport's studio light blur);
              the light it casts is unchanged
    background_alpha: opacity of the background the camera sees (a studio light's)
    sun:      the world's sun taken out of the texture (``world_sun``), a "SUN" ``Light`` that
              is also one of the scene's lights; the camera sees its disc (``world_sun``)
    group:    the light group of its light, the indirect light and the background ("": none)
    """

    color: np.ndarray = field(default_factory=lambda: np.full(3, 0.05, np.float32))
    texture: Texture | None = None
    strength: float = 1.0
    rotation: np.ndarray = field(default_factory=lambda: np.eye(3))
    background_lod: float = 0.0
    background_alpha: float = 1.0
    sun: Light | None = None
    group: str = ""


@dataclass(frozen=True)
class Choice:
    """One value of a setting that takes a few named values: its identifier, and the label and
    description a UI shows (citing the slide it implements)."""

    id: str
    label: str
    description: str


# The values of ``RenderSettings``' named settings, declared once (the UI's lists derive from
# them; a test holds them to the formulas' and kernels' own names).
CHOICES: dict[str, tuple[Choice, ...]] = {
    "specular_model": (
        Choice("reference", "Reference", "The talk's terms (slides 'Black Ops: normal "
               "distribution function', 'reflectance function', 'visibility function'): "
               "Blinn-Phong NDF, Schlick Fresnel, Schlick-Smith"),
        Choice("bo2", "BO2 optimized", "Bonus slides 'Black Ops II: new Fresnel "
               "approximation' and 'new visibility function approximation': 2^(-10 l.h) "
               "Fresnel, fast visibility"),
        Choice("none", "No visibility", "Visibility term V = 1 (slide 'Black Ops: visibility "
               "function', its comparison)"),
        Choice("cook_torrance", "Cook-Torrance", "Cook-Torrance geometry term (slide 'Black "
               "Ops: visibility function', its comparison)"),
        Choice("kelemen", "Kelemen/Szirmay-Kalos", "Kelemen and Szirmay-Kalos visibility "
               "approximation (slide 'Black Ops: visibility function', its comparison)"),
    ),
    "env_brdf": (
        Choice("bo1", "BO1", "Slide 'Black Ops: environment map \u201cFresnel\u201d': "
               "rf0 + (1 - rf0)(1 - n.v)^5 / (4 - 3 gloss)"),
        Choice("bo2", "BO2", "Slide 'Final approximation': the analytic EnvironmentBRDF of "
               "the talk"),
        Choice("fit", "Fit", "Our fit to the ground truth: BO2's curve refitted, two "
               "operations more, lower maximum, mean and relative error than BO2 for "
               "dielectrics and metals (docs/env_brdf.md)"),
        Choice("table", "Ground Truth (Table)", "The numerically integrated environment BRDF, "
               "looked up in a 64 x 64 table"),
    ),
    "normalization": (
        Choice("none", "None", "The cube map as captured"),
        Choice("bo1", "BO1 Average Irradiance", "Slide 'Black Ops: normalization algorithm': "
               "divide by the probe's average irradiance (SH constant term), multiply by the "
               "pixel's"),
        Choice("bo2", "BO2 Directional Irradiance", "Slide 'Improved normalization "
               "algorithm': divide by the probe's irradiance at the normal (tinted scalar SH), "
               "multiply by the pixel's irradiance"),
    ),
    "blend_sort": (
        Choice("pixel", "Per Pixel", "Blended surfaces composited in the order of their depths "
               "at each pixel: exact, as Cycles sees them"),
        Choice("object", "Object Origin", "As EEVEE sorts them: whole objects by their "
               "origins' depth along the view axis, an object's faces in their order"),
    ),
    "prefilter": (
        Choice("bo1", "BO1 Angular Gaussian", "Slide 'Black Ops: environment map "
               "pre-filtering': CubeMapGen's angular Gaussian filter"),
        Choice("bo2", "BO2 Cosine Power", "Slide 'Improved environment map pre-filtering': "
               "each mip filtered with the Phong power of the gloss that reads it"),
    ),
}


@dataclass
class RenderSettings:
    """Engine settings that change the image.

    samples:        anti-aliasing samples per pixel
    shade_every_sample: shade each sample on its own instead of once per pixel and triangle
                    (supersamples textures, highlights and shadow edges; slower)
    filter_width:   Blackman-Harris pixel filter width in pixels (Cycles' default 1.5)
    specular_model: the direct specular terms, an id of ``CHOICES["specular_model"]``
    layered_diffuse: a Principled BSDF's diffuse weighted by one less its specular's albedo
                    toward the eye (``env_brdf.diffuse_layering``), as Cycles layers it
    env_brdf:       environment BRDF of indirect specular, of ``CHOICES["env_brdf"]``
    normalization:  environment map normalization, of ``CHOICES["normalization"]``
    prefilter:      prefiltered chain of the reflections, of ``CHOICES["prefilter"]``
    film_transparent: background alpha 0 instead of the world colour
    shadow_resolution: shadow map size in texels (per cube face or cascade)
    ambient_occlusion: contact occlusion of probe and world light (``occlusion``)
    ao_distance:    how far surfaces occlude, metres
    ao_pass:        the AO pass is wanted: contact occlusion is searched even where no indirect
                    light reaches (a scene without any: False searches none, the pass is 1)
    specular_occlusion: reflections occluded as well (from the ambient occlusion)
    sky_directions: directions of the dome of shadow maps through which the world's light is
                    occluded (``sky``); 0 lets it reach every point
    sky_resolution: size of each of the dome's shadow maps, texels
    implicit_bounce: a scene without a volume probe gets the light that bounces off its
                    surfaces from a coarse volume baked on demand (``bounce``)
    volume_extrapolation: volumes' light extrapolated past their outermost samples up to
                    their boxes' faces (``IrradianceVolume.sample_sh``), not held
    volume_visibility: volumes' samples weighted by whether they see the point
                    (``sample_visibility``)
    nearest_reflections: beyond the Sphere probes' influence, where the world is hidden, the
                    nearest probes reflect in its place (``probes.indirect``; off by default:
                    it asks the world's dome of most points, 13% of the demo room's frame);
                    the bakes' captures leave it off (it would cost them the world's
                    visibility of most of their points, for reflections that matter little to
                    the light they gather)
    tile_size:      the frame is rendered in square tiles of this many pixels (bounds memory)
    threads:        tiles and shadow-map faces rendered at once (the kernels release the
                    GIL); 0 = one per CPU core
    border:         optional (x0, y0, x1, y1) pixel region to render, top-left origin,
                    x1 and y1 exclusive (Blender's render border)
    lightmaps:      objects with a baked lightmap take their diffuse indirect light from it
                    (``lightmap``); False: from the probes, as every other object
    cryptomatte:    the Cryptomatte passes wanted, of ``render.cryptomatte.KINDS``
    cryptomatte_levels: the ranks each keeps per pixel (the view layer's Levels)
    light_groups:   the light groups whose passes are wanted (``Combined_<name>``): each the
                    light of the lights, the world and the emission of the meshes in it
    shadow_catcher_pass: the Shadow Catcher pass is wanted: shadow catchers are then left out
                    of Combined (alpha 0), their shadows in the pass alone, as Cycles does
    blend_sort:     the order blended surfaces are composited in, of ``CHOICES["blend_sort"]``
    shutter_curve:  the shutter's openness at evenly spaced times from its opening to its
                    closing (Cycles' shutter curve), () for a flat one: the samples' times of
                    motion blur are distributed as it (``motion_blur.shutter_times``)
    rolling_shutter: None for a global shutter; else the rows are read from top to bottom
                    over the shutter, each open for this share of it, in [0, 1] (Cycles'
                    Rolling Shutter Top-Bottom and its Duration; ``motion_blur.rolling``)
    aovs:           the shader AOV passes wanted, (name, "COLOR" or "VALUE") each: what the
                    materials' AOV Output nodes of that name give (``Program.aovs``; a colour
                    with alpha 1), 0 elsewhere
    """

    samples: int = 4
    shade_every_sample: bool = False
    filter_width: float = 1.5
    specular_model: str = "reference"
    layered_diffuse: bool = False
    env_brdf: str = "bo2"
    normalization: str = "bo2"
    prefilter: str = "bo2"
    film_transparent: bool = False
    shadow_resolution: int = 1024
    ambient_occlusion: bool = True
    ao_distance: float = 0.25
    ao_pass: bool = True
    specular_occlusion: bool = True
    sky_directions: int = 32
    sky_resolution: int = 256
    implicit_bounce: bool = True
    volume_extrapolation: bool = False
    volume_visibility: bool = True
    nearest_reflections: bool = False
    tile_size: int = 256
    threads: int = 0
    border: tuple[int, int, int, int] | None = None
    lightmaps: bool = True
    cryptomatte: tuple[str, ...] = ()
    cryptomatte_levels: int = 6
    light_groups: tuple[str, ...] = ()
    shadow_catcher_pass: bool = False
    blend_sort: str = "pixel"
    aovs: tuple[tuple[str, str], ...] = ()
    shutter_curve: tuple[float, ...] = ()
    rolling_shutter: float | None = None


@dataclass
class Scene:
    """Everything one frame needs."""

    camera: Camera
    meshes: list[MeshBatch] = field(default_factory=list)
    materials: list[Material] = field(default_factory=list)
    lights: list[Light] = field(default_factory=list)
    world: World = field(default_factory=World)
    settings: RenderSettings = field(default_factory=RenderSettings)
    probes: Probes | None = None  # indirect light; None renders direct light only
