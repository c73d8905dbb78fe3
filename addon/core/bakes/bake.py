"""Probe baking: capture points, bounces, SH and prefiltered chains, the files' metadata.

A bake renders radiance cube maps at every probe's capture points (a reflection probe: its
centre; an irradiance volume: each grid sample, ``probes.volume_sample_positions``) through a
capture callback that the host supplies (the engine's pipeline, ``capture.Capture.cube``, or
another renderer), and turns them into what the renderer reads: SH (``sh.project``) for every
point and, for reflection probes, the BO2 cosine-power and BO1 angular Gaussian prefiltered
chains (``world_probes.filtered``; slides "Black Ops: environment map pre-filtering").

Bounces: the first bounce's captures see direct light, emission and the world, whose light
reaches each captured surface in proportion to the sky it sees (``sky``: an open scene's ground
is lit by all of it, a closed room only through its openings; no rule about where a surface
lies decides it). Each further bounce captures the scene lit by the previous bounce's probes,
diffuse and specular (a metal in a capture reflects the previous bounce's reflection probes),
and by the world's seen light where they leave weight, so bounce n adds light that has bounced
n times and the sum converges (a closed box: the geometric series of its albedo). Within a
bounce the volumes are captured first, and the reflection probes' captures take their diffuse
light from this bounce's volumes: a surface a metal reflects has as many diffuse bounces as
the same surface in a frame. With ``Bake.converge`` the bounces after the last are
estimated from the last three (``series``).

Irradiance volumes without leaks, as EEVEE's (``VolumeSettings``): before the first bounce,
each sample's surroundings are looked at (``SurfacesFn``); a sample that sees mostly back faces
is in geometry: it escapes through the nearest back face when that is within its escape
distance, and a sample still invalid takes the light of its valid neighbours (``dilate``), or
is left out of the look-up's blend (``IrradianceVolume.validity``).

The host writes the results (``BakedProbe``) with ``probe_file.write`` and ``metadata``; nothing
here touches the disk, so a bake that is stopped early leaves the previous files as they were.
"""

from __future__ import annotations

from collections.abc import Callable, Iterator
from dataclasses import dataclass, field, replace

import numpy as np

from ..formulas import cubemap, sh
from ..lighting import sample_visibility
from ..lighting.probes import (
    IrradianceVolume,
    Probes,
    ReflectionProbe,
    grid_spacing,
    volume_sample_positions,
)
from ..lighting.world_probes import filtered, world_probes
from ..render.job import Warnings
from ..scene import World
from . import capture, series

__all__ = ["Bake", "BakedProbe", "Here", "Look", "ProbeSpec", "Shot", "VolumeSettings", "check",
           "dilate", "escape", "look", "looks", "metadata", "shoot"]

KINDS = ("reflection", "irradiance")
FILTERS = {"bo2": "cosine power", "bo1": "angular gaussian"}

# capture(position (3,) metres, face size, near, far, probes lighting the view, probe kind) ->
# (6, size, size, 3) float32 radiance (faces of ``cubemap.FACES``)
CaptureFn = Callable[[np.ndarray, int, float, float, Probes, str], np.ndarray]
# surfaces(position (3,) metres, face size, near, far) -> ``capture.Surfaces``
SurfacesFn = Callable[[np.ndarray, int, float, float], "capture.Surfaces"]


BAKED_LEAK_SETTINGS = ("dilation_threshold", "validity_threshold", "dilation_radius",
                       "escape_bias")  # what a bake depends on (the others: the look-up)


