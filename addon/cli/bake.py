"""``bo2 bake``: the light probes (or lightmaps) of a .blend file baked into its own bake
folder, with a progress bar; the .blend saved, declaring (or packing) the new files."""

from __future__ import annotations

import sys
import time
from pathlib import Path

from ..blender import interrupt
from . import CommandError, load_blend, on_cluster
from .terminal import progress_bar, quiet_blender, stderr_copy


@on_cluster
def run(args, cluster) -> int:
    """Bake the light probes, or with ``--lightmaps`` the lightmaps, of a .blend file (on the
    Dask cluster of ``--scheduler``)."""
    lightmapping = args.lightmaps is not None
    if lightmapping and cluster is not None and args.backend == "cycles":
        raise CommandError("--backend cycles bakes lightmaps on this machine only: drop "
                           "--scheduler, or bake them with --backend bo2")
    scene = load_blend(Path(args.scene), bakes=lightmapping)
    from ..blender import bake, bake_files, lightmaps, probes
    from ..cluster.session import ClusterError
    from ..core.render.job import Cancelled, Warnings

    if cluster is not None and not lightmapping:  # (a lightmap bake's workers need no file)
        with quiet_blender():
            cluster.ship()
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
    if args.pack is not None:
        scene.bo2.bake_pack = args.pack
    start = time.perf_counter()
    warnings = Warnings()
    terminal = stderr_copy()  # the progress bar passes Blender's silencing
    try:
        folder = bake_files.file_folder(scene)
        with quiet_blender():
            if lightmapping:
                folder = folder / bake_files.LIGHTMAPS
                steps = bake.lightmap_steps(scene, objs, warnings, backend=args.backend.upper(),
                                            cluster=cluster)
            else:
                steps = bake.bake_steps(scene, objs, args.backend.upper(), warnings,
                                        cluster=cluster)
            try:
                count = _drive(steps, lambda fraction: progress_bar(terminal, fraction, start))
            except Cancelled:  # a capture stopped by Ctrl-C
                raise KeyboardInterrupt from None
            except ClusterError as exc:
                raise CommandError(f"{exc}; nothing was written, the previous bake files "
                                   "are as they were") from None
    except probes.BakeError as exc:
        raise CommandError(str(exc)) from None
    finally:
        terminal.write("\n")
        terminal.close()
        for message in warnings:  # a failed bake's too
            print(f"bo2: warning: {message}", file=sys.stderr)
    size = sum(p.stat().st_size for p in map(bake_files.path, objs) if p and p.is_file())
    seconds = time.perf_counter() - start
    _save(Path(args.scene))
    print(f"baked {count} {what}{'s' * (count != 1)} into {folder} in {seconds:.2f} s "
          f"({size / 2**20:.2f} MiB{', packed into the .blend' if scene.bo2.bake_pack else ''})"
          f"; saved {args.scene}")
    return 0


def _drive(steps, progress) -> int:
    """Run a bake generator to its end, ``progress(fraction)`` after each step, Ctrl-C
    checked between steps (closing the generator writes nothing); what it returns."""
    while True:
        interrupt.check()
        try:
            fraction = next(steps)
        except StopIteration as done:
            return done.value
        progress(fraction)


def _save(path: Path) -> None:
    """Save the .blend in place (Blender writes a temporary file and renames it), so that it
    declares its new bakes; CommandError when it cannot."""
    import bpy

    with quiet_blender():
        try:
            bpy.ops.wm.save_mainfile(filepath=str(path.resolve()))
        except RuntimeError as exc:
            raise CommandError(f"{path}: the bakes are written, but the .blend could not be "
                               f"saved ({str(exc).strip().splitlines()[-1]}); bake again once "
                               "it can be") from None


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
