"""The ``bo2 render`` output language, pure Python: frame lists and ``-o`` path patterns.

``--frames``: ``N``, ``A-B`` or ``A-BxSTEP``, comma separated (``1-10``, ``1,3,5-7``,
``1-10x2``). ``-o``: ``{scene}`` (the .blend's name without .blend) and ``{frame}`` (format spec
allowed: ``{frame:04d}``) are filled in, and the last run of ``#`` in the file name is the frame
padded to its length, as Blender does (``shot_####.png`` -> ``shot_0007.png``). ``plan`` finds
two images that would get the same path before anything renders.
"""

from __future__ import annotations

import os
import re
import string
from pathlib import Path

MAX_FRAME = 1048574  # Blender's MAXFRAME
_FRAME_ITEM = re.compile(r"(-?\d+)(?:-(-?\d+)(?:x(\d+))?)?")


def frame_list(text: str, most: int | None = None) -> list[int]:
    """The frames of a ``--frames`` list, in order, each once; ValueError for bad input or,
    before any is listed, for more than ``most`` frames."""
    frames: dict[int, None] = {}
    count = 0
    for item in text.split(","):
        m = _FRAME_ITEM.fullmatch(item.strip())
        if not m:
            raise ValueError(f"invalid frames {text!r}, expected e.g. 7, 1-10, 1,3,5-7 or 1-10x2")
        first, last = int(m[1]), int(m[2] if m[2] is not None else m[1])
        step = int(m[3] or 1)
        if last < first or step < 1 or max(abs(first), abs(last)) > MAX_FRAME:
            raise ValueError(
                f"invalid frame range {item.strip()!r}: A-BxSTEP needs A <= B, STEP >= 1 and "
                f"frames within +-{MAX_FRAME}")
        count += len(range(first, last + 1, step))
        if most is not None and count > most:
            raise ValueError(f"too many frames in {text!r}: at most {most:,} at once")
        frames.update(dict.fromkeys(range(first, last + 1, step)))
    return list(frames)


def output_path(pattern: str, scene: str, frame: int) -> Path:
    """The path of one image: ``pattern`` with ``{scene}``, ``{frame}`` and the last run of
    ``#`` in the file name filled in (a ``#`` in a folder or in a filled-in value stays)."""
    pieces: list[list] = []  # [is literal text, text]
    for literal, field, spec, conversion in string.Formatter().parse(pattern):
        pieces.append([True, literal])
        if field is not None:
            value = {"scene": scene, "frame": frame}[field]
            if conversion:
                value = {"s": str, "r": repr, "a": ascii}[conversion](value)
            pieces.append([False, format(value, spec)])
    for piece in reversed(pieces):
        if not piece[0]:
            continue
        text = piece[1]
        cut = max(text.rfind("/"), text.rfind(os.sep))
        runs = list(re.finditer(r"#+", text[cut + 1:]))
        if runs:
            start, end = runs[-1].start() + cut + 1, runs[-1].end() + cut + 1
            piece[1] = f"{text[:start]}{frame:0{end - start}d}{text[end:]}"
            break
        if cut >= 0:
            break  # the file name has no '#'; directories keep theirs
    return Path("".join(text for _, text in pieces))


def check_pattern(pattern: str) -> None:
    """ValueError (one line) for an empty ``-o`` pattern, one with other fields than {scene}
    and {frame}, a format spec that does not fit them, or unbalanced braces."""
    if not pattern.strip():
        raise ValueError("no file name; give an image file name, such as out/frame.png")
    try:
        fields = [(f, s) for _, f, s, _ in string.Formatter().parse(pattern) if f is not None]
        for field, spec in fields:
            if field not in ("scene", "frame") or "{" in spec:
                raise ValueError(f"unknown field {{{field}}}, use {{scene}} and {{frame}} "
                                 "(write {{ and }} for a brace)")
        output_path(pattern, "scene", 1)
    except TypeError as exc:
        raise ValueError(str(exc)) from None


def uses_frame(pattern: str) -> bool:
    """Whether the paths of ``pattern`` depend on the frame."""
    return output_path(pattern, "s", 1) != output_path(pattern, "s", 2)


def path_key(path: Path) -> str:
    """``path`` as the file system tells paths apart: absolute, case-folded where it ignores
    case."""
    return os.path.normcase(os.path.abspath(path))


def plan(pattern: str, blends: list[Path], frames: list[int] | None) -> dict[str, tuple[Path, str]]:
    """The output path of every image, planned before anything renders.

    blends:  .blend files, their names (``Path.stem``) fill in {scene}
    frames:  frames rendered of every file; None: each file's current frame, assumed the same
             (frame 1) in every file
    returns: {``path_key``: (path, label)}, label e.g. "shots/a.blend frame 7"
    raises:  ValueError (one line) when two images get the same path
    """
    planned: dict[str, tuple[Path, str]] = {}
    for blend in blends:
        for frame in frames or [None]:
            out = output_path(pattern, blend.stem, 1 if frame is None else frame)
            key = path_key(out)
            image = f"{blend}" if frame is None else f"{blend} frame {frame}"
            if key in planned:
                same = "the same path" if frame is None and uses_frame(pattern) else out
                raise ValueError(f"-o {pattern!r} gives {same} for both {planned[key][1]} and "
                                 f"{image}; use {{scene}}, {{frame}} or #### so that every "
                                 "image has its own path")
            planned[key] = out, image
    return planned


def overwrites_input(inputs, outputs) -> str | None:
    """Why writing ``outputs`` would destroy one of ``inputs`` (an output is an input, by any
    path to the same file), or None."""
    def same(a: Path, b: Path) -> bool:
        try:
            return a.resolve() == b.resolve() or (a.exists() and b.exists()
                                                  and os.path.samefile(a, b))
        except OSError:
            return False

    for out in map(Path, outputs):
        for source in map(Path, inputs):
            if same(out, source):
                return (f"{out}: this is the input {source}; writing it would replace it: "
                        "choose another output")
    return None
