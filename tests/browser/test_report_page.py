"""The review page as a reader uses it, in headless Chromium (Playwright driving the system's
browser): opened from a file:// URL with no console error, the A/B wipe moving and changing
the pixels under it, sorting, the old/new and map toggles, and the page's own exposure and view
transform on the scene-linear renders. Screenshots go to out/report/."""

import io
import os
import shutil
from pathlib import Path

import numpy as np
import pytest

from bo2_lighting.addon.core.review import flip, report

ROOT = Path(__file__).resolve().parents[2]
SHOTS = ROOT / "out" / "report"
CHROMIUM = os.environ.get("BO2_CHROMIUM") or shutil.which("chromium")
FLAGS = ["--no-sandbox", "--disable-gpu", "--disable-background-networking",
         "--disable-component-update", "--disable-sync", "--no-first-run",
         "--force-color-profile=srgb"]

pytestmark = [
    pytest.mark.skipif(not CHROMIUM, reason="no Chromium (tools/chromium.sh installs it)"),
    pytest.mark.skipif(flip.unavailable() is not None, reason="no flip-evaluator"),
]

# scene-linear colours of the three renders, distinct in every channel
COLOURS = {"cycles": (0.05, 0.10, 0.60), "bo2": (0.60, 0.10, 0.05), "bo2_old": (0.05, 0.50, 0.05)}
W, H = 160, 90


def srgb8(linear):
    v = np.clip(np.asarray(linear, float), 0, 1)
    return np.round(255 * np.where(v <= 0.0031308, 12.92 * v,
                                   1.055 * v ** (1 / 2.4) - 0.055)).astype(int)


def make_report(folder: Path, n: int) -> list[dict]:
    """``n`` scenes; scene i's BO2 renders are their colour times 1 + i / 4 (worse as i grows),
    each with a white square at its top left (rows at the top)."""
    entries = []
    for i in range(n):
        passes = {}
        for key, colour in COLOURS.items():
            lin = np.broadcast_to(np.float32(colour), (H, W, 3)).copy()
            if key != "cycles":
                lin *= 1 + i / 4
            lin[:10, :10] = 1.0
            disp = srgb8(lin) / 255.0
            passes[key] = {"Combined": (lin, disp), "Diffuse Direct": (lin * 0.5, disp * 0.7)}
        info = {"seconds": {"bo2": 1.0 + i, "cycles": 30.0, "bo2_old": 0.9},
                "samples": {"bo2": 8, "cycles": 64}, "resolution": [W, H],
                "source": {"blend_file": f"s{i}.blend", "scene": "Scene"},
                "color_management": {"view_transform": "Standard", "exposure": 0.0}}
        entries.append(report.analyse_scene(f"scene {i}", passes, info,
                                            folder / "scenes" / f"s{i}", folder, {}))
    meta = {"title": "Review", "created": "today", "blender_version": "5.0.1",
            "fail_above": None, "flip": None, "pending": []}
    report.write_page(folder, entries, meta)
    return entries


@pytest.fixture(scope="module")
def browser():
    from playwright.sync_api import sync_playwright

    with sync_playwright() as p:
        b = p.chromium.launch(executable_path=CHROMIUM, args=FLAGS)
        yield b
        b.close()


@pytest.fixture
def page(browser, tmp_path):
    make_report(tmp_path, 4)
    pg = browser.new_page(viewport={"width": 1200, "height": 900})
    errors = []
    pg.on("console", lambda m: errors.append(m.text) if m.type in ("error", "warning") else 0)
    pg.on("pageerror", lambda e: errors.append(str(e)))
    pg.on("requestfailed", lambda r: errors.append(f"failed: {r.url}"))
    pg.goto((tmp_path / "index.html").as_uri())
    pg.wait_for_load_state("load")
    yield pg
    assert errors == []
    pg.close()


def pixel(pg, locator, x_fraction, y_fraction):
    """The rendered RGB (0-255) of ``locator`` at a fraction of its box."""
    from PIL import Image

    shot = Image.open(io.BytesIO(locator.screenshot())).convert("RGB")
    px = np.asarray(shot)
    return px[int(y_fraction * (px.shape[0] - 1)), int(x_fraction * (px.shape[1] - 1))].astype(int)


def set_range(pg, locator, value):
    locator.evaluate("(e, v) => { e.value = v; e.dispatchEvent(new Event('input')); }",
                     str(value))


def test_page_loads_with_every_picture(page):
    assert page.title() == "Review"
    rows = page.locator("#summary tbody tr")
    assert rows.count() == 4
    assert rows.locator("td.name").all_inner_texts() == ["scene 3", "scene 2", "scene 1",
                                                         "scene 0"]  # worst first
    page.evaluate("document.querySelectorAll('img').forEach(i => i.loading = 'eager')")
    page.wait_for_function("Array.from(document.images).every(i => i.complete)")
    broken = page.evaluate("Array.from(document.images).filter(i => "
                           "i.getAttribute('src') && i.naturalWidth === 0).length")
    assert broken == 0 and page.locator("img").count() == 4 + 2 * 4  # thumbs, two per scene
    SHOTS.mkdir(parents=True, exist_ok=True)
    page.screenshot(path=SHOTS / "browser_page.png", full_page=True)


