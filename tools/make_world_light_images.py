"""The pictures of docs/probes.md's world-light figures: before | after | Cycles, side by side.

Usage: python tools/make_world_light_images.py BEFORE_DIR AFTER_DIR OUT_DIR SCENE [SCENE ...]

Reads ``<dir>/<scene>/bo2.exr`` of two runs of ``tools/measure_indirect.py`` (one with the
add-on before a change, one after; the Cycles render of the after run, ``cycles.exr``) and
writes ``OUT_DIR/world_<scene>.png``: the three Combined images through the sRGB transfer,
labelled.
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import OpenEXR

from bo2_lighting.addon.core.formulas import texture
from bo2_lighting.addon.core.review import imaging


def combined(path: Path) -> np.ndarray:
    """(H, W, 3) display image of an EXR's Combined layer (a render's, or a single image)."""
    for part in OpenEXR.File(str(path)).parts:
        for name in ("ViewLayer.Combined", "Combined", "RGBA", "RGB"):
            if name in part.channels:
                linear = np.asarray(part.channels[name].pixels, np.float32)[..., :3]
                return texture.linear_to_srgb(np.clip(linear, 0.0, 1.0))
    raise SystemExit(f"{path}: no Combined layer")


def main() -> int:
    if len(sys.argv) < 5:
        print(__doc__)
        return 2
    before, after, out = (Path(a) for a in sys.argv[1:4])
    out.mkdir(parents=True, exist_ok=True)
    for scene in sys.argv[4:]:
        images = [combined(before / scene / "bo2.exr"), combined(after / scene / "bo2.exr"),
                  combined(after / scene / "cycles.exr")]
        strip = imaging.panels(images, [("BO2 Lighting before", "before"),
                                        ("BO2 Lighting now", "now"), ("Cycles",)])
        path = out / f"world_{scene}.png"
        imaging.write_png(path, strip)
        print(f"wrote {path}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
