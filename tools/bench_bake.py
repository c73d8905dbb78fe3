"""Benchmark of probe baking: prefiltered mip chains, and one whole probe bake.

Usage: python tools/bench_bake.py [--sizes 128 256] [--repeat 3] [--workers 2]

Prints, for each face size, the time of the full prefiltered mip chain (S, S/2, ..., 1) of one
cube map, prefilter only (no capture, no SH):

- BO2: ``prefilter.prefilter_cosine_power`` (Lazarov 2013, slide "Improved environment map
  pre-filtering"), against this project's target (256: 1 s on a 2-core machine);
- BO1: ``prefilter.prefilter_angular_gaussian`` (CubeMapGen's angular Gaussian with its default
  angles, slide "Black Ops: environment map pre-filtering").

"cold" is the first call in the process (it builds and caches the per-size geometry tables),
"warm" the best of ``--repeat`` further calls. The input is an analytic environment with detail
(a gradient, bright caps, one across a cube corner) so that no shortcut applies.

Anchors, from the cmft README ("Performance"): a 256 -> 256 Phong radiance filter with mips,
CPU only on a 4-core desktop, takes 8.6 s with cmft and 87.7 s with AMD CubeMapGen; the ratio
printed is anchor time / our time (above 1: faster than the anchor, on different hardware).

``time_probe_bake`` times one whole probe: the capture of its six faces by the engine (a
40k-triangle scene with a sun and a point light and their shadow maps), the SH projection and
both prefiltered chains.
"""

from __future__ import annotations

import argparse
import os
import platform
import time

import numpy as np

from bo2_lighting.addon.core.formulas import cubemap, prefilter

TARGETS_BO2 = {256: 1.0}  # seconds, full chain, this project's goals (2 cores)
TARGETS_PROBE = {128: 0.5}  # seconds, one whole probe
ANCHOR_SIZE = 256
ANCHORS = (("cmft (4-core CPU)", 8.6), ("AMD CubeMapGen", 87.7))  # seconds, 256 -> 256 Phong


def environment(size: int) -> np.ndarray:
    """(6, S, S, 3) float32 test environment: gradient plus bright caps, at texel centres."""
    d = cubemap.texel_directions(size).astype(np.float64)
    lum = 0.3 + 0.2 * d[..., 0] + 0.1 * d[..., 2]
    for centre, cos_radius, boost in (([0.3, 0.5, 0.81], 0.95, 5.0), ([1, 1, 1], 0.98, 8.0),
                                      ([0.1, -1, 0.05], 0.995, 20.0)):
        c = np.array(centre, float) / np.linalg.norm(centre)
        lum = lum + boost * (d @ c > cos_radius)
    return np.stack([lum, 1.5 * lum, 0.5 + 0.1 * d[..., 1]], -1).astype(np.float32)


def timed(fn, repeat: int) -> tuple[float, float]:
    """(cold, warm): the first call's time and the best of ``repeat`` more, in seconds."""
    t = time.perf_counter()
    fn()
    cold = time.perf_counter() - t
    warm = []
    for _ in range(repeat):
        t = time.perf_counter()
        fn()
        warm.append(time.perf_counter() - t)
    return cold, min(warm) if warm else cold


# ---------------------------------------------------------------------------------------------
# one whole probe bake (capture of six faces, SH projection, both prefiltered chains)


