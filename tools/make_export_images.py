"""Pictures of ``bo2 prefilter``'s output for docs/export.md, read back from the files it wrote.

Usage: python tools/make_export_images.py [--hdr PATH] [--out docs/images]

Runs ``bo2 prefilter`` on a reference lat-long map (venice_sunset_1k.hdr of
../shared/reference/envmaps by default) with the talk's filter (bo2), CubeMapGen's (bo1) and
cmft's blinnbrdf (gloss scale 10, bias 1) into KTX2 files, reads each file back with pyktx2 (its
colour model list completed, as tests/core/test_engine_export.py does), and writes, through a
Reinhard tone curve and the sRGB encoding:

- export_cross.png: mips 0, 2 and 4 of the bo2 file as horizontal crosses (+Y above +Z, -Y
  below), the faces as the GPU stores them;
- export_filters.png: the +Z face of mips 1 to 5 for the three filters, one row each.

Prints the commands' times. Run with a Python that has the package (``.venv/bin/python``).
"""

from __future__ import annotations

import argparse
import subprocess
import sys
import tempfile
import time
from enum import Enum
from pathlib import Path

import numpy as np

from bo2_lighting.addon.core.review import imaging

ROOT = Path(__file__).resolve().parents[1]
BO2 = Path(sys.executable).parent / "bo2"
CROSS = ((1, 2), (1, 0), (0, 1), (2, 1), (1, 1), (1, 3))  # GPU face -> (row, column) cell


class _Models(Enum):  # pyktx2 0.3.1 knows only 0 and the Basis colour models
    NONE = 0
    KHR_DF_MODEL_RGBSDA = 1
    KHR_DF_MODEL_ETC1S = 163
    KHR_DF_MODEL_UASTC = 166


def read_ktx2(path: Path) -> list[np.ndarray]:
    """The mips of a KTX2 RGBA16F cube as (6, S, S, 3) float32, read by pyktx2."""
    from pyktx2 import parser

    parser.ColorModel = _Models
    k = parser.parse_path(path)
    images = iter(k.levelImages)
    mips = []
    for m in range(k.levelCount):
        s = k.pixelWidth >> m
        mips.append(np.stack([np.frombuffer(next(images).data, np.float16).reshape(s, s, 4)
                              [..., :3].astype(np.float32) for _ in range(6)]))
    return mips


def display(x: np.ndarray, exposure: float) -> np.ndarray:
    x = np.maximum(x * exposure, 0.0)
    x = x / (1.0 + x)
    return np.where(x <= 0.0031308, 12.92 * x, 1.055 * np.power(x, 1 / 2.4) - 0.055)


def cross(level: np.ndarray, cell: int) -> np.ndarray:
    s = level.shape[1]
    rep = max(1, cell // s)
    out = np.full((3 * s * rep, 4 * s * rep, 3), 0.12, np.float32)
    for f, (r, c) in enumerate(CROSS):
        face = level[f].repeat(rep, 0).repeat(rep, 1)
        out[r * s * rep:(r + 1) * s * rep, c * s * rep:(c + 1) * s * rep] = face
    return out


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--hdr", type=Path,
                        default=ROOT.parent / "shared" / "reference" / "envmaps" /
                        "venice_sunset_1k.hdr")
    parser.add_argument("--out", type=Path, default=ROOT / "docs" / "images")
    args = parser.parse_args()
    chains = {}
    with tempfile.TemporaryDirectory() as tmp:
        for name, extra in (("bo2", []), ("bo1", ["--size", "128"]),
                            ("blinnbrdf", ["--size", "128"])):
            path = Path(tmp) / f"{name}.ktx2"
            start = time.perf_counter()
            subprocess.run([str(BO2), "prefilter", str(args.hdr), "-o", str(path), "--filter",
                            name, *extra], check=True, capture_output=True)
            print(f"bo2 prefilter --filter {name}: {time.perf_counter() - start:.2f} s "
                  "(Python start included)")
            chains[name] = read_ktx2(path)
    exposure = 1.0 / max(float(np.percentile(chains["bo2"][0], 99)), 1e-6)
    bo2 = chains["bo2"]
    crosses = [display(cross(bo2[m], bo2[0].shape[1]), exposure) for m in (0, 2, 4)]
    labels = [(f"bo2 mip {m}: {bo2[m].shape[1]} x {bo2[m].shape[1]}, gloss "
               f"{1 - m / (len(bo2) - 1):.2f}",) for m in (0, 2, 4)]
    args.out.mkdir(parents=True, exist_ok=True)
    imaging.write_png(args.out / "export_cross.png", imaging.panels(crosses, labels))
    rows = []
    for name, mips in chains.items():
        faces = [display(mips[m][4].repeat(128 // mips[m].shape[1], 0)
                         .repeat(128 // mips[m].shape[1], 1), exposure) for m in range(1, 6)]
        rows.append(imaging.panels(faces, [(f"{name} mip {m}",) for m in range(1, 6)]))
    imaging.write_png(args.out / "export_filters.png", np.concatenate(rows, 0))
    print(f"wrote {args.out / 'export_cross.png'} and {args.out / 'export_filters.png'}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
