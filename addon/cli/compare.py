"""``bo2 compare``: one frame rendered with BO2 Lighting and with Cycles and compared
(``blender/compare.py``, docs/compare.md); Ctrl-C keeps what is written."""

from __future__ import annotations

import os
from pathlib import Path

from ..blender import headless
from ..core.review.compare import headline
from . import CommandError, load_blend
from .terminal import exit_on_interrupt, quiet_blender


def load_scene(path: Path, args):
    """Open ``path`` for a comparison: its scene, with a camera (CommandError otherwise) and
    the command's --frame, --resolution, --samples and --cycles-samples applied."""
    scene = load_blend(path)
    if not headless.has_camera(scene):
        raise CommandError(f"{path}: the scene has no active camera")
    headless.apply_comparison_options(scene, **comparison_options(args))
    return scene


def comparison_options(args) -> dict:
    """The arguments of ``headless.apply_comparison_options`` that the command was given."""
    return {"frame": getattr(args, "frame", None), "resolution": args.resolution,
            "samples": args.samples, "cycles_samples": args.cycles_samples}


def run(args) -> int:
    """Render one frame with BO2 Lighting and with Cycles and compare them (docs/compare.md)."""
    folder = Path(args.output)
    try:
        folder.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise CommandError(f"{folder}: cannot create the output folder "
                           f"({exc.strerror or exc})") from None
    if not os.access(folder, os.W_OK | os.X_OK):
        raise CommandError(f"{folder}: output folder is not writable")
    scene = load_scene(Path(args.scene), args)
    from ..blender import compare

    stage = ["start"]

    def interrupted() -> str:
        kept = [str(folder / e[2]) for e in compare.ENGINES.values() if (folder / e[2]).exists()]
        return (f"interrupted during the {stage[0]}; "
                + (f"kept {', '.join(kept)}" if kept else "nothing written"))

    failure = result = None
    with exit_on_interrupt(interrupted), quiet_blender():
        try:
            result = compare.run(scene, headless.view_layer(), folder,
                                 on_stage=lambda text: stage.__setitem__(0, text))
        except compare.CompareError as exc:
            failure = str(exc)
    if failure:
        raise CommandError(failure)
    print(headline(result))
    for path in result["files"].values():
        print(f"  {path}")
    return 0
