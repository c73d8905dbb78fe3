"""Plain data that the core renders: camera, meshes, materials, lights, world.

The Blender host (``addon/blender/extract.py``) translates a depsgraph into these objects; the
core knows nothing of Blender. Conventions (see the project's DESIGN.md): world space is
Blender's (Z up, right-handed, metres), colours are scene-linear float32 RGB, light values are
Blender's units (W for point, spot and area lights; W/m^2 irradiance for sun).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

LIGHT_KINDS = ("POINT", "SPOT", "SUN", "AREA")


@dataclass
class Camera:
    """A pinhole or orthographic camera.

    world_to_camera: (4, 4) float64 view matrix; the camera looks down its -Z axis, Y up
    projection:      (4, 4) float64 OpenGL-style projection (camera space -> clip space)
    width, height:   output resolution in pixels
    orthographic:    True for an orthographic camera (view direction is constant)
    """

    world_to_camera: np.ndarray
    projection: np.ndarray
    width: int
    height: int
    orthographic: bool = False

    @property
    def camera_to_world(self) -> np.ndarray:
        """(4, 4) float64 inverse of ``world_to_camera``."""
        return np.linalg.inv(self.world_to_camera)

    @property
    def position(self) -> np.ndarray:
        """(3,) float64 camera origin in world space."""
        return self.camera_to_world[:3, 3]

    @property
    def forward(self) -> np.ndarray:
        """(3,) float64 unit viewing direction (the camera's -Z axis) in world space."""
        f = -self.camera_to_world[:3, 2]
        return f / np.linalg.norm(f)


@dataclass
class Material:
    """The talk's material parameters, constant over a surface.

    albedo:   (3,) diffuse reflectance, linear
    rf0:      (3,) specular colour: base reflectance at normal incidence, linear
    gloss:    gloss in [0, 1]; specular power alpha = 8192^gloss
    emission: (3,) emitted radiance, W/(m^2 sr), colour times strength
    backface_culling: cull faces seen from behind
    """

    name: str = "Material"
    albedo: np.ndarray = field(default_factory=lambda: np.full(3, 0.8, np.float32))
    rf0: np.ndarray = field(default_factory=lambda: np.full(3, 0.04, np.float32))
    gloss: float = 0.5
    emission: np.ndarray = field(default_factory=lambda: np.zeros(3, np.float32))
    backface_culling: bool = False


@dataclass
class MeshBatch:
    """Triangles of one evaluated object instance, already in world space.

    positions: (T, 3, 3) float32 corner positions, metres
    normals:   (T, 3, 3) float32 unit corner normals (smooth, flat or custom split normals)
    material:  (T,) int32 index into ``Scene.materials``
    name:      the object's name, for messages
    """

    positions: np.ndarray
    normals: np.ndarray
    material: np.ndarray
    name: str = ""


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

    def __post_init__(self) -> None:
        if self.kind not in LIGHT_KINDS:
            raise ValueError(f"unknown light kind {self.kind!r}; expected one of {LIGHT_KINDS}")


@dataclass
class World:
    """The background: a constant radiance seen by the camera. color: (3,) W/(m^2 sr)."""

    color: np.ndarray = field(default_factory=lambda: np.full(3, 0.05, np.float32))


@dataclass
class RenderSettings:
    """Engine settings that change the image.

    samples:        anti-aliasing samples per pixel (stratified over the pixel)
    specular_model: one of ``brdf.MODELS``
    film_transparent: background alpha 0 instead of the world colour
    """

    samples: int = 4
    specular_model: str = "reference"
    film_transparent: bool = False


@dataclass
class Scene:
    """Everything one frame needs."""

    camera: Camera
    meshes: list[MeshBatch] = field(default_factory=list)
    materials: list[Material] = field(default_factory=list)
    lights: list[Light] = field(default_factory=list)
    world: World = field(default_factory=World)
    settings: RenderSettings = field(default_factory=RenderSettings)
