"""Stack pictures top to bottom into one PNG (the user guide's demo overview).

Usage: python tools/make_demo_overview.py A.png B.png ... -o OUT.png [--width 960]

Each picture is scaled to ``--width`` (nearest neighbour, display-referred values as stored)
and the pictures are stacked with a thin dark gap. Reads PNGs with Blender's image loader.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

from bo2_lighting.addon.blender import images
from bo2_lighting.addon.core.review import imaging


def resize(image: np.ndarray, width: int) -> np.ndarray:
    h, w = image.shape[:2]
    height = max(1, round(h * width / w))
    rows = np.minimum((np.arange(height) + 0.5) * h / height, h - 1).astype(int)
    cols = np.minimum((np.arange(width) + 0.5) * w / width, w - 1).astype(int)
    return image[rows][:, cols]


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("images", type=Path, nargs="+")
    parser.add_argument("-o", "--output", type=Path, required=True)
    parser.add_argument("--width", type=int, default=960)
    args = parser.parse_args()
    gap = np.full((6, args.width, 3), 0.11, np.float32)
    parts = []
    for path in args.images:
        parts += [resize(images.read_file(path)[..., :3], args.width), gap]
    imaging.write_png(args.output, np.concatenate(parts[:-1], 0))
    print(f"wrote {args.output}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
