"""``bo2 prefilter``: an environment image prefiltered into a cube map mip chain for a game engine
(OpenEXR, DDS, KTX2), with the talk's filters and cmft's; the core alone, no Blender."""

from __future__ import annotations

import json
import sys
import time
from pathlib import Path

import numpy as np

from . import BadInput
from .patterns import overwrites_input
from .terminal import progress_bar

FILTERS = ("bo2", "bo1", "phong", "phongbrdf", "blinn", "blinnbrdf")
MAX_SIZE = 4096  # face size of mip 0 (a 4096 cube is 805 MiB of float32 RGB)
HALF_MAX = 65504.0  # the largest finite half float


def read_cube(paths: list[str], size: int | None):
    """The cube map (``cubemap.FACES``) of one lat-long or cross image or six faces; BadInput
    for what cannot be read."""
    from ..core.files import environment_files as ef

    try:
        images = [ef.read_image(p) for p in paths]
        for path, image in zip(paths, images, strict=True):
            if min(image.shape[:2]) < 2 and len(paths) == 1:
                raise ef.ImageError(f"{path}: a {image.shape[1]} x {image.shape[0]} image is "
                                    "too small for an environment")
            bad = int((~np.isfinite(image)).any(axis=-1).sum())
            if bad:
                print(f"bo2: warning: {path}: {bad} texels are NaN or infinite; read as 0",
                      file=sys.stderr)
            negative = int((image[..., :3] < 0.0).any(axis=-1).sum())
            if negative:  # no radiance is negative: a filter would spread them as darkness
                print(f"bo2: warning: {path}: {negative} texels are negative; read as 0",
                      file=sys.stderr)
        return np.maximum(ef.to_cube(images, size), 0.0)
    except ef.ImageError as exc:
        raise BadInput(str(exc)) from None


def _warn_half_float(outputs: list[Path], mips: list[np.ndarray], scale: float) -> None:
    """One warning when KTX2 or DDS outputs (RGBA16F) clip texels above 65504."""
    if not any(o.suffix.lower() in (".ktx2", ".dds") for o in outputs):
        return
    over = sum(int((m[..., :3] > HALF_MAX).any(axis=-1).sum()) for m in mips)
    if over:
        peak = max(float(m[..., :3].max()) for m in mips)
        fit = scale * HALF_MAX / peak
        step = 10.0 ** (np.floor(np.log10(fit)) - 2)  # three digits, rounded down: it fits
        fit = np.floor(fit / step) * step
        print(f"bo2: warning: {over} texels are above {HALF_MAX:g}, the largest half float of "
              f"KTX2 and DDS, and are clipped there (the brightest is {peak:.7g}; the JSON's "
              f"SH keeps the real values); --scale {fit:.3g} brings every texel under it",
              file=sys.stderr)


def run(args) -> int:
    """Prefilter IMAGE (or six faces) into ``-o`` files."""
    from ..core.files import engine_export
    from ..core.formulas import prefilter

    outputs = [Path(o) for o in args.output]
    if why := overwrites_input(args.images, outputs):
        raise BadInput(why)
    for out in outputs:
        if out.suffix.lower().lstrip(".") not in engine_export.FORMATS:
            raise BadInput(f"{out}: unknown format; use .ktx2, .dds or .exr")
        if not out.parent.is_dir():
            raise BadInput(f"{out.parent}: no such folder")
    if len(args.images) not in (1, 6):
        raise BadInput(f"give one lat-long or cross image, or six face images (+X -X +Y -Y +Z "
                       f"-Z), not {len(args.images)}")
    if args.size is not None and (args.size > MAX_SIZE or args.size & (args.size - 1)):
        raise BadInput(f"--size {args.size}: a power of two up to {MAX_SIZE}")
    if args.filter == "bo1" and args.edge_fixup == "warp":
        raise BadInput("--edge-fixup warp needs a filter that reads the input for every mip "
                       "(bo2 or cmft's); bo1's cascade filters each mip from the previous one")
    size = args.size or (prefilter.top_resolution() if args.filter == "bo2" else None)
    start = time.perf_counter()
    cube = read_cube(args.images, size) * np.float32(args.scale)
    size = cube.shape[1]
    full = size.bit_length()
    count = args.mips or full
    if count > full:
        raise BadInput(f"--mips {count}: a face of {size} has at most {full} mips")
    if args.filter == "bo2":
        powers = prefilter.cmft_powers(count, 13.0, 0.0, "blinn")
    elif args.filter != "bo1":
        powers = prefilter.cmft_powers(count, args.gloss_scale, args.gloss_bias, args.filter)
    terminal = sys.stderr
    done = [0]

    def tick() -> bool:
        progress_bar(terminal, done[0] / count, start)
        done[0] += 1
        return False

    if args.filter == "bo1":
        mips = prefilter.prefilter_angular_gaussian(cube, warp=args.edge_fixup == "warp")
        mips = mips[:count]
        _, sigmas = prefilter.angular_gaussian_angles(size)
        powers = [1.0 / max(np.radians(s), 1e-6) ** 2 for s in sigmas[:count]]
    else:
        mips = prefilter.prefilter_powers(cube, powers, warp=args.edge_fixup == "warp",
                                          exclude_base=args.exclude_base, should_stop=tick)
    progress_bar(terminal, 1.0, start)
    terminal.write("\n")
    meta = engine_export.chain_metadata(
        args.filter, powers, size, engine_export.cube_sh(cube),
        source=str(Path(args.images[0]).name), edge_fixup=args.edge_fixup,
        exclude_base=bool(args.exclude_base), **({"scale": args.scale} if args.scale != 1.0
                                                 else {}),
        **({"gloss_scale": args.gloss_scale, "gloss_bias": args.gloss_bias}
           if args.filter not in ("bo2", "bo1") else {}))
    if args.filter == "bo1":
        meta["mip_phong_power_note"] = "BO1 mips are angular Gaussians: power ~ 1 / sigma^2"
    _warn_half_float(outputs, mips, args.scale)
    written = []
    for out in outputs:
        try:
            written += engine_export.write_chain(out, mips, meta)
        except OSError as exc:
            raise BadInput(f"{out}: cannot write ({exc.strerror})") from None
    seconds = time.perf_counter() - start
    if args.json:
        print(json.dumps({"files": [str(p) for p in written], "seconds": round(seconds, 3),
                          **meta}))
    else:
        print(f"prefiltered {args.images[0]} ({args.filter}, {count} mips of {size} to "
              f"{size >> (count - 1)}) in {seconds:.2f} s: {', '.join(map(str, written))}")
    return 0
