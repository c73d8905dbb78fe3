"""The main job of ``make demo``: bake and render the demo scenes with BO2 Lighting and Cycles.

Builds any missing demo .blend from its script in ``demo_blends/``, bakes its light probes with
``bo2 bake``, renders it with the ``bo2`` command (both engines, same camera and resolution),
writes the images to ``out/`` and prints a table of times. Exits non-zero if any step fails.
"""

from __future__ import annotations

import subprocess
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
OUT = ROOT / "out"
BO2 = Path(sys.executable).parent / "bo2"
SCENES = {"first_light": {"cycles_samples": 64, "bo2_samples": 8}}


def run(cmd: list[str]) -> float:
    start = time.perf_counter()
    proc = subprocess.run(cmd, capture_output=True, text=True)
    if proc.returncode != 0:
        sys.stderr.write(proc.stdout + proc.stderr)
        raise SystemExit(f"demo: failed: {' '.join(cmd)}")
    return time.perf_counter() - start


def main() -> int:
    OUT.mkdir(exist_ok=True)
    rows = []
    for name, cfg in SCENES.items():
        blend = ROOT / "demo_blends" / f"{name}.blend"
        if not blend.exists():
            print(f"building {blend.relative_to(ROOT)}")
            run([sys.executable, str(ROOT / "demo_blends" / f"build_{name}.py"), str(blend)])
        print(f"baking the light probes of {name}", flush=True)
        times = {"bake": run([str(BO2), "bake", str(blend)])}
        for engine in ("bo2", "cycles"):
            out = OUT / f"{name}_{engine}.png"
            print(f"rendering {name} with {engine} -> {out.relative_to(ROOT)}", flush=True)
            times[engine] = run([str(BO2), "render", str(blend), "-o", str(out),
                                 "--engine", engine, "--samples", str(cfg[f"{engine}_samples"])])
        rows.append((name, times["bake"], times["bo2"], times["cycles"]))
    print()
    print(f"{'scene':<14} {'bake s':>7} {'BO2 s':>8} {'Cycles s':>9} {'speed-up':>9}")
    for name, t_bake, t_bo2, t_cyc in rows:
        print(f"{name:<14} {t_bake:7.2f} {t_bo2:8.2f} {t_cyc:9.2f} {t_cyc / t_bo2:8.1f}x")
    print("(times include starting Blender and loading the scene)")
    for name, *_ in rows:
        for engine in ("bo2", "cycles"):
            print(f"  {OUT.relative_to(ROOT) / f'{name}_{engine}.png'}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
