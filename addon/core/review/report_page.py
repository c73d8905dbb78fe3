"""The look-dev review's page (``report.write_page``): one HTML file with its style and script
inline, no network, working from a file:// URL. Its HTML, CSS and script are files of their
own (``page/report.html``, ``report.css``, ``report.js``), joined by ``page``; ``__TITLE__`` and
``__DATA__`` (the report's JSON) are filled in by the report.

The script's view transforms, applied to the scene-linear renders when the reader picks one:
- Standard: the sRGB transfer function of IEC 61966-2-1 on the exposed values, clipped;
- Khronos PBR Neutral: the Khronos 3D Formats Working Group's "PBR Neutral" tone mapper
  (2024), start of compression 0.76, desaturation 0.15, then the sRGB transfer function.
"As rendered" shows Blender's own output of the scene's view transform, look and exposure.
"""

from __future__ import annotations

from functools import cache
from pathlib import Path

FOLDER = Path(__file__).with_name("page")


@cache
def page() -> str:
    """The page's HTML with its style and script inline, ``__TITLE__`` and ``__DATA__`` left
    to fill in."""
    html = (FOLDER / "report.html").read_text(encoding="utf-8")
    return (html.replace("__STYLE__", (FOLDER / "report.css").read_text(encoding="utf-8"))
            .replace("__SCRIPT__", (FOLDER / "report.js").read_text(encoding="utf-8")))