@dataclass(frozen=True)
class VolumeSettings:
    """An irradiance volume's leak settings (Blender's ``LightProbeVolume``, same defaults).

    dilation_threshold: a sample whose front-facing ratio (``capture.Surfaces``) is below this
                        is invalid: it takes its neighbours' light (``dilate``)
    validity_threshold: an invalid sample with no valid neighbour, its ratio below this too,
                        is left out of the look-up
    dilation_radius:    how far ``dilate`` looks, in grid steps
    escape_bias:        an invalid sample moves out through the nearest back face within this
                        many sample spacings before it is captured (``escape``)
    normal_bias, view_bias, facing_bias: the look-up's (``IrradianceVolume``)
    """

    dilation_threshold: float = 0.5
    validity_threshold: float = 0.4
    dilation_radius: float = 1.0
    escape_bias: float = 0.1
    normal_bias: float = 0.3
    view_bias: float = 0.0
    facing_bias: float = 0.5


@dataclass(frozen=True, eq=False)
class ProbeSpec:
    """A probe to bake, as the host describes it.

    name:           the probe's name
    kind:           "reflection" (a sphere: centre, influence radius and falloff) or
                    "irradiance" (a volume: the grid spans the local cube [-1, 1]^3)
    local_to_world: (4, 4) float64 object matrix
    influence:      reflection: influence radius, metres; irradiance: distance outside the box
                    over which the volume fades, in its local units (Blender's Distance)
    falloff:        fraction of the influence over which it fades (Blender's Falloff)
    resolution:     irradiance: samples along local x, y, z
    clip_start, clip_end: clip distances of the captures, metres
    proxy:          reflection: the parallax proxy, "none", "sphere" or "box"
                    (``ReflectionProbe.proxy``), of ``proxy_distance`` local units around the
                    centre in the object's frame (its rotation and scale apply)
    volume:         irradiance: the leak settings
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
    volume: VolumeSettings = VolumeSettings()

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
            v = self.volume
            meta["leaks"] = {name: float(getattr(v, name)) for name in BAKED_LEAK_SETTINGS}
        return meta

    def probe(self, coeffs: np.ndarray, chains: dict | None,
              validity: np.ndarray | None = None,
              moments: np.ndarray | None = None) -> ReflectionProbe | IrradianceVolume:
        """The renderer's probe from baked SH ``coeffs`` (K, 9, 3) and, for a reflection probe,
        its prefiltered ``chains`` ({"bo2": [...], "bo1": [...]}); for a volume, the samples'
        ``validity`` (K,) (None: all valid) and depth ``moments`` (K, 6, M, M, 2) (None: no
        visibility test)."""
        m = np.asarray(self.local_to_world, np.float64)
        if self.kind == "reflection":
            proxy = self.proxy if self.proxy_distance > 0.0 else "none"
            return ReflectionProbe(self.name, m[:3, 3], float(self.influence),
                                   float(self.falloff), chains, coeffs[0], proxy,
                                   m @ np.diag([self.proxy_distance] * 3 + [1.0]))
        res = tuple(int(r) for r in self.resolution)
        v = self.volume
        return IrradianceVolume(
            self.name, m, res, coeffs.reshape(*res, 9, 3), float(self.influence),
            None if validity is None else np.asarray(validity, np.float32).reshape(res),
            float(v.normal_bias), float(v.view_bias), float(v.facing_bias), float(self.falloff),
            None if moments is None else np.asarray(moments, np.float32).reshape(
                *res, *np.shape(moments)[1:]))


@dataclass
class BakedProbe:
    """One probe's bake: SH ``coeffs`` (K, 9, 3) float32 per capture point and, for a
    reflection probe, the prefiltered ``chains`` of its centre; ``face_size`` of the captures;
    for a volume, ``validity`` (K,) float32, 1 or 0 (``dilate``), ``escaped``, the samples
    moved out of geometry, and the samples' depth ``moments`` (K, 6, M, M, 2) float32
    (``sample_visibility``)."""

    spec: ProbeSpec
    coeffs: np.ndarray
    chains: dict[str, list[np.ndarray]] | None
    face_size: int
    validity: np.ndarray | None = None
    escaped: int = 0
    moments: np.ndarray | None = None


def check(specs: list[ProbeSpec], warnings: Warnings) -> list[ProbeSpec]:
    """The probes a bake can use; into ``warnings``, one message for each that is odd: a
    volume with one sample along an axis (constant along it), a probe of no size (skipped), a
    reflection probe of no influence (it lights nothing), two probes of the same kind in
    exactly the same place (their light is averaged)."""
    kept, seen = [], {}
    for spec in specs:
        m = np.asarray(spec.local_to_world, np.float64)
        where = f"Light probe '{spec.name}'"
        if not np.isfinite(m).all() or abs(np.linalg.det(m[:3, :3])) < 1e-12:
            warnings.add(f"{where} has no size (a zero or non-finite scale); it is skipped")
            continue
        if spec.kind == "irradiance":
            flat = [axis for axis, r in zip("xyz", spec.resolution, strict=True) if r < 2]
            if flat:
                warnings.add(f"{where} has one sample along {', '.join(flat)}: its light is "
                                "the same all along that axis")
        elif spec.influence <= 0.0:
            warnings.add(f"{where} has no influence (Influence Distance 0): it lights "
                            "nothing")
        key = (spec.kind, np.round(m, 6).tobytes(), spec.resolution)
        if key in seen:
            warnings.add(f"{where} is exactly where '{seen[key]}' is: their light is "
                            "averaged; delete one")
        seen.setdefault(key, spec.name)
        kept.append(spec)
    return kept


def capture_region(specs: list[ProbeSpec]) -> tuple[np.ndarray, np.ndarray]:
    """The world box (lo (3,), hi (3,)) float64, metres, whose shadows the captures of
    ``specs`` need sharp: each probe's capture points out to a margin of the larger of their
    spread and twice the probe's influence (at least 1 m, at most its Clip End). The suns'
    shadow maps of a bake cover this box (``capture.Capture``), so a far terrain or ocean
    does not spread their texels over kilometres; beyond it captures see no sun shadows."""
    lo, hi = [], []
    for s in specs:
        points = s.points
        scale = float(np.abs(np.asarray(s.local_to_world, np.float64)[:3, :3]).sum(0).max())
        reach = s.influence if s.kind == "reflection" else s.influence * scale
        margin = min(max(float(np.linalg.norm(np.ptp(points, axis=0))), 2.0 * reach, 1.0),
                     s.clip_end)
        lo.append(points.min(0) - margin)
        hi.append(points.max(0) + margin)
    return np.min(lo, axis=0), np.max(hi, axis=0)


def _sh_of_cube(cube: np.ndarray) -> np.ndarray:
    size = cube.shape[1]
    weights = np.broadcast_to(cubemap.texel_solid_angles(size), (6, size, size)).reshape(-1)
    return sh.project(cubemap.texel_directions(size).reshape(-1, 3), cube.reshape(-1, 3),
                      weights)


def dilate(coeffs: np.ndarray, ratio: np.ndarray, settings: VolumeSettings) -> tuple[
        np.ndarray, np.ndarray]:
    """EEVEE's dilation: a sample whose front-facing ratio is below ``dilation_threshold`` takes
    the light of the samples at or above it within ``dilation_radius`` grid steps, weighted by
    inverse squared distance in grid steps; with none there, it keeps its own light, and is
    left out of the look-up (validity 0) when its ratio is below ``validity_threshold`` too.

    coeffs: (X, Y, Z, 9, 3) SH;  ratio: (X, Y, Z) front-facing ratios (``capture.Surfaces``)
    returns: (coeffs (X, Y, Z, 9, 3), validity (X, Y, Z) float32, 1 or 0)
    """
    out = np.array(coeffs, np.float32)
    valid = ratio >= settings.dilation_threshold
    validity = np.ones(ratio.shape, np.float32)
    radius = float(settings.dilation_radius)
    r = int(np.floor(radius))
    offsets = [(i, j, k) for i in range(-r, r + 1) for j in range(-r, r + 1)
               for k in range(-r, r + 1) if 0 < i * i + j * j + k * k <= radius * radius]
    shape = np.array(valid.shape)
    for cell in np.argwhere(~valid):
        acc, total = np.zeros((9, 3), np.float64), 0.0
        for off in offsets:
            q = cell + off
            if (q >= 0).all() and (q < shape).all() and valid[tuple(q)]:
                w = 1.0 / float(np.dot(off, off))
                acc += w * coeffs[tuple(q)]
                total += w
        if total > 0.0:
            out[tuple(cell)] = acc / total
        elif ratio[tuple(cell)] < settings.validity_threshold:
            validity[tuple(cell)] = 0.0
    return out, validity


@dataclass(frozen=True)
class Look:
    """One volume sample's look at its surroundings (``look``): where it is, the captures'
    face size and clip distances, the dilation threshold, how far it may escape (metres) and
    the depth moments' clamp (``sample_visibility.max_distance``)."""

    position: np.ndarray
    size: int
    near: float
    far: float
    threshold: float
    reach: float
    clamp: float