def probe_scene():
    """A core scene of about 40k triangles: a floor, two walls and 16 spheres (numpy only),
    lit by a sun (cascaded shadow map) and a point light (cube shadow map)."""
    from bo2_lighting.addon.core.scene import Light, Material, MeshBatch, RenderSettings, Scene

    def quad(corner, u, v):
        c, u, v = (np.asarray(a, np.float32) for a in (corner, u, v))
        p = np.array([[c, c + u, c + u + v], [c, c + u + v, c + v]], np.float32)
        n = np.broadcast_to(np.cross(u, v) / np.linalg.norm(np.cross(u, v)), p.shape)
        return p, n.astype(np.float32)

    def sphere(centre, radius, rings=48, segments=96):
        th = np.linspace(0, np.pi, rings + 1)
        ph = np.linspace(0, 2 * np.pi, segments + 1)
        t, f = np.meshgrid(th, ph, indexing="ij")
        d = np.stack([np.sin(t) * np.cos(f), np.sin(t) * np.sin(f), np.cos(t)], -1)
        a, b, c, e = d[:-1, :-1], d[1:, :-1], d[1:, 1:], d[:-1, 1:]
        n = np.concatenate([np.stack([a, b, c], 2), np.stack([a, c, e], 2)]).reshape(-1, 3, 3)
        return (centre + radius * n).astype(np.float32), n.astype(np.float32)

    parts = [quad((-5, -5, 0), (10, 0, 0), (0, 10, 0)), quad((-5, 5, 0), (10, 0, 0), (0, 0, 4)),
             quad((-5, -5, 0), (0, 0, 4), (0, 10, 0))]
    parts += [sphere(np.array([-3 + 2 * (i % 4), -3 + 2 * (i // 4), 0.5]), 0.5)
              for i in range(16)]
    meshes = [MeshBatch(p, n, np.full(len(p), i % 3, np.int32)) for i, (p, n) in enumerate(parts)]
    mats = [Material.talk(albedo=np.array(c, np.float32)) for c in
            ((0.7, 0.7, 0.7), (0.8, 0.1, 0.1), (0.2, 0.4, 0.8))]
    sun = np.array([0.3, 0.5, -0.8]) / np.linalg.norm([0.3, 0.5, -0.8])
    lights = [Light("SUN", color=np.full(3, 3.0), direction=sun),
              Light("POINT", color=np.full(3, 500.0), position=np.array([1.0, 0.0, 3.0]))]
    from bo2_lighting.addon.core.scene import Camera

    cam = Camera(world_to_camera=np.eye(4), projection=np.eye(4), width=1, height=1)
    return Scene(camera=cam, meshes=meshes, materials=mats, lights=lights,
                 settings=RenderSettings(samples=4))


def time_probe_bake(size: int, repeat: int, workers: int) -> tuple[float, float]:
    """Capture (six faces rendered by the engine, 4 samples, shadows) + SH + both prefiltered
    chains of one reflection probe of face size ``size``: (cold, warm) seconds."""
    from bo2_lighting.addon.core.bakes import capture
    from bo2_lighting.addon.core.lighting.world_probes import filtered
    from bo2_lighting.addon.core.render.job import RenderJob

    scene = probe_scene()
    scene.settings.threads = workers

    def bake():
        cube = capture.Capture(RenderJob(scene)).cube(np.array([0.0, 0.0, 1.5]), size, 0.05, 1e4)
        filtered(cube)

    return timed(bake, repeat)


# ---------------------------------------------------------------------------------------------


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--sizes", type=int, nargs="+", default=[128, 256])
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument("--workers", type=int, default=2)
    args = parser.parse_args()

    load = os.getloadavg() if hasattr(os, "getloadavg") else (float("nan"),) * 3
    print(f"machine: {platform.processor() or platform.machine()}, {os.cpu_count()} cores, "
          f"load average {load[0]:.2f}; numpy {np.__version__}; workers {args.workers}")
    print("prefilter only, full mip chain (S .. 1), 3 channels, seconds: cold / warm (best of "
          f"{args.repeat})")
    results = {}
    for size in args.sizes:
        cube = environment(size)
        for name, fn in (
            ("BO2 cosine power", lambda c=cube: prefilter.prefilter_cosine_power(
                c, workers=args.workers)),
            ("BO1 angular Gaussian", lambda c=cube: prefilter.prefilter_angular_gaussian(
                c, workers=args.workers)),
        ):
            cold, warm = timed(fn, args.repeat)
            results[(name, size)] = warm
            line = f"  {name:22s} {size:4d}: {cold:6.3f} / {warm:6.3f}"
            if name.startswith("BO2") and size in TARGETS_BO2:
                goal = TARGETS_BO2[size]
                line += f"   target {goal:.0f} s: {'met' if warm <= goal else 'MISSED'}"
            print(line)

    if any(size == ANCHOR_SIZE for size in args.sizes):
        print(f"anchors ({ANCHOR_SIZE} -> {ANCHOR_SIZE} Phong with mips, cmft README), "
              "ratio = anchor / ours (warm):")
        for name in ("BO2 cosine power", "BO1 angular Gaussian"):
            ours = results[(name, ANCHOR_SIZE)]
            ratios = ", ".join(f"{label} {anchor:.1f} s -> x{anchor / ours:.1f}"
                               for label, anchor in ANCHORS)
            print(f"  {name:22s} {ours:6.3f} s: {ratios}")

    print("one probe (capture + SH + prefilter):")
    for size in args.sizes:
        bake = time_probe_bake(size, args.repeat, args.workers)
        goal = TARGETS_PROBE.get(size)
        verdict = "" if goal is None else \
            f"   target {goal:.1f} s: {'met' if bake[1] <= goal else 'MISSED'}"
        print(f"  {size:4d}: {bake[0]:6.3f} / {bake[1]:6.3f}{verdict}")
    print("  (40k triangles, sun and point light with shadow maps, 4 samples; both chains)")


if __name__ == "__main__":
    main()
