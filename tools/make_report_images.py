"""Screenshots of a review page for docs/report.md, in headless Chromium.

Usage: python tools/make_report_images.py [out/report/index.html] [-o docs/images]

Writes ``report_page.png`` (the header, the ranking and the first scene's A/B wipe),
``report_flip.png`` (the first scene's LDR-FLIP map) and ``report_exposure.png`` (the wipe
under Khronos PBR Neutral at +1 EV).
"""

from __future__ import annotations

import argparse
import os
import shutil
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
FLAGS = ["--no-sandbox", "--disable-gpu", "--disable-background-networking",
         "--disable-component-update", "--disable-sync", "--no-first-run",
         "--force-color-profile=srgb"]


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("page", type=Path, nargs="?", default=ROOT / "out/report/index.html")
    parser.add_argument("-o", "--output", type=Path, default=ROOT / "docs" / "images")
    args = parser.parse_args()
    from playwright.sync_api import sync_playwright

    chromium = os.environ.get("BO2_CHROMIUM") or shutil.which("chromium")
    with sync_playwright() as p:
        browser = p.chromium.launch(executable_path=chromium, args=FLAGS)
        page = browser.new_page(viewport={"width": 1280, "height": 1100})
        page.goto(args.page.resolve().as_uri())
        page.wait_for_load_state("load")
        first = page.locator("section.scene").first
        first.locator("input.wipe").evaluate(
            "e => { e.value = 62; e.dispatchEvent(new Event('input')); }")
        page.wait_for_timeout(500)
        page.screenshot(path=args.output / "report_page.png")
        first.locator("button[data-mode=flip_ldr]").click()
        page.wait_for_timeout(300)
        first.screenshot(path=args.output / "report_flip.png")
        first.locator("button[data-mode=wipe]").click()
        page.select_option("#view", "neutral")
        page.locator("#exposure").evaluate(
            "e => { e.value = 1; e.dispatchEvent(new Event('input')); }")
        page.wait_for_function("document.querySelector('section.scene .top img')"
                               ".src.startsWith('data:')")
        page.wait_for_timeout(300)
        page.screenshot(path=args.output / "report_exposure.png")
        browser.close()
    for name in ("report_page.png", "report_flip.png", "report_exposure.png"):
        print(args.output / name)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