def look(job: Look, surfaces: SurfacesFn) -> tuple[np.ndarray, float, bool, np.ndarray]:
    """A volume sample's capture position (``VolumeSettings``): a sample whose front-facing
    ratio is below the dilation threshold moves through the nearest back face it sees when
    that face is within its reach (to a point a tenth of that beyond it), if its ratio is at
    or above the threshold there. Returns (position (3,) float64, ratio, whether it moved,
    depth moments (6, M, M, 2) float32 seen from the position, ``sample_visibility.moments``)."""
    p = np.asarray(job.position, np.float64)
    seen = surfaces(p, job.size, job.near, job.far)
    ratio, moved = float(seen.front_ratio), False
    if seen.front_ratio < job.threshold and seen.back_direction is not None \
            and seen.back_distance <= job.reach:
        out = p + seen.back_direction * (seen.back_distance + 0.1 * job.reach)
        there = surfaces(out, job.size, job.near, job.far)
        if there.front_ratio >= job.threshold:
            p, ratio, seen, moved = out, float(there.front_ratio), there, True
    return p, ratio, moved, sample_visibility.moments(seen.distances, job.clamp)


def looks(spec: ProbeSpec, size: int, near: float, far: float) -> list[Look]:
    """The looks (``look``) of a volume's samples, in the order of ``spec.points``."""
    settings = spec.volume
    reach = settings.escape_bias * grid_spacing(spec.local_to_world, spec.resolution)
    clamp = sample_visibility.max_distance(spec.local_to_world, spec.resolution)
    return [Look(p, size, near, far, float(settings.dilation_threshold), float(reach),
                 float(clamp)) for p in spec.points]


