"""Probe baking: capture points, bounces, SH and prefiltered chains, the files' metadata.

A bake renders radiance cube maps at every probe's capture points (a reflection probe: its
centre; an irradiance volume: each grid sample, ``probes.volume_sample_positions``) through a
capture callback that the host supplies (the engine's pipeline, ``capture.Capture.cube``, or
another renderer), and turns them into what the renderer reads: SH (``sh.project``) for every
point and, for reflection probes, the BO2 cosine-power and BO1 angular Gaussian prefiltered
chains (``capture.filtered``; slides "Black Ops: environment map pre-filtering").

Bounces: the first bounce's captures see direct light, emission and the world, which lights
surfaces outside the probes' regions (an open scene's ground) but nothing inside them (a closed
room must not be lit by a sky it cannot see): ``first_bounce``. Each further bounce captures the
scene lit by the previous bounce's probes.

The host writes the results (``BakedProbe``) with ``probe_file.write`` and ``metadata``; nothing
here touches the disk, so a bake that is stopped early leaves the previous files as they were.
"""

from __future__ import annotations

from collections.abc import Callable, Iterator
from dataclasses import dataclass, field

import numpy as np

from . import capture, cubemap, sh
from .probes import IrradianceVolume, Probes, ReflectionProbe, volume_sample_positions
from .scene import World

__all__ = ["Bake", "BakedProbe", "ProbeSpec", "first_bounce", "metadata", "world_key",
           "world_probes"]

KINDS = ("reflection", "irradiance")
FILTERS = {"bo2": "cosine power", "bo1": "angular gaussian"}

# capture(position (3,) metres, face size, near, far, probes lighting the view) ->
# (6, size, size, 3) float32 radiance (faces of ``cubemap.FACES``)
CaptureFn = Callable[[np.ndarray, int, float, float, Probes], np.ndarray]


@dataclass(frozen=True, eq=False)
class ProbeSpec:
    """A probe to bake, as the host describes it.

    name:           the probe's name
    kind:           "reflection" (a sphere: centre, influence radius and falloff) or
                    "irradiance" (a volume: the grid spans the local cube [-1, 1]^3)
    local_to_world: (4, 4) float64 object matrix
    influence:      reflection: influence radius; irradiance: distance outside the box over
                    which the volume fades; metres
    falloff:        reflection: fraction of the radius over which the influence fades
    resolution:     irradiance: samples along local x, y, z
    clip_start, clip_end: clip distances of the captures, metres
    proxy:          reflection: the parallax proxy, "none", "sphere" or "box"
                    (``ReflectionProbe.proxy``), of ``proxy_distance`` local units around the
                    centre in the object's frame (its rotation and scale apply)
    """

    name: str
    kind: str
    local_to_world: np.ndarray
    influence: float
    falloff: float = 0.0
    resolution: tuple[int, int, int] | None = None
    clip_start: float = 0.05
    clip_end: float = 1e4
    proxy: str = "none"
    proxy_distance: float = 0.0

    def __post_init__(self) -> None:
        if self.kind not in KINDS:
            raise ValueError(f"unknown probe kind {self.kind!r}; expected one of {KINDS}")

    @property
    def points(self) -> np.ndarray:
        """(K, 3) float64 capture positions, metres: the centre, or the grid samples in
        x-major order (``volume_sample_positions``)."""
        m = np.asarray(self.local_to_world, np.float64)
        if self.kind == "reflection":
            return m[None, :3, 3]
        return volume_sample_positions(m, self.resolution).reshape(-1, 3)

    def describe(self) -> dict:
        """What a bake of this probe depends on, as stored in its file's metadata."""
        meta = {"probe": self.name, "kind": self.kind,
                "matrix": np.asarray(self.local_to_world, np.float64).tolist(),
                "clip_start": float(self.clip_start)}
        if self.kind == "irradiance":
            meta["resolution"] = [int(r) for r in self.resolution]
        return meta

    def probe(self, coeffs: np.ndarray, chains: dict | None) -> ReflectionProbe | IrradianceVolume:
        """The renderer's probe from baked SH ``coeffs`` (K, 9, 3) and, for a reflection probe,
        its prefiltered ``chains`` ({"bo2": [...], "bo1": [...]})."""
        m = np.asarray(self.local_to_world, np.float64)
        if self.kind == "reflection":
            proxy = self.proxy if self.proxy_distance > 0.0 else "none"
            return ReflectionProbe(self.name, m[:3, 3], float(self.influence),
                                   float(self.falloff), chains, coeffs[0], proxy,
                                   m @ np.diag([self.proxy_distance] * 3 + [1.0]))
        res = tuple(int(r) for r in self.resolution)
        return IrradianceVolume(self.name, m, res, coeffs.reshape(*res, 9, 3),
                                float(self.influence))