def test_wipe_moves_and_changes_the_pixels_under_it(page):
    sec = page.locator("section.scene").first  # scene 3: BO2 is 1.75 x Cycles
    viewer, wipe = sec.locator(".viewer"), sec.locator("input.wipe")
    cycles, bo2 = srgb8(COLOURS["cycles"]), srgb8(np.array(COLOURS["bo2"]) * 1.75)
    set_range(page, wipe, 10)
    assert np.abs(pixel(page, viewer, 0.5, 0.6) - cycles).max() <= 2
    set_range(page, wipe, 90)
    assert np.abs(pixel(page, viewer, 0.5, 0.6) - bo2).max() <= 2
    assert np.abs(pixel(page, viewer, 0.97, 0.6) - cycles).max() <= 2  # right of the divider
    box = viewer.bounding_box()  # dragging on the picture moves it too
    page.mouse.move(box["x"] + 0.2 * box["width"], box["y"] + 50)
    page.mouse.down()
    page.mouse.move(box["x"] + 0.3 * box["width"], box["y"] + 50)
    page.mouse.up()
    assert float(wipe.input_value()) == pytest.approx(30, abs=1)
    assert np.abs(pixel(page, viewer, 0.5, 0.6) - cycles).max() <= 2
    sec.screenshot(path=SHOTS / "browser_wipe.png")


def test_sorting_reorders_rows(page):
    names = page.locator("#summary tbody td.name")
    header = page.locator("#summary th[data-key=bo2_s]")
    header.click()
    assert names.all_inner_texts() == ["scene 0", "scene 1", "scene 2", "scene 3"]
    assert header.get_attribute("aria-sort") == "ascending"
    header.click()
    assert names.all_inner_texts() == ["scene 3", "scene 2", "scene 1", "scene 0"]
    page.locator("#summary th[data-key=name]").click()
    assert names.all_inner_texts() == ["scene 0", "scene 1", "scene 2", "scene 3"]
    passes = page.locator("section.scene").first.locator("table.passes")
    rows = passes.locator("tbody tr td:first-child")
    assert rows.all_inner_texts() == ["Combined", "Diffuse Direct"]
    passes.locator("th[data-key=pass]").click()  # ascending, then descending
    passes.locator("th[data-key=pass]").click()
    assert rows.all_inner_texts() == ["Diffuse Direct", "Combined"]


def test_toggles_switch_pictures(page):
    sec = page.locator("section.scene").nth(1)  # scene 2: 1.5 x
    viewer = sec.locator(".viewer")
    set_range(page, sec.locator("input.wipe"), 90)
    sec.locator("button[data-variant=bo2_old]").click()
    assert sec.locator(".top img").get_attribute("src").endswith("/bo2_old.png")
    old = srgb8(np.array(COLOURS["bo2_old"]) * 1.5)
    assert np.abs(pixel(page, viewer, 0.5, 0.6) - old).max() <= 2
    sec.locator("button[data-mode=difference]").click()
    assert sec.locator("img.base").get_attribute("src").endswith("/difference_bo2_old.png")
    assert not sec.locator("input.wipe").is_visible()
    sec.locator("button[data-mode=flip_ldr]").click()
    assert sec.locator("img.base").get_attribute("src").endswith("/flip_ldr_bo2_old.png")
    assert "LDR-FLIP, mean" in sec.locator(".legend").inner_text()
    sec.screenshot(path=SHOTS / "browser_flip.png")
    sec.locator("button[data-variant=bo2]").click()
    assert sec.locator("img.base").get_attribute("src").endswith("/flip_ldr_bo2.png")
    sec.locator("button[data-mode=wipe]").click()
    assert sec.locator("input.wipe").is_visible()


def test_exposure_and_view_transform(page):
    sec = page.locator("section.scene").nth(2)  # scene 1: 1.25 x
    viewer = sec.locator(".viewer")
    sec.scroll_into_view_if_needed()
    set_range(page, sec.locator("input.wipe"), 90)
    assert page.locator("#exposure").is_disabled()  # "As rendered": Blender's pictures
    page.select_option("#view", "standard")
    set_range(page, page.locator("#exposure"), 1)
    page.wait_for_function("document.querySelectorAll('section.scene')[2]"
                           ".querySelector('.top img').src.startsWith('data:')")
    expected = srgb8(np.array(COLOURS["bo2"]) * 1.25 * 2)  # +1 EV
    assert np.abs(pixel(page, viewer, 0.5, 0.6) - expected).max() <= 2
    assert page.locator("#exposure-value").inner_text() == "1.0 EV"
    page.select_option("#view", "neutral")
    set_range(page, page.locator("#exposure"), 0)
    page.wait_for_timeout(300)
    expected = srgb8(pbr_neutral(np.array(COLOURS["bo2"]) * 1.25))
    assert np.abs(pixel(page, viewer, 0.5, 0.6) - expected).max() <= 2
    page.select_option("#view", "rendered")
    assert sec.locator(".top img").get_attribute("src").endswith("/bo2.png")


def pbr_neutral(c):
    """Khronos PBR Neutral (the Khronos 3D Formats Working Group's reference, 2024)."""
    start, desaturation = 0.8 - 0.04, 0.15
    x = c.min()
    c = c - (x - 6.25 * x * x if x < 0.08 else 0.04)
    peak = c.max()
    if peak < start:
        return c
    d = 1 - start
    new_peak = 1 - d * d / (peak + d - start)
    c = c * new_peak / peak
    g = 1 - 1 / (desaturation * (peak - new_peak) + 1)
    return c * (1 - g) + new_peak * g
