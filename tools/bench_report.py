"""Measure the look-dev review (docs/report.md): how long ``bo2 report`` takes over the demo
scenes and the glTF add-on's test scenes, BO2 Lighting and Cycles at 64 samples, and how fast
and heavy its page is in Chromium.

Usage: python tools/bench_report.py [--samples 64] [--size 480x270] [--reuse]

1. Stages the glTF-Blender-IO scenes of the shared reference folder as the real-asset tests do
   (legacy glTF groups rebuilt, one sun, a framing camera; ``tests/blender/test_real_assets``)
   into ``out/bench_report/scenes/``; the demo scenes are taken baked from ``out/scenes/``
   (``make demo``), else unbaked from ``demo_blends/``.
2. Times ``bo2 report`` over all of them (a fresh process, kernels cached) and prints the
   wall time beside the sum of the Cycles render times of the same run.
3. Writes a second page from those comparison folders plus the rooms and Ignis scenes (25 in
   all, no rendering) and loads it in headless Chromium from file://: time to the load event,
   the bytes the page fetched, and the report folder's weight without the EXRs.
``--reuse`` skips step 2 when its report exists.
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import subprocess
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
OUT = ROOT / "out" / "bench_report"
REFERENCE = ROOT.parent / "shared" / "reference" / "scenes"
BO2 = Path(sys.executable).parent / "bo2"
DEMO = ("first_light", "material_spheres", "room", "old_vs_new")
EXTRA = ("closed_room", "artist_room")  # for the 25-scene page

STAGE = r"""
import sys
from pathlib import Path
import bpy
sys.path[:0] = [sys.argv[-3], sys.argv[-4]]
from test_real_assets import rebuild_legacy_gltf
import make_asset_images
src, dst = Path(sys.argv[-2]), Path(sys.argv[-1])
w, h = (int(v) for v in sys.argv[-5].split("x"))
bpy.ops.wm.open_mainfile(filepath=str(src))
for mat in bpy.data.materials:
    rebuild_legacy_gltf(mat)
