"""``bo2 bake``: the light probes of a .blend file baked into its bake folder, with a progress
bar."""

from __future__ import annotations

import sys
import time
from pathlib import Path

from ..blender import headless, interrupt
from ..core import pipeline
from . import CommandError, load_blend
from .terminal import progress_bar, quiet_blender, stderr_copy


def run(args) -> int:
    """Bake the light probes of a .blend file into its bake folder."""
    scene = load_blend(Path(args.scene))
    from ..blender import bake, probes

    objs = probes.probe_objects(scene)
    if args.probes:
        names = {o.name for o in objs}
        unknown = [n for n in args.probes if n not in names]
        if unknown:
            raise CommandError(f"no Sphere or Volume light probe named {', '.join(unknown)} "
                               f"(have: {', '.join(sorted(names)) or 'none'})")
        objs = [o for o in objs if o.name in args.probes]
    if not objs:
        raise CommandError(f"{args.scene}: the scene has no Sphere or Volume light probes")
    start = time.perf_counter()
    warnings: list[str] = []
    terminal = stderr_copy()  # the progress bar passes Blender's silencing
    try:
        folder = probes.bake_folder(scene)
        depsgraph = headless.depsgraph()
        with quiet_blender():
            steps = bake.bake_steps(scene, depsgraph, objs, args.backend.upper(),
                                    report=warnings.append)
            try:
                for fraction in steps:
                    interrupt.check()  # closing the generator writes nothing
                    progress_bar(terminal, fraction, start)
            except pipeline.Cancelled:  # a capture stopped by Ctrl-C
                raise KeyboardInterrupt from None
    except probes.BakeError as exc:
        raise CommandError(str(exc)) from None
    finally:
        terminal.write("\n")
        terminal.close()
        for message in warnings:  # a failed bake's too
            print(f"bo2: warning: {message}", file=sys.stderr)
    print(f"baked {len(objs)} probe{'s' * (len(objs) != 1)} into {folder} "
          f"in {time.perf_counter() - start:.2f} s")
    return 0
