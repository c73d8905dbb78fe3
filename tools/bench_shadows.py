"""Benchmark of the shadow maps (``addon/core/render/shadows.py``): build and query time, peak
memory.

Usage: python tools/bench_shadows.py [--points N] [--triangles N] [--resolutions 1024 2048]
                                     [--order random|screen] [--blend FILE ...]

Scene: ~1e5 random small triangles (0.05-0.2 m) scattered over a 20 x 20 x 3 m volume above a
ground quad, seen by a camera from 14 m away. Query points: N points on the casters' surfaces
(half on the ground, half on the random triangles) with their geometric normals, as a G-buffer
would give them, in random order (default) or, with ``--order screen``, in the order a tiled
renderer shades them (by 512-pixel tile, then pixel row and column; points off screen last),
so that neighbouring queries read neighbouring texels. Cases: cube map (point light, hard and
soft), spot map (soft), sun cascades (hard and soft), at each resolution. For each case it
prints the wall time of building the maps and of one query of all points, the time per query
point, the maps' size, and the peak of NumPy's allocations during one more build and one more
query traced with ``tracemalloc`` (the query's peak counts the maps it reads), and the
pyramid's saving on soft shadows: the share of soft-shadowed points whose search region the
pyramid proves lit or dark (no blocker search: "proven"), the time per point with that test
off ("no skip": every such point searches) and whether both give the same bits ("same").
With ``--blend``, the same saving on scenes as F12 prepares them: points spread over each
file's surfaces by area, every light's map (the random scene's small casters leave few search
regions empty; a room's walls and floor many). Prints figures only.
"""

from __future__ import annotations

import argparse
import time
import tracemalloc
from pathlib import Path

import numpy as np

from bo2_lighting.addon.core.kernels import shadows as filter_kernel
from bo2_lighting.addon.core.render import shadow_filter, shadows
from bo2_lighting.addon.core.scene import Camera, Light


def random_scene(n_tri: int, seed: int = 0) -> np.ndarray:
    """(n_tri + 2, 3, 3) float32 triangles: random small ones in a volume, and a ground quad."""
    rng = np.random.default_rng(seed)
    centre = rng.uniform([-10.0, -10.0, 0.0], [10.0, 10.0, 3.0], (n_tri, 1, 3))
    size = rng.uniform(0.05, 0.2, (n_tri, 1, 1))
    tris = centre + size * rng.normal(size=(n_tri, 3, 3)) / np.sqrt(3.0)
    g = 12.0
    quad = np.array([[[-g, -g, 0], [g, -g, 0], [g, g, 0]], [[-g, -g, 0], [g, g, 0], [-g, g, 0]]])
    return np.concatenate([tris, quad]).astype(np.float32)


def surface_points(tris: np.ndarray, count: int, seed: int = 1):
    """(count, 3) points on the ground and the triangles, and (count, 3) unit normals."""
    rng = np.random.default_rng(seed)
    half = count // 2
    ground = np.zeros((half, 3), np.float32)
    ground[:, :2] = rng.uniform(-10.0, 10.0, (half, 2))
    ground_n = np.tile(np.float32([0.0, 0.0, 1.0]), (half, 1))
    pick = rng.integers(0, len(tris) - 2, count - half)
    bary = rng.dirichlet(np.ones(3), count - half).astype(np.float32)
    on_tri = np.einsum("nk,nkc->nc", bary, tris[pick])
    normal = np.cross(tris[pick, 1] - tris[pick, 0], tris[pick, 2] - tris[pick, 0])
    normal /= np.linalg.norm(normal, axis=1, keepdims=True)
    return (
        np.concatenate([ground, on_tri]).astype(np.float32),
        np.concatenate([ground_n, normal]).astype(np.float32),
    )