make_asset_images.stage(bpy.context.scene, w, h)
bpy.context.scene.cycles.max_bounces = 12  # the review compares the whole light
bpy.ops.wm.save_as_mainfile(filepath=str(dst), relative_remap=True)
"""


def stage_gltf(size: str) -> list[Path]:
    out = OUT / "scenes"
    out.mkdir(parents=True, exist_ok=True)
    staged = []
    for src in sorted((REFERENCE / "gltf-blender-io").glob("*.blend")):
        dst = out / src.name
        if not dst.exists():
            subprocess.run([sys.executable, "-c", STAGE, size, str(ROOT / "tools"),
                            str(ROOT / "tests" / "blender"), str(src), str(dst)],
                           check=True, capture_output=True)
        staged.append(dst)
    return staged


def demo_scene(name: str) -> Path:
    baked = ROOT / "out" / "scenes" / f"{name}.blend"
    if baked.exists():
        return baked
    print(f"note: {name} is not baked (run make demo first); using demo_blends/", flush=True)
    return ROOT / "demo_blends" / f"{name}.blend"


def folder_bytes(folder: Path) -> int:
    return sum(p.stat().st_size for p in folder.rglob("*")
               if p.is_file() and p.suffix != ".exr")


def load_page(index: Path) -> dict:
    """Chromium's time to the load event and the bytes fetched by then, from file://."""
    from playwright.sync_api import sync_playwright

    chromium = os.environ.get("BO2_CHROMIUM") or shutil.which("chromium")
    fetched = []
    with sync_playwright() as p:
        browser = p.chromium.launch(executable_path=chromium, args=[
            "--no-sandbox", "--disable-gpu", "--disable-background-networking",
            "--disable-component-update", "--disable-sync", "--no-first-run"])
        runs, every = [], []
        for _ in range(3):
            page = browser.new_page(viewport={"width": 1600, "height": 1000})
            fetched.clear()
            page.on("requestfinished", lambda r: fetched.append(r.url))
            page.goto(index.as_uri())
            page.wait_for_load_state("load")
            counted = list(fetched)
            runs.append(page.evaluate(
                "performance.getEntriesByType('navigation')[0].loadEventEnd"))
            page.evaluate("document.querySelectorAll('img').forEach(i => i.loading = 'eager')")
            page.wait_for_function("Array.from(document.images).every(i => i.complete)")
            every.append(page.evaluate("performance.now()"))
            page.close()
        browser.close()
    paths = [Path(u.removeprefix("file://")) for u in counted if u.startswith("file://")]
    return {"load_ms": min(runs), "load_ms_runs": runs, "every_ms": min(every),
            "requests": len(paths),
            "bytes": sum(p.stat().st_size for p in paths if p.exists())}


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--samples", type=int, default=64)
    parser.add_argument("--size", default="480x270", help="glTF scenes' resolution")
    parser.add_argument("--reuse", action="store_true")
    args = parser.parse_args()
    gltf = stage_gltf(args.size)
    report = OUT / "report"
    scenes = [demo_scene(n) for n in DEMO] + gltf
    if not (args.reuse and (report / "report.json").exists()):
        shutil.rmtree(report, ignore_errors=True)
        start = time.perf_counter()
        proc = subprocess.run([str(BO2), "report", *map(str, scenes), "-o", str(report),
                               "--samples", str(args.samples), "--cycles-samples",
                               str(args.samples)], text=True, stdout=subprocess.PIPE)
        wall = time.perf_counter() - start
        if proc.returncode not in (0, 1):
            raise SystemExit(f"bench_report: bo2 report failed ({proc.returncode})")
        data = json.loads((report / "report.json").read_text())
        cycles = sum(s["cycles_seconds"] for s in data["scenes"])
        bo2 = sum(s["variants"]["bo2"]["seconds"] for s in data["scenes"])
        print(f"bo2 report, {len(data['scenes'])} scenes ({len(DEMO)} demo + {len(gltf)} glTF), "
              f"{args.samples} samples each engine: {wall:.0f} s wall "
              f"(BO2 renders {bo2:.0f} s, Cycles renders {cycles:.0f} s; target 600 s)")
        for s in data["scenes"]:
            m = s["variants"]["bo2"]["metrics"]["Combined"]
            flip = "  -  " if m["flip_ldr"] is None else f"{m['flip_ldr']:.3f}"
            print(f"  {s['name']:<28} FLIP {flip}  PSNR {m['psnr_db'] or 0:5.1f}  "
                  f"BO2 {s['variants']['bo2']['seconds']:6.2f} s  "
                  f"Cycles {s['cycles_seconds']:6.2f} s")
    # 25 scenes on one page: those comparisons read back, plus the rooms and Ignis scenes
    extra = [demo_scene(n) for n in EXTRA] + sorted((REFERENCE / "ignis").glob("*.blend"))
    page25 = OUT / "page25"
    shutil.rmtree(page25, ignore_errors=True)
    subprocess.run([str(BO2), "report", str(report / "scenes"), *map(str, extra), "-o",
                    str(page25), "--samples", "8", "--cycles-samples", "16"],
                   text=True, stdout=subprocess.PIPE)
    count = len(json.loads((page25 / "report.json").read_text())["scenes"])
    load = load_page(page25 / "index.html")
    print(f"page of {count} scenes: load event {load['load_ms']:.0f} ms (best of 3: "
          f"{', '.join(f'{t:.0f}' for t in load['load_ms_runs'])}; target 1000 ms), "
          f"{load['requests']} files fetched, {load['bytes'] / 1e6:.1f} MB; every picture "
          f"of every scene loaded after {load['every_ms']:.0f} ms; report folder "
          f"without EXRs {folder_bytes(page25) / 1e6:.1f} MB (target 30 MB)")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
