"""The look-dev review: many scenes, each rendered by BO2 Lighting (and, where asked, with the
talk's old methods) and by Cycles, ranked by perceptual error on one static page that works
offline from a file:// URL (docs/report.md).

A scene's entry holds, per BO2 variant ("bo2": the file's settings; "bo2_old": the talk's old
methods) and per pass, the comparison's metrics (``compare.image_metrics``: RMSE, mean relative
error, PSNR, SSIM) and the mean LDR-FLIP (``flip.py``); the Combined pass also has the mean
HDR-FLIP. The page ranks scenes by the Combined pass's mean LDR-FLIP, worst first: it judges
what a viewer sees, through the scene's view transform, as Blender's own render-test reports
do.

Pictures (8-bit PNG, sRGB): each render through the view transform, the difference heat map
(``compare.difference``), the LDR and HDR FLIP maps, a thumbnail, and the scene-linear renders
in Radiance's RGBE encoding (G. Ward, "Real Pixels", Graphics Gems II, 1991) inside a script
file, which the page decodes for its own exposure and view transforms (a canvas cannot read
pixels of a file:// image, but it can read a data: URL). Images are (H, W, C) float32, row 0 at
the top.
"""

from __future__ import annotations

import base64
import html
import json
import math
import os
import re
from pathlib import Path
from urllib.parse import quote

import numpy as np

from ..system.atomic import write_text
from . import compare, flip, imaging, report_page

VARIANTS = {"bo2": "BO2 Lighting", "bo2_old": "BO2 Lighting, the talk's old methods"}
THUMB_WIDTH = 192
RANK_KEY = "flip_ldr"  # the Combined pass's mean LDR-FLIP


class ReportError(Exception):
    """A report that cannot be written: one line for the user."""


# ---------------------------------------------------------------------------------------------
# Encodings


def rgbe(linear) -> np.ndarray:
    """Radiance RGBE: (H, W, >=3) scene-linear RGB -> (H, W, 4) uint8, a shared exponent E and
    mantissas floor(c * 256 / 2^e) for the largest component's frexp exponent e (Ward 1991).
    Values below 1e-32, negative or NaN are 0; a decoded value is (m + 0.5) 2^(E - 136)."""
    c = np.nan_to_num(np.asarray(linear, np.float32)[..., :3], nan=0.0, posinf=0.0)
    c = np.clip(c, 0.0, 1e30)
    top = c.max(-1)
    mant, exp = np.frexp(top)
    scale = np.divide(mant * 256.0, top, out=np.zeros_like(top), where=top > 1e-32)
    out = np.zeros(c.shape[:2] + (4,), np.uint8)
    out[..., :3] = np.clip(np.floor(c * scale[..., None]), 0, 255).astype(np.uint8)
    out[..., 3] = np.where(top > 1e-32, np.clip(exp + 128, 0, 255), 0).astype(np.uint8)
    return out


def rgbe_stack(linear) -> np.ndarray:
    """``rgbe`` as an opaque RGB image of twice the height, (2H, W, 3) uint8: the mantissas
    above, the exponent (in all three channels) below. A browser's canvas keeps RGBA pixels
    with their colour premultiplied by alpha, which would round the mantissas off."""
    e = rgbe(linear)
    return np.concatenate([e[..., :3], np.repeat(e[..., 3:], 3, -1)], 0)