def screen_order(points: np.ndarray, cam: Camera, tile: int = 512) -> np.ndarray:
    """Permutation of (N, 3) points into the order of a tiled renderer: by ``tile``-pixel tile
    (row-major), then by pixel row and column; points off screen last, in their order."""
    homog = np.concatenate([points, np.ones((len(points), 1), np.float32)], 1)
    clip = homog.astype(np.float64) @ (cam.projection @ cam.world_to_camera).T
    with np.errstate(divide="ignore", invalid="ignore"):
        x = np.floor((clip[:, 0] / clip[:, 3] + 1.0) * 0.5 * cam.width)
        y = np.floor((1.0 - clip[:, 1] / clip[:, 3]) * 0.5 * cam.height)
    on = (clip[:, 3] > 0) & (x >= 0) & (x < cam.width) & (y >= 0) & (y < cam.height)
    tiles_x = -(-cam.width // tile)
    key = np.full(len(points), np.iinfo(np.int64).max, np.int64)
    xi, yi = x[on].astype(np.int64), y[on].astype(np.int64)
    key[on] = ((yi // tile) * tiles_x + xi // tile) * tile * tile + (yi % tile) * tile + xi % tile
    return np.argsort(key, kind="stable")


def camera() -> Camera:
    """A 1920x1080 perspective camera 14 m from the scene centre, looking at it."""
    return Camera.look_at([0.0, -12.0, 7.0], [0.0, 0.0, 0.0], np.radians(50.0), 1920, 1080)


def lights() -> list[tuple[str, Light]]:
    pos = np.array([2.0, -1.0, 6.0])
    sun_dir = np.array([0.4, 0.3, -0.85]) / np.linalg.norm([0.4, 0.3, -0.85])
    return [
        ("point, cube, hard", Light("POINT", np.ones(3), position=pos)),
        ("point, cube, R = 0.25 m", Light("POINT", np.ones(3), position=pos, radius=0.25)),
        (
            "spot 120 deg, R = 0.1 m",
            Light("SPOT", np.ones(3), position=pos, direction=np.array([0.0, 0.0, -1.0]),
                  spot_size=np.radians(120.0), radius=0.1),
        ),
        ("sun, hard", Light("SUN", np.ones(3), direction=sun_dir)),
        ("sun, 2 deg", Light("SUN", np.ones(3), direction=sun_dir, radius=np.radians(2.0))),
    ]


def run_case(name, light, tris, cam, points, normals, res) -> None:
    start = time.perf_counter()
    sm = shadows.build_shadow_map(light, tris, cam, resolution=res)
    t_build = time.perf_counter() - start
    how = np.empty(len(points), np.uint8)
    start = time.perf_counter()
    vis = shadow_filter.shadow_visibility(sm, points, normals, how=how)
    t_query = time.perf_counter() - start
    start = time.perf_counter()
    searched = shadow_filter.shadow_visibility(sm, points, normals, skip=False)
    t_search = time.perf_counter() - start
    same = np.array_equal(vis.view(np.uint32), searched.view(np.uint32))
    soft = int(np.isin(how, (filter_kernel.HOW_PROVEN, filter_kernel.HOW_SEARCHED)).sum())
    proven = int((how == filter_kernel.HOW_PROVEN).sum())
    lit = float(vis.mean())
    maps, faces = sm.nbytes, sm.depth.shape[0]
    del vis, sm
    tracemalloc.start()
    sm = shadows.build_shadow_map(light, tris, cam, resolution=res)
    peak_build = tracemalloc.get_traced_memory()[1]
    tracemalloc.reset_peak()
    vis = shadow_filter.shadow_visibility(sm, points, normals)
    peak_query = tracemalloc.get_traced_memory()[1]
    tracemalloc.stop()
    del vis, sm
    n = len(points)
    print(
        f"{name:<26} {res:>5} {faces:>5} {t_build:>8.2f} {t_query:>8.2f} "
        f"{t_query / n * 1e6:>8.2f} {lit:>6.3f} {maps / 2**20:>8.1f} "
        f"{peak_build / 2**20:>10.0f} {peak_query / 2**20:>10.0f} "
        f"{(f'{proven / soft:.1%}' if soft else '-'):>7} {t_search / n * 1e6:>9.2f} "
        f"{'yes' if same else 'NO':>5}"
    )


def blend_cases(paths: list[str], count: int) -> None:
    """The pyramid's saving on scenes as F12 prepares them (``bpy``): ``count`` points spread
    over each .blend's surfaces by area with their geometric normals, every light's map."""
    import bpy

    import bo2_lighting
    from bo2_lighting.addon.blender import extract, settings
    from bo2_lighting.addon.core.render import pipeline
    from bo2_lighting.addon.core.render.job import RenderJob

    bo2_lighting.register()
    print(f"{'scene, light':<34} {'soft points':>11} {'proven':>7} {'us/point':>8} "
          f"{'no skip':>8} {'same':>5}")
    for path in paths:
        bpy.ops.wm.open_mainfile(filepath=str(path), load_ui=False)
        scene = bpy.context.scene
        scene.render.engine = "BO2_LIGHTING"
        core, _ = extract.extract_scene(bpy.context.evaluated_depsgraph_get(),
                                        settings.render_settings(scene, "FINAL"), indirect=False)
        frame = pipeline.prepare(RenderJob(core))
        tris = np.asarray(frame.positions, np.float64)
        normal = np.cross(tris[:, 1] - tris[:, 0], tris[:, 2] - tris[:, 0])
        area = 0.5 * np.linalg.norm(normal, axis=1)
        rng = np.random.default_rng(0)
        pick = rng.choice(len(tris), count, p=area / area.sum())
        bary = rng.dirichlet(np.ones(3), count)
        points = np.einsum("nk,nkc->nc", bary, tris[pick]).astype(np.float32)
        normals = (normal[pick] / (2.0 * area[pick, None])).astype(np.float32)
        for light, sm in zip(core.lights, frame.shadow_maps, strict=False):
            if sm is None:
                continue
            how = np.empty(count, np.uint8)
            shadow_filter.shadow_visibility(sm, points, normals)  # the first query loads
            start = time.perf_counter()
            vis = shadow_filter.shadow_visibility(sm, points, normals, how=how)
            t_skip = time.perf_counter() - start
            start = time.perf_counter()
            searched = shadow_filter.shadow_visibility(sm, points, normals, skip=False)
            t_search = time.perf_counter() - start
            soft = int(np.isin(how, (filter_kernel.HOW_PROVEN, filter_kernel.HOW_SEARCHED)).sum())
            proven = int((how == filter_kernel.HOW_PROVEN).sum())
            same = np.array_equal(vis.view(np.uint32), searched.view(np.uint32))
            name = f"{Path(path).stem}, {light.kind.lower()} {light.name}"[:34]
            print(f"{name:<34} {soft:>11} {(f'{proven / soft:.1%}' if soft else '-'):>7} "
                  f"{t_skip / count * 1e6:>8.3f} {t_search / count * 1e6:>8.3f} "
                  f"{'yes' if same else 'NO':>5}")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--points", type=int, default=2_000_000, help="query points")
    parser.add_argument("--triangles", type=int, default=100_000, help="random casters")
    parser.add_argument("--resolutions", type=int, nargs="+", default=[1024, 2048])
    parser.add_argument("--order", choices=["random", "screen"], default="random",
                        help="order of the query points")
    parser.add_argument("--blend", nargs="+", default=[],
                        help=".blend files: measure the pyramid's saving on their surfaces "
                        "instead (needs bpy)")
    args = parser.parse_args()
    if args.blend:
        blend_cases(args.blend, min(args.points, 400_000))
        return
    tris = random_scene(args.triangles)
    points, normals = surface_points(tris, args.points)
    cam = camera()
    if args.order == "screen":
        order = screen_order(points, cam)
        points, normals = points[order], normals[order]
    print(f"{len(tris)} triangles, {len(points)} query points ({args.order} order)")
    print(
        f"{'case':<26} {'res':>5} {'maps':>5} {'build s':>8} {'query s':>8} {'us/point':>8} "
        f"{'lit':>6} {'maps MiB':>8} {'build MiB':>10} {'query MiB':>10} {'proven':>7} "
        f"{'no skip':>9} {'same':>5}"
    )
    for res in args.resolutions:
        for name, light in lights():
            run_case(name, light, tris, cam, points, normals, res)


if __name__ == "__main__":
    main()
