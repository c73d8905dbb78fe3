"""Replace the generated part of a docs page: the text between two marker comments."""

from __future__ import annotations

import re
import sys
from pathlib import Path


def replace_section(doc: Path, begin: str, end: str, text: str) -> bool:
    """Put ``text`` between the lines ``begin`` and ``end`` of ``doc``; False (and a message on
    stderr) when the markers are missing, the page then left as it was."""
    old = doc.read_text()
    pattern = re.compile(re.escape(begin) + ".*?" + re.escape(end), re.S)
    if not pattern.search(old):
        print(f"{doc}: markers not found, not written", file=sys.stderr)
        return False
    doc.write_text(pattern.sub(lambda _: f"{begin}\n{text}\n{end}", old))
    return True
