"""Pictures of Compare with Cycles for docs/compare.md, made by the ``bo2 compare`` command.

Usage: python tools/make_compare_images.py [--resolution 640x360] [--samples 8]
                                           [--cycles-samples 64]

Copies demo_blends/first_light.blend into a temporary folder, bakes its light probes there with
``bo2 bake`` (the demo's own bake folder is left alone), runs ``bo2 compare`` on it, copies the
pictures to docs/images/compare_side_by_side.png, compare_split.png and compare_difference.png,
and prints the command's headline and the image metrics of metrics.json.
"""

from __future__ import annotations

import argparse
import json
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
OUT = ROOT / "docs" / "images"
BO2 = Path(sys.executable).parent / "bo2"
DEMO = ROOT / "demo_blends" / "first_light.blend"


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--resolution", default="640x360", help="WxH of both renders")
    parser.add_argument("--samples", type=int, default=8, help="BO2 Lighting samples")
    parser.add_argument("--cycles-samples", type=int, default=64, help="Cycles samples")
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        blend = Path(tmp) / DEMO.name
        shutil.copyfile(DEMO, blend)
        proc = subprocess.run([str(BO2), "bake", str(blend)], capture_output=True, text=True)
        if proc.returncode != 0:
            sys.stderr.write(proc.stderr)
            return proc.returncode
        proc = subprocess.run([str(BO2), "compare", str(blend), "-o", tmp,
                               "--resolution", args.resolution, "--samples", str(args.samples),
                               "--cycles-samples", str(args.cycles_samples)],
                              capture_output=True, text=True)
        if proc.returncode != 0:
            sys.stderr.write(proc.stderr)
            return proc.returncode
        print(proc.stdout.splitlines()[0])
        for name in ("side_by_side", "split", "difference"):
            target = OUT / f"compare_{name}.png"
            shutil.copyfile(Path(tmp) / f"{name}.png", target)
            print(f"wrote {target.relative_to(ROOT)}")
        metrics = json.loads((Path(tmp) / "metrics.json").read_text())
    print(json.dumps({"image": metrics["image"], "passes": metrics["passes"],
                      "heat_map": metrics["heat_map"]}, indent=2))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
