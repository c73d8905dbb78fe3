"""The main job of ``make demo``: bake, render and compare every demo scene with Cycles.

Usage: python tools/demo.py [--docs]

For each scene of ``demo_blends/`` (built from its script when the .blend is missing), copied
into ``out/scenes/`` (a bake saves its .blend; the bakes go to ``out/scenes/bo2_bake/``): bake its
light probes (``bo2 bake``; the room's lightmaps too, ``bo2 bake --lightmaps``), render it with
BO2 Lighting and with Cycles and compare the two (``bo2 compare``: both EXRs, side-by-side,
split and difference pictures, metrics.json in ``out/<scene>/``), and gather the comparisons on
one review page (``bo2 report``, ``out/report/index.html``). Then render the talk's
old-versus-new pairs (``tools/render_old_vs_new.py``,
``out/old_vs_new_pairs/``). Ends with a table (scene, bake, BO2 and Cycles times, speed-up, RMSE,
PSNR) and the path of every picture. ``--docs`` also writes the pictures of the user guide
into ``docs/images/``. Exits non-zero if any step fails.
"""

from __future__ import annotations

import argparse
import json
import shutil
import subprocess
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
OUT = ROOT / "out"
DOCS = ROOT / "docs" / "images"
BO2 = Path(sys.executable).parent / "bo2"
# Cycles samples are chosen so that the whole run stays within minutes on 2 cores.
SCENES = {
    "first_light": {"bo2_samples": 8, "cycles_samples": 64},
    "material_spheres": {"bo2_samples": 8, "cycles_samples": 64},
    "room": {"bo2_samples": 8, "cycles_samples": 48, "lightmaps": True},
    "old_vs_new": {"bo2_samples": 8, "cycles_samples": 64},
}


def run(cmd: list[str]) -> float:
    """Run ``cmd``; its wall time in seconds; exits with its output if it fails."""
    start = time.perf_counter()
    proc = subprocess.run(cmd, capture_output=True, text=True)
    if proc.returncode != 0:
        sys.stderr.write(proc.stdout + proc.stderr)
        raise SystemExit(f"demo: failed: {' '.join(cmd)}")
    return time.perf_counter() - start


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--docs", action="store_true",
                        help="also write the user guide's pictures into docs/images")
    args = parser.parse_args()
    OUT.mkdir(exist_ok=True)
    rows, pictures = [], []
    for name, cfg in SCENES.items():
        blend = ROOT / "demo_blends" / f"{name}.blend"
        if not blend.exists():
            print(f"building {blend.relative_to(ROOT)}", flush=True)
            run([sys.executable, str(ROOT / "demo_blends" / f"build_{name}.py"), str(blend)])
        scene = OUT / "scenes" / blend.name  # baked and saved there: demo_blends/ stays as is
        scene.parent.mkdir(parents=True, exist_ok=True)
        shutil.copyfile(blend, scene)
        blend = scene
        print(f"baking the light probes of {name}", flush=True)
        bake = run([str(BO2), "bake", str(blend)])
        if cfg.get("lightmaps"):
            print(f"baking the lightmaps of {name}", flush=True)
            bake += run([str(BO2), "bake", str(blend), "--lightmaps"])
        folder = OUT / name
        print(f"rendering {name} with BO2 Lighting and Cycles -> {folder.relative_to(ROOT)}",
              flush=True)
        run([str(BO2), "compare", str(blend), "-o", str(folder),
             "--samples", str(cfg["bo2_samples"]),
             "--cycles-samples", str(cfg["cycles_samples"])])
        metrics = json.loads((folder / "metrics.json").read_text())
        image = metrics["image"]
        engines = metrics["engines"]
        rows.append((name, bake, engines["bo2"]["render_seconds"],
                     engines["cycles"]["render_seconds"], image["rmse"], image["psnr_db"]))
        pictures += [folder / p for p in ("side_by_side.png", "split.png", "difference.png")]
    print("writing the look-dev review page -> out/report/index.html", flush=True)
    run([str(BO2), "report", *[str(OUT / n) for n in SCENES], "-o", str(OUT / "report"),
         "--title", "BO2 Lighting demo scenes"])
    pictures.append(OUT / "report" / "index.html")
    print("rendering the old-versus-new pairs", flush=True)
    run([sys.executable, str(ROOT / "tools" / "render_old_vs_new.py"),
         str(OUT / "old_vs_new_pairs")])
    pairs = sorted((OUT / "old_vs_new_pairs").glob("*.png"))
    pictures += pairs
    if args.docs:
        DOCS.mkdir(parents=True, exist_ok=True)
        run([sys.executable, str(ROOT / "tools" / "make_demo_overview.py"),
             *[str(OUT / n / "side_by_side.png") for n in SCENES],
             "-o", str(DOCS / "demo_overview.png")])
        for src in pairs:
            shutil.copyfile(src, DOCS / f"old_vs_new_{src.name}")
        for name in ("split.png", "difference.png"):
            shutil.copyfile(OUT / "room" / name, DOCS / f"room_{name}")
        print(f"wrote the user guide's pictures into {DOCS.relative_to(ROOT)}")
    print()
    print(f"{'scene':<18} {'bake s':>7} {'BO2 s':>7} {'Cycles s':>9} {'speed-up':>9} "
          f"{'RMSE':>7} {'PSNR dB':>8}")
    for name, bake, t_bo2, t_cyc, rmse, psnr in rows:
        print(f"{name:<18} {bake:7.1f} {t_bo2:7.2f} {t_cyc:9.2f} {t_cyc / t_bo2:8.1f}x "
              f"{rmse:7.4f} {psnr:8.2f}")
    print("(bake: wall time of bo2 bake, Blender start included; BO2 and Cycles: render times)")
    for path in pictures:
        print(f"  {path.relative_to(ROOT)}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
