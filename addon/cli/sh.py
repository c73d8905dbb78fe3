"""``bo2 sh``: the 9 RGB SH coefficients of a lat-long image, printed and, for a game engine,
written as JSON and as a C header with the talk's tinted scalar SH. Radiance HDR and OpenEXR
files are read by the core alone (``environment_files``), other formats by Blender
(``headless.read_equirect``)."""

from __future__ import annotations

import json
import sys
from pathlib import Path

import numpy as np

from . import BadInput, CommandError
from .patterns import overwrites_input


def _head(path: Path) -> bytes:
    try:
        with open(path, "rb") as f:
            return f.read(4)
    except OSError:
        return b""


def _read(path: Path) -> np.ndarray:
    from ..core.files import environment_files as ef

    head = _head(path)
    if head[:2] == b"#?" or head == b"\x76\x2f\x31\x01" or not path.is_file():
        try:
            image = ef.read_image(path)
        except ef.ImageError as exc:
            raise BadInput(str(exc)) from None
    else:
        from ..blender import headless
        from .terminal import quiet_blender

        try:
            with quiet_blender():
                image = headless.read_equirect(path)
        except CommandError as exc:
            raise BadInput(str(exc)) from None
    if ef.layout_of_or_none(image.shape) != "latlong":
        raise BadInput(f"{path}: a {image.shape[1]} x {image.shape[0]} image is not a lat-long "
                       "(2:1) image")
    bad = ~np.isfinite(image)
    if bad.any():
        print(f"bo2: warning: {path}: {int(bad.any(axis=-1).sum())} texels are NaN or infinite; "
              "read as 0", file=sys.stderr)
        image = np.where(bad, 0.0, image).astype(np.float32)
    return image


def run(args) -> int:
    """Print the 9 RGB SH coefficients of the radiance of a lat-long (equirectangular) image;
    with ``-o`` / ``--header`` write them, and the tinted scalar SH, for an engine."""
    from ..core.files import engine_export, gpu_textures
    from ..core.formulas import sh
    from ..core.system import atomic

    path = Path(args.image)
    if why := overwrites_input([path], [o for o in (args.output, args.header) if o]):
        raise BadInput(why)
    coefficients = sh.project_equirect(_read(path))
    if args.axes == "y-up":
        coefficients = sh.rotate(coefficients, gpu_textures.Y_UP)
    record = {"image": str(args.image), **engine_export.sh_record(coefficients, args.axes)}
    record["coefficients"] = record["radiance_rgb"]
    writes = []
    if args.output:
        writes.append((Path(args.output), json.dumps(record, indent=2) + "\n"))
    if args.header:
        writes.append((Path(args.header), engine_export.sh_header(path.stem, coefficients,
                                                                  path.name, args.axes)))
    try:  # all of them or none
        atomic.replace_all([(out, lambda tmp, text=text: tmp.write_text(text, encoding="utf-8"))
                            for out, text in writes])
    except OSError as exc:
        where = exc.filename or "output"
        raise BadInput(f"{where}: cannot write ({exc.strerror}); nothing was written") from None
    if args.json:
        print(json.dumps(record))
    else:
        for (l, m), (r, g, b) in zip(sh.ORDER, coefficients, strict=True):
            print(f"{l} {m:2d}  {r:.7g} {g:.7g} {b:.7g}")
    return 0
