"""``bo2 bake``: the light probes (or lightmaps) of a .blend file baked into its bake folder,
with a progress bar."""

from __future__ import annotations

import sys
import time
from pathlib import Path

from ..blender import headless, interrupt
from ..core import pipeline
from . import CommandError, load_blend
from .terminal import progress_bar, quiet_blender, stderr_copy


def run(args) -> int:
    """Bake the light probes, or with ``--lightmaps`` the lightmaps, of a .blend file."""
    scene = load_blend(Path(args.scene))
    from ..blender import bake, lightmaps, probes

    lightmapping = args.lightmaps is not None
    if lightmapping:
        if args.probes:
            raise CommandError("--probes and --lightmaps: bake the probes first, then the "
                               "lightmaps, with two commands")
        objs = _named(lightmaps.lightmap_objects(scene), args.lightmaps, "static mesh object")
        if not objs:
            raise CommandError(f"{args.scene}: the scene has no static mesh objects")
        what = "lightmap"
    else:
        objs = _named(probes.probe_objects(scene), args.probes,
                      "Sphere or Volume light probe")
        if not objs:
            raise CommandError(f"{args.scene}: the scene has no Sphere or Volume light probes")
        what = "probe"
    start = time.perf_counter()
    warnings: list[str] = []
    terminal = stderr_copy()  # the progress bar passes Blender's silencing
    try:
        folder = probes.bake_folder(scene)
        depsgraph = headless.depsgraph()
        with quiet_blender():
            if lightmapping:
                folder = folder / lightmaps.FOLDER
                steps = bake.lightmap_steps(scene, depsgraph, objs, report=warnings.append,
                                            backend=args.backend.upper())
            else:
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
    size = sum(lightmaps.path(folder, o.name).stat().st_size for o in objs
               if lightmaps.path(folder, o.name).exists()) if lightmapping else 0
    print(f"baked {len(objs)} {what}{'s' * (len(objs) != 1)} into {folder} "
          f"in {time.perf_counter() - start:.2f} s"
          + (f" ({size / 2**20:.2f} MiB)" if lightmapping else ""))
    return 0


def _named(objs: list, names: list[str] | None, kind: str) -> list:
    """``objs``, or those of ``names`` (all when None or empty); CommandError for a name that
    is not one of them."""
    if not names:
        return objs
    have = {o.name for o in objs}
    unknown = [n for n in names if n not in have]
    if unknown:
        raise CommandError(f"no {kind} named {', '.join(unknown)} "
                           f"(have: {', '.join(sorted(have)) or 'none'})")
    return [o for o in objs if o.name in names]