@dataclass
class BakedProbe:
    """One probe's bake: SH ``coeffs`` (K, 9, 3) float32 per capture point and, for a
    reflection probe, the prefiltered ``chains`` of its centre; ``face_size`` of the captures."""

    spec: ProbeSpec
    coeffs: np.ndarray
    chains: dict[str, list[np.ndarray]] | None
    face_size: int


def world_key(world: World, size: int) -> tuple:
    """A key that changes whenever the world's probe would (its texture by content)."""
    digest = world.texture.digest if world.texture is not None else None
    return (digest, np.asarray(world.color, np.float32).tobytes(), float(world.strength),
            np.asarray(world.rotation, np.float64).tobytes(), int(size))


_world_cache: dict = {}


def world_probes(world: World, size: int = 64) -> Probes:
    """Probes of the world alone, the fallback of every probe (SH (9, 3) and both chains of
    its ``size`` cube), computed once while the world stays the same."""
    key = world_key(world, size)
    if _world_cache.get("key") != key:
        _world_cache.clear()
        _world_cache["value"] = capture.filtered(capture.world_cube(world, size))
        _world_cache["key"] = key
    world_sh, world_mips = _world_cache["value"]
    color = None if world.texture is not None else np.asarray(world.color, np.float32)[:3]
    return Probes(world_sh=world_sh, world_mips=world_mips, world_color=color)


def first_bounce(world: World, specs: list[ProbeSpec]) -> Probes:
    """Indirect light of the first bounce's captures: the world's probes, with every probe to
    bake present but black, so that the world lights surfaces outside the probes' regions and
    nothing lights those inside them (later bounces fill them in)."""
    probes = world_probes(world)
    black_chain = [np.zeros((6, 1, 1, 3), np.float32)]
    for spec in specs:
        if spec.kind == "reflection":
            probes.reflection.append(spec.probe(np.zeros((1, 9, 3), np.float32),
                                                {"bo2": black_chain, "bo1": black_chain}))
        else:
            black = ProbeSpec(spec.name, spec.kind, spec.local_to_world, spec.influence,
                              resolution=(1, 1, 1))
            probes.volumes.append(black.probe(np.zeros((1, 9, 3), np.float32), None))
    return probes


def _sh_of_cube(cube: np.ndarray) -> np.ndarray:
    size = cube.shape[1]
    weights = np.broadcast_to(cubemap.texel_solid_angles(size), (6, size, size)).reshape(-1)
    return sh.project(cubemap.texel_directions(size).reshape(-1, 3), cube.reshape(-1, 3),
                      weights)


@dataclass
class Bake:
    """A bake of ``specs`` in the scene whose ``world`` is given, through ``capture``.

    bounces:          light bounces (>= 1; see the module docstring)
    face_size:        cube face size of reflection probes' captures, texels
    volume_face_size: cube face size of irradiance volumes' captures, texels
    results:          filled by ``steps()`` once every bounce is done
    """

    specs: list[ProbeSpec]
    world: World
    capture: CaptureFn
    bounces: int = 1
    face_size: int = 128
    volume_face_size: int = 16
    results: list[BakedProbe] = field(default_factory=list)

    def steps(self) -> Iterator[float]:
        """Run the bake, yielding the finished fraction in (0, 1] after every capture; closing
        the generator early (cancel) leaves ``results`` empty."""
        points = [spec.points for spec in self.specs]
        total = max(1, self.bounces) * sum(len(p) for p in points)
        done = 0
        lighting = first_bounce(self.world, self.specs)
        results: list[BakedProbe] = []
        for _ in range(max(1, self.bounces)):
            results = []
            baked = world_probes(self.world)
            for spec, pos in zip(self.specs, points, strict=True):
                size = self.face_size if spec.kind == "reflection" else self.volume_face_size
                near = max(float(spec.clip_start), 1e-3)
                far = max(float(spec.clip_end), 2.0 * near)
                coeffs, chains = [], None
                for p in pos:
                    cube = self.capture(p, size, near, far, lighting)
                    if spec.kind == "reflection":
                        c, chains = capture.filtered(cube)
                    else:
                        c = _sh_of_cube(cube)
                    coeffs.append(np.asarray(c, np.float32))
                    done += 1
                    yield done / total
                result = BakedProbe(spec, np.stack(coeffs), chains, size)
                results.append(result)
                probe = spec.probe(result.coeffs, chains)
                (baked.reflection if spec.kind == "reflection" else baked.volumes).append(probe)
            lighting = baked
        self.results = results


def metadata(baked: BakedProbe, backend: str, bounces: int, bake_time: str, seconds: float,
             version: str) -> dict:
    """The metadata of a probe file (``probe_file.write``): what the bake depends on
    (``ProbeSpec.describe``), how it was made and when."""
    return {**baked.spec.describe(), "face_size": baked.face_size,
            "filters": dict(FILTERS) if baked.chains else {}, "backend": backend,
            "bounces": bounces, "bake_time": bake_time, "bake_seconds": round(seconds, 3),
            "version": version}