def escape(spec: ProbeSpec, surfaces: SurfacesFn, size: int, near: float,
           far: float) -> Iterator[None]:
    """A volume's capture positions and what each sees (``look``), one sample per step.

    Yields once per sample; returns (positions (K, 3) float64, ratios (K,) float64, how many
    samples moved, depth moments (K, 6, M, M, 2) float32 seen from the positions; the look-up
    measures a point's distance from the grid's position, at most a tenth of a spacing beyond
    an escaped sample's).
    """
    found = []
    for job in looks(spec, size, near, far):
        found.append(look(job, surfaces))
        yield
    return _placed(found)


def _placed(found: list) -> tuple:
    """``escape``'s result from its samples' ``look`` results."""
    points, ratios, moved, depth = zip(*found, strict=True)
    return (np.stack(points), np.array(ratios, np.float64), int(sum(moved)),
            np.stack(depth))


@dataclass(frozen=True)
class Shot:
    """One capture (``CaptureFn``) of a bake: at ``position`` (3,), metres, faces of ``size``
    texels, clip distances ``near`` and ``far``, for a probe of ``kind``."""

    position: np.ndarray
    size: int
    near: float
    far: float
    kind: str


def shoot(job: Shot, capture: CaptureFn, seen: Probes) -> tuple[np.ndarray, dict | None]:
    """A capture lit by the probes ``seen``, as the bake keeps it: (SH (9, 3) float32, the
    prefiltered chains of a reflection probe or None)."""
    cube = capture(job.position, job.size, job.near, job.far, seen, job.kind)
    if job.kind == "reflection":
        c, chains = filtered(cube)
        return np.asarray(c, np.float32), chains
    return np.asarray(_sh_of_cube(cube), np.float32), None