def shrink(image: np.ndarray, width: int) -> np.ndarray:
    """Box-filtered down to at most ``width`` pixels wide by a whole factor: (H, W, C)."""
    f = max(1, min(math.ceil(image.shape[1] / width), image.shape[0]))
    if f == 1:
        return image
    h, w = image.shape[0] // f * f, image.shape[1] // f * f
    a = np.asarray(image[:h, :w], np.float32)
    return a.reshape(h // f, f, w // f, f, -1).mean((1, 3))


def href(path: Path, page: Path) -> str:
    """A link from the page's folder ``page`` to ``path``: relative and percent-encoded, or a
    file:// URL when no relative path exists (another drive)."""
    try:
        rel = Path(os.path.relpath(path, page)).as_posix()
    except ValueError:
        return Path(path).resolve().as_uri()
    return quote(rel)  # ":" too: a first segment never reads as a URL scheme


def slug(text: str, taken: set) -> str:
    """A file-name-safe, unique folder name for a scene."""
    base = re.sub(r"[^A-Za-z0-9._-]+", "_", text).strip("._") or "scene"
    name, n = base, 2
    while name.lower() in taken:
        name, n = f"{base}_{n}", n + 1
    taken.add(name.lower())
    return name


# ---------------------------------------------------------------------------------------------
# One scene


def variant_metrics(test: dict, reference: dict, use_flip: bool) -> dict:
    """Per pass: ``compare.image_metrics`` plus the mean LDR-FLIP ("flip_ldr", None without
    FLIP, and for Combined, whose FLIP ``analyse_scene`` computes with its map).

    test, reference: {pass: (linear (H, W, 3), display (H, W, 3))}, the passes of ``test``
    """
    out = {}
    for name, (lin, disp) in test.items():
        ref_lin, ref_disp = reference[name]
        m = compare.image_metrics(lin, ref_lin, disp, ref_disp)
        m["flip_ldr"] = flip.evaluate(ref_disp, disp)[1] if use_flip and (
            name != "Combined") else None  # Combined's: with its map, in ``analyse_scene``
        out[name] = m
    return out


def analyse_scene(name: str, passes: dict, info: dict, folder: Path, page: Path,
                  links: dict) -> dict:
    """Compare each BO2 variant of one scene with Cycles, write its pictures into ``folder``
    and return its entry of the page.

    passes: {variant ("cycles", "bo2", "bo2_old"): {pass label: (linear (H, W, 3), display
            (H, W, 3))}}, "Combined" first; Cycles' light passes already times their colour
    info:   what the page shows of the scene: "source", "resolution", "color_management",
            "seconds" {variant: render seconds}, "samples" {variant: samples}
    folder: the scene's folder of pictures (created), inside ``page``, the page's folder
    links:  {variant: path of its EXR, relative to the page}
    """
    folder.mkdir(parents=True, exist_ok=True)
    base = Path(os.path.relpath(folder, page)).as_posix()

    def write(name: str, image: np.ndarray) -> str:
        imaging.write_png(folder / name, image)
        return f"{base}/{name}"

    use_flip = flip.unavailable() is None
    cycles = passes["cycles"]
    ref_lin, ref_disp = cycles["Combined"]
    variants = [v for v in VARIANTS if v in passes]
    diffs = {v: compare.difference({"Combined": (passes[v]["Combined"][0], ref_lin)})
             for v in variants}
    scale_max = max(d[1] for d in diffs.values())
    pictures = {"cycles": write("cycles.png", ref_disp)}
    hdr = {"cycles": ref_lin}
    entry_variants = {}
    for v in variants:
        lin, disp = passes[v]["Combined"]
        metrics = variant_metrics(passes[v], cycles, use_flip)
        pics = {"render": write(f"{v}.png", disp),
                "difference": write(f"difference_{v}.png",
                                     imaging.colormap(diffs[v][0] / scale_max))}
        if use_flip:
            ldr_map, metrics["Combined"]["flip_ldr"] = flip.evaluate(ref_disp, disp, colour=True)
            hdr_map, hdr_mean = flip.evaluate(ref_lin, lin, hdr=True, colour=True)
            metrics["Combined"]["flip_hdr"] = hdr_mean  # None for a black Cycles render
            pics["flip_ldr"] = write(f"flip_ldr_{v}.png", ldr_map)
            if hdr_map is not None:
                pics["flip_hdr"] = write(f"flip_hdr_{v}.png", hdr_map)
        entry_variants[v] = {"label": VARIANTS[v], "metrics": metrics, "pictures": pics,
                             "seconds": info["seconds"].get(v),
                             "samples": info.get("samples", {}).get(v)}
        hdr[v] = lin
    pictures["thumbnail"] = write("thumbnail.png",
                            shrink(passes[variants[0]]["Combined"][1], THUMB_WIDTH))
    pictures["hdr"] = f"{base}/{_write_hdr(folder, hdr)}"
    return {"name": name, "folder": folder.name, **info, "cycles_pictures": pictures,
            "cycles_seconds": info["seconds"].get("cycles"), "variants": entry_variants,
            "heat_scale_max": scale_max, "links": links}


def _write_hdr(folder: Path, images: dict) -> str:
    """``hdr.js``: the scene-linear renders as ``rgbe_stack`` PNG data URLs, registered with
    the page."""
    data = {k: "data:image/png;base64," + base64.b64encode(imaging.png_bytes(rgbe_stack(v)))
            .decode() for k, v in images.items()}
    text = f"BO2Report.hdrLoaded({json.dumps(folder.name)}, {json.dumps(data)});\n"
    write_text(folder / "hdr.js", text)
    return "hdr.js"


# ---------------------------------------------------------------------------------------------
# The page


def score(entry: dict, variant: str = "bo2") -> float | None:
    """The figure a scene is ranked by: its Combined pass's mean LDR-FLIP (None without)."""
    v = entry["variants"].get(variant) or next(iter(entry["variants"].values()))
    return v["metrics"]["Combined"].get(RANK_KEY)


def ranked(entries: list[dict]) -> list[dict]:
    """Worst first: by mean LDR-FLIP, or by PSNR (lowest first) when FLIP is not available."""
    def key(e):
        s = score(e)
        if s is not None:
            return (0, -s)
        psnr = e["variants"]["bo2"]["metrics"]["Combined"]["psnr_db"]
        return (1, math.inf if psnr is None else psnr)
    return sorted(entries, key=key)


def failing(entries: list[dict], limit: float | None) -> list[dict]:
    """The entries whose score is above ``limit`` (none when ``limit`` is None)."""
    if limit is None:
        return []
    return [e for e in entries if (score(e) or 0.0) > limit]


def write_page(folder: Path, entries: list[dict], meta: dict) -> Path:
    """Write ``folder/index.html`` and ``folder/report.json`` (atomically) for ``entries``.

    meta: {"title", "created", "blender_version", "fail_above" (or None), "flip" (None when
          available, else why not), "pending" (scene names not done yet)}
    returns: the page's path
    """
    entries = ranked(entries)
    limit = meta.get("fail_above")
    bad = {e["name"] for e in failing(entries, limit)}
    for e in entries:
        e["failing"] = e["name"] in bad
    if bad:  # the failing scenes first, worst first among them
        entries = [e for e in entries if e["failing"]] + [e for e in entries if not e["failing"]]
    stops = imaging.to_uint8(imaging.COLORMAP[::32].tolist() + [imaging.COLORMAP[-1].tolist()])
    heat = ",".join("#" + bytes(c.tolist()).hex() for c in stops)
    data = {**meta, "definitions": {**compare.DEFINITIONS, **DEFINITIONS},
            "heat_gradient": f"linear-gradient(90deg,{heat})", "scenes": entries}
    text = json.dumps(data, indent=1, allow_nan=False)
    head, rest = report_page.page().split("__TITLE__")
    middle, tail = rest.split("__DATA__")
    title = html.escape(meta.get("title", "Look-dev review"))
    # inside <script>, no "<" at all: neither "</script" nor "<!--" can end or bend it
    page = head + title + middle + text.replace("<", "\\u003c") + tail
    write_text(folder / "report.json", text + "\n")
    write_text(folder / "index.html", page)
    return folder / "index.html"


DEFINITIONS = {
    "flip_ldr": "mean LDR-FLIP (Andersson et al. 2020, NVIDIA's flip-evaluator, 67 pixels per "
                "degree) of the display-referred images through the scene's view transform; 0 "
                "identical, 1 the largest error",
    "flip_hdr": "mean HDR-FLIP (Andersson et al. 2021, ACES tone mapper, automatic exposure "
                "range) of the scene-linear Combined pass",
}


