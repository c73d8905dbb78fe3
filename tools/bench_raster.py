"""Benchmark of the NumPy rasterizer (``addon/core/render/raster.py``): speed and peak memory.

Usage: python tools/bench_raster.py [--repeat N]

Cases: 1e5 small random triangles and a 1e5-triangle screen-filling grid mesh at 1920x1080; the
same scenes seen through one 514x514 tile of the 1920x1080 frame (a 512x512 render tile and its
one-pixel margin, as the renderer rasterizes them: most triangles lie outside the tile), with a
sample offset and back-face culling; a 1024x1024 shadow-map face of the grid mesh; and one
full-screen quad at 3840x2160 and 7680x4320. For each case it prints the best wall time of
``--repeat`` runs of a new input ("cold": with the set-up) and of the same input once more
("warm": ``rasterize`` reuses the set-up of the last input, as for the second and later samples
of a tile), triangles/s of the cold time and image pixels/s of the warm time, the share of
pixels covered, and the peak of NumPy's allocations during one more cold run, traced with
``tracemalloc`` (the output Fragments included: 20 bytes per pixel). Prints figures only.
"""

from __future__ import annotations

import argparse
import time
import tracemalloc

import numpy as np

from bo2_lighting.addon.core.render import raster, visibility


def window_to_clip(pts, width, height, z, w):
    """Window coordinates (..., 2), pixels from the top-left corner -> clip space (..., 4)."""
    xn = 2.0 * pts[..., 0] / width - 1.0
    yn = 1.0 - 2.0 * pts[..., 1] / height
    return np.stack([xn * w, yn * w, z * w, w], axis=-1).astype(np.float32)


def random_triangles(n, width, height, size=8.0, seed=0):
    """(n, 3, 4) triangles about ``size`` pixels across at random places, depths and w."""
    rng = np.random.default_rng(seed)
    pts = rng.uniform([0, 0], [width, height], (n, 1, 2)) + rng.uniform(-size, size, (n, 3, 2))
    z = rng.uniform(-0.9, 0.9, (n, 3))
    w = rng.uniform(1.0, 4.0, (n, 3))
    return window_to_clip(pts, width, height, z, w)


def grid_mesh(n_tri, width, height, seed=0):
    """A jittered grid of about ``n_tri`` triangles filling the screen, tilted in depth."""
    rng = np.random.default_rng(seed)
    nx = int(np.sqrt(n_tri / 2 * width / height))
    ny = int(n_tri / 2 / nx)
    gx, gy = np.meshgrid(np.linspace(0, width, nx + 1), np.linspace(0, height, ny + 1))
    pts = np.stack([gx, gy], -1)
    pts[1:-1, 1:-1] += rng.uniform(-0.3, 0.3, pts[1:-1, 1:-1].shape) * (width / nx)
    w = 1.0 + 3.0 * pts[..., 1] / height
    corners = window_to_clip(pts, width, height, 0.5 - 0.4 * pts[..., 1] / height, w)
    corners = corners.reshape(-1, 4)
    a = (np.arange(ny)[:, None] * (nx + 1) + np.arange(nx)[None, :]).ravel()
    b = a + nx + 1
    tris = np.concatenate([np.stack([a, b, b + 1], 1), np.stack([a, b + 1, a + 1], 1)])
    return corners[tris]


def full_screen_quad():
    """Two triangles covering the whole screen at z_ndc = 0.5."""
    c = np.array([[-1, -1, 0.5, 1], [1, -1, 0.5, 1], [1, 1, 0.5, 1], [-1, 1, 0.5, 1]], np.float32)
    return c[[[0, 1, 2], [0, 2, 3]]]


def run_case(name, clip, width, height, repeat, **kw):
    def flush():  # rasterize another input: ``rasterize`` keeps the set-up of the last one only
        raster.rasterize(np.zeros((1, 3, 4), np.float32), 1, 1)

    cold = warm = np.inf
    for _ in range(repeat):
        flush()
        start = time.perf_counter()
        frags = raster.rasterize(clip, width, height, **kw)
        cold = min(cold, time.perf_counter() - start)
        del frags
        start = time.perf_counter()  # the same input again, as for the next sample of a tile
        frags = raster.rasterize(clip, width, height, **kw)
        warm = min(warm, time.perf_counter() - start)
    covered = float(raster.coverage(frags).mean())
    del frags
    flush()
    tracemalloc.start()
    frags = raster.rasterize(clip, width, height, **kw)
    peak = tracemalloc.get_traced_memory()[1]
    tracemalloc.stop()
    del frags
    n_tri, n_pix = len(clip), width * height
    print(
        f"{name:<34} {width:>5}x{height:<5} {n_tri:>8} {cold:>8.3f} {warm:>8.3f} "
        f"{n_tri / cold:>10.3e} {n_pix / warm:>10.3e} {covered:>7.1%} {peak / 2**20:>8.0f}"
    )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=3, help="timed runs per case (best kept)")
    args = parser.parse_args()
    print(
        f"{'case':<34} {'size':>11} {'tris':>8} {'cold s':>8} {'warm s':>8} {'tris/s':>10} "
        f"{'pixels/s':>10} {'covered':>7} {'peak MiB':>8}"
    )
    run_case(
        "1e5 random triangles, ~8 px",
        random_triangles(100_000, 1920, 1080),
        1920,
        1080,
        args.repeat,
    )
    grid = grid_mesh(100_000, 1920, 1080)
    run_case("1e5-triangle grid mesh", grid, 1920, 1080, args.repeat)
    tile = (703, 283, 1217, 797)  # a 512x512 tile near the centre and its one-pixel margin
    for name, clip in (("random", random_triangles(100_000, 1920, 1080)), ("grid mesh", grid)):
        cull = np.random.default_rng(1).random(len(clip)) < 0.5
        in_tile, index = visibility.tile_clip(clip, 1920, 1080, tile)
        run_case(
            f"1e5 {name}, 514 px tile, culled",
            in_tile,
            514,
            514,
            args.repeat,
            cull=cull[index],
            sample_offset=(0.83, 0.21),
        )
    run_case("grid mesh, shadow-map face", grid, 1024, 1024, args.repeat)
    run_case("full-screen quad", full_screen_quad(), 3840, 2160, args.repeat)
    run_case("full-screen quad", full_screen_quad(), 7680, 4320, max(1, args.repeat - 1))


if __name__ == "__main__":
    main()