class Here:
    """A bake's captures run here, one after the other (``Bake.runner``). Another runner
    (a cluster's) has the same two generators: each yields the number of jobs finished so far
    and returns their results in the jobs' order."""

    def __init__(self, capture: CaptureFn, surfaces: SurfacesFn | None):
        self.capture, self.surfaces = capture, surfaces

    def looks(self, jobs: list[Look]) -> Iterator[int]:
        """``look`` of each of ``jobs``."""
        out = []
        for job in jobs:
            out.append(look(job, self.surfaces))
            yield len(out)
        return out

    def shots(self, jobs: list[Shot], seen: Probes) -> Iterator[int]:
        """``shoot`` of each of ``jobs``, lit by ``seen``."""
        out = []
        for job in jobs:
            out.append(shoot(job, self.capture, seen))
            yield len(out)
        return out


@dataclass
class Bake:
    """A bake of ``specs`` in the scene whose ``world`` is given, through ``capture``.

    bounces:          light bounces (>= 1; see the module docstring)
    converge:         the bounces after the last estimated from the last ones (``series``;
                      with 3 bounces or more: the first holds the direct light, whose ratio
                      to the second says little of the later ones)
    face_size:        cube face size of reflection probes' captures, texels
    volume_face_size: cube face size of irradiance volumes' captures, texels
    runner:           where the captures run (``Here`` by default, through ``capture`` and
                      ``surfaces``; a cluster's runner has the same generators)
    results:          filled by ``steps()`` once every bounce is done
    """

    specs: list[ProbeSpec]
    world: World
    capture: CaptureFn
    bounces: int = 1
    converge: bool = False
    face_size: int = 128
    volume_face_size: int = 16
    surfaces: SurfacesFn | None = None
    runner: object | None = None
    results: list[BakedProbe] = field(default_factory=list)

    @property
    def converged(self) -> bool:
        """Whether the bounces after the last are estimated (``converge`` with 3 bounces or
        more)."""
        return self.converge and self.bounces >= 3

    def _clip(self, spec: ProbeSpec) -> tuple[float, float]:
        near = max(float(spec.clip_start), 1e-3)
        return near, max(float(spec.clip_end), 2.0 * near)

    def steps(self) -> Iterator[float]:
        """Run the bake, yielding the finished fraction in (0, 1] after every capture (and
        every volume sample's look at its surroundings); closing the generator early (cancel)
        leaves ``results`` empty."""
        runner = self.runner or Here(self.capture, self.surfaces)
        volumes = ([k for k, s in enumerate(self.specs) if s.kind == "irradiance"]
                   if self.surfaces or self.runner else [])
        total = (max(1, self.bounces) * sum(len(s.points) for s in self.specs)
                 + sum(len(self.specs[k].points) for k in volumes))
        done = [0]

        def counted(work):  # ``work``'s results, its finished jobs counted into the fraction
            start = done[0]
            while True:
                try:
                    finished = next(work)
                except StopIteration as end:
                    return end.value
                done[0] = start + finished
                yield done[0] / total

        placed = {}  # spec index -> (positions, ratios, moved, moments)
        jobs = [looks(self.specs[k], self.volume_face_size, *self._clip(self.specs[k]))
                for k in volumes]
        found = yield from counted(runner.looks([j for part in jobs for j in part]))
        first = 0
        for k, part in zip(volumes, jobs, strict=True):
            placed[k] = _placed(found[first:first + len(part)])
            first += len(part)
        lighting = world_probes(self.world)
        results: list[BakedProbe] = []
        history: list[list[BakedProbe]] = []  # the last three bounces' results
        for _ in range(max(1, self.bounces)):
            found_probes: dict[int, BakedProbe] = {}
            baked = world_probes(self.world)
            # the volumes first: a bounce's reflection probes see the surfaces lit by this
            # bounce's volumes, as a frame does (the same number of diffuse bounces)
            for kind in ("irradiance", "reflection"):
                ks = [k for k, s in enumerate(self.specs) if s.kind == kind]
                if not ks:
                    continue
                size = self.face_size if kind == "reflection" else self.volume_face_size
                seen = lighting if kind == "irradiance" else replace(
                    lighting, volumes=list(baked.volumes))
                where = {k: placed.get(k, (self.specs[k].points, None, 0, None)) for k in ks}
                shots = [Shot(p, size, *self._clip(self.specs[k]), kind)
                         for k in ks for p in where[k][0]]
                taken = yield from counted(runner.shots(shots, seen))
                first = 0
                for k in ks:
                    spec = self.specs[k]
                    _, ratios, moved, depth = where[k]
                    mine = taken[first:first + len(where[k][0])]
                    first += len(mine)
                    coeffs, validity = np.stack([c for c, _ in mine]), None
                    chains = mine[-1][1]
                    if ratios is not None:
                        res = tuple(spec.resolution)
                        dilated, validity = dilate(coeffs.reshape(*res, 9, 3),
                                                   ratios.reshape(res), spec.volume)
                        coeffs, validity = dilated.reshape(-1, 9, 3), validity.reshape(-1)
                    result = BakedProbe(spec, coeffs, chains, size, validity, moved, depth)
                    found_probes[k] = result
                    probe = spec.probe(result.coeffs, chains, validity, depth)
                    (baked.reflection if kind == "reflection" else baked.volumes).append(probe)
            results = [found_probes[k] for k in range(len(self.specs))]
            if self.converged:
                history = [*history[-2:], results]
            lighting = baked
        if self.converged:
            results = _converged(*history)
        self.results = results


