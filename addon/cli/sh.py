"""``bo2 sh``: the 9 RGB SH coefficients of a lat-long image, read by Blender
(``headless.read_equirect``)."""

from __future__ import annotations

import json
from pathlib import Path

from ..blender import headless
from ..core import sh
from .terminal import quiet_blender


def run(args) -> int:
    """Print the 9 RGB SH coefficients of the radiance of a lat-long (equirectangular) image."""
    with quiet_blender():
        image = headless.read_equirect(Path(args.image))
    coefficients = sh.project_equirect(image)
    if args.json:
        print(json.dumps({"image": str(args.image), "order": [list(lm) for lm in sh.ORDER],
                          "coefficients": [[float(x) for x in row] for row in coefficients]}))
    else:
        for (l, m), (r, g, b) in zip(sh.ORDER, coefficients, strict=True):
            print(f"{l} {m:2d}  {r:.7g} {g:.7g} {b:.7g}")
    return 0