def _converged(before: list[BakedProbe], previous: list[BakedProbe],
               last: list[BakedProbe]) -> list[BakedProbe]:
    """The bake after every bounce, from its last bounces' results: each probe's SH and
    chains plus their last increment continued as a geometric series (``series``; the ratio
    of the last two increments of the volumes' SH DC terms, summed per channel, or of the
    reflection probes' without volumes: theirs run a bounce ahead, lit by the same bounce's
    volumes)."""
    volumes = [k for k, r in enumerate(last) if r.spec.kind == "irradiance"]

    def dc(results):
        return sum(results[k].coeffs[:, 0].sum(0, dtype=np.float64)
                   for k in (volumes or range(len(results))))

    k = series.tail_factor(dc(last) - dc(previous), dc(previous) - dc(before))
    k32 = k.astype(np.float32)
    out = []
    for a, b in zip(last, previous, strict=True):
        chains = None if a.chains is None else {
            name: [hi + np.maximum(hi - lo, 0.0) * k32
                   for hi, lo in zip(levels, b.chains[name], strict=True)]
            for name, levels in a.chains.items()}
        out.append(replace(a, coeffs=a.coeffs + (a.coeffs - b.coeffs) * k32, chains=chains))
    return out


def metadata(baked: BakedProbe, backend: str, bounces: int, bake_time: str, seconds: float,
             version: str, converged: bool = False) -> dict:
    """The metadata of a probe file (``probe_file.write``): what the bake depends on
    (``ProbeSpec.describe``), how it was made and when (``converged``: the bounces after the
    last estimated, ``Bake.converge``)."""
    meta = {**baked.spec.describe(), "face_size": baked.face_size,
            "filters": dict(FILTERS) if baked.chains else {}, "backend": backend,
            "bounces": bounces, "bake_time": bake_time, "bake_seconds": round(seconds, 3),
            "version": version}
    if converged:
        meta["converged"] = True
    if baked.validity is not None:
        meta["invalid_samples"] = np.flatnonzero(baked.validity < 0.5).tolist()
        meta["escaped_samples"] = int(baked.escaped)
    return meta
