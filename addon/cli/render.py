"""``bo2 render``: frames of .blend files to images, one per frame; a batch goes on when one
file or frame fails, with a progress bar and an optional JSON summary."""

from __future__ import annotations

import json
import os
import sys
import time
from pathlib import Path

from ..blender import headless, interrupt
from ..core.system import atomic
from . import CommandError, load_blend, on_cluster, patterns, too_many_samples, usage_error
from .terminal import BatchProgress, quiet_blender


def check_output(out: Path, create: bool = True) -> str:
    """The image format of ``out`` (``headless.IMAGE_FORMATS``); CommandError if it cannot be
    written. ``create`` makes its folder, otherwise the nearest existing folder above it must be
    writable."""
    if out.is_dir():
        raise CommandError(f"{out}: is a folder; give an image file name, such as "
                           f"{out / 'frame.png'}")
    fmt = headless.IMAGE_FORMATS.get(out.suffix.lower())
    if fmt is None:
        raise CommandError(f"{out}: unknown image type, use one of "
                           f"{', '.join(headless.IMAGE_FORMATS)}")
    if len(os.fsencode(out.name)) > 255 or len(os.fsencode(out.absolute())) > 4095:
        raise CommandError(f"{out.name[:40]}...: the output path is too long")
    folder = out.parent
    if create:
        folder.mkdir(parents=True, exist_ok=True)
    while not folder.exists() and folder != folder.parent:
        folder = folder.parent
    if not folder.is_dir() or not os.access(folder, os.W_OK):
        raise CommandError(f"{folder}: output folder is not writable")
    return fmt


def render_frame(scene, out: Path) -> tuple[float, list[str]]:
    """Render the scene's current frame to ``out``; returns the render time in seconds and the
    engine's warnings."""
    fmt = check_output(out)
    with quiet_blender():
        seconds, warnings = headless.render_frame(scene, out, fmt)
    if not out.exists():
        raise CommandError(f"{out}: the render did not produce an image")
    return seconds, warnings


def fetch_frame(cluster, future, out: Path) -> tuple[float, list[str]]:
    """A frame rendered on the cluster (``cluster.tasks.frame``), written to ``out``
    (replaced atomically); its render time and warnings."""
    from ..cluster.session import ClusterError

    check_output(out)
    try:
        data, seconds, warnings = cluster.result(future)
    except ClusterError as exc:
        raise CommandError(str(exc)) from None
    with interrupt.writing():
        atomic.write_bytes(out, data)
    return seconds, warnings


def _submit(cluster, scene, blend: Path, frames, args) -> dict:
    """The frames of ``blend``, open as ``scene`` (its current frame for None), sent to the
    cluster, the file shipped: {frame: its task}."""
    from ..cluster import tasks

    with quiet_blender():
        cluster.ship()
    suffix = patterns.output_path(args.output, blend.stem, 0).suffix
    options = {"engine": args.engine, "resolution": args.resolution, "samples": args.samples,
               "specular_model": args.specular_model, "all_passes": args.all_passes}
    return {frame: cluster.submit(tasks.frame, headless.current_frame(scene) if frame is None
                                  else frame, options, suffix) for frame in frames}


def _error_text(exc: Exception) -> str:
    text = str(exc) if isinstance(exc, CommandError) else f"{type(exc).__name__}: {exc}"
    return " ".join(text.split())


def _write_summary(path: Path, args, images: list[dict], seconds: float,
                   interrupted: bool = False) -> None:
    ok = sum(image["status"] == "ok" for image in images)
    warnings = list(dict.fromkeys(w for image in images for w in image["warnings"]))
    summary = {"engine": args.engine, "output": args.output, "total": len(images), "ok": ok,
               "failed": len(images) - ok, "seconds": round(seconds, 3),
               "interrupted": interrupted, "warnings": warnings, "images": images}
    try:
        with interrupt.writing():  # a farm polling the file never reads half of it
            atomic.write_text(path, json.dumps(summary, indent=2, allow_nan=False) + "\n")
    except OSError as exc:
        raise CommandError(f"{path}: cannot write the summary ({exc.strerror})") from None


@on_cluster
def run(args, cluster) -> int:
    """Render frames of .blend files, one image each; the others go on when one fails (on
    the Dask cluster of ``--scheduler``: every frame of a file sent out at once, the images
    written here as they come, in order)."""
    # --samples is checked here, where the engine is known
    if args.samples and (reason := too_many_samples(args.samples, args.engine)):
        usage_error(f"argument --samples: {reason}")
    try:
        patterns.check_pattern(args.output)
    except ValueError as exc:
        usage_error(f"-o {args.output!r}: {exc}")
    blends = [Path(name) for name in args.scenes]
    frames = args.frames or ([args.frame] if args.frame is not None else None)
    per_file = frames or [None]  # None: the file's current frame, known once it is loaded
    batch = len(blends) * len(per_file) > 1
    uses_frame = patterns.uses_frame(args.output)
    # Every path is planned before anything renders (for current frames, the same frame in
    # every file is assumed); folders are checked now when the paths are known, made later.
    try:
        planned = patterns.plan(args.output, blends, frames)
    except ValueError as exc:
        usage_error(str(exc))
    for out, _ in planned.values():
        if frames or not uses_frame or headless.IMAGE_FORMATS.get(out.suffix.lower()) is None:
            check_output(out, create=False)  # e.g. an unknown image type: before loading
    summary = Path(args.summary) if args.summary else None
    if summary is not None:
        if summary.is_dir():
            raise CommandError(f"{summary}: --summary is a folder; give a .json file name")
        summary.parent.mkdir(parents=True, exist_ok=True)
        if not os.access(summary.parent, os.W_OK):
            raise CommandError(f"{summary.parent}: summary folder is not writable")

    start = time.perf_counter()
    images: list[dict] = []
    written: set[str] = set()
    progress = BatchProgress(len(planned)) if batch else None

    def record(blend, frame, out, seconds, error=None, warnings=()):
        images.append({"file": str(blend), "scene": blend.stem, "frame": frame,
                       "output": None if out is None else str(out),
                       "status": "ok" if error is None else "failed",
                       "seconds": round(seconds, 3), "error": error,
                       "warnings": list(warnings)})

    said: set[str] = set()  # each warning is printed once per command

    def say(line, stream):
        if progress is None:
            print(line, file=stream)
        else:
            progress.message(line, stream)

    try:
        for blend in blends:
            interrupt.check()
            if progress is not None:
                progress.draw(f"{blend.name} (loading)")
            try:
                scene = load_blend(blend)  # once per file
                sent = _submit(cluster, scene, blend, per_file, args) if cluster else {}
                headless.apply_render_options(scene, args.engine, args.resolution, args.samples,
                                              args.specular_model, args.all_passes)
            except Exception as exc:  # noqa: BLE001 - the other files still render
                for frame in per_file:
                    record(blend, frame, None, 0.0, _error_text(exc))
                if progress is not None:
                    progress.done += len(per_file)
                say(f"bo2: error: {_error_text(exc)}", sys.stderr)
                continue
            for frame in per_file:
                interrupt.check()
                began, out, warnings = time.perf_counter(), None, []
                number = headless.current_frame(scene) if frame is None else frame
                where = f"{blend} frame {number}" if batch else f"{blend}"
                if progress is not None:
                    progress.draw(f"{blend.name} frame {number}")
                try:
                    if frame is not None:
                        with quiet_blender():
                            headless.set_frame(scene, frame)
                    if not headless.has_camera(scene):  # per frame: markers can bind cameras
                        raise CommandError("the scene has no active camera")
                    out = patterns.output_path(args.output, blend.stem, number)
                    key = patterns.path_key(out)
                    if key in written:
                        raise CommandError(f"{out}: already written by this command")
                    if cluster is not None:
                        seconds, warnings = fetch_frame(cluster, sent[frame], out)
                    else:
                        seconds, warnings = render_frame(scene, out)
                    written.add(key)
                except Exception as exc:  # noqa: BLE001 - the other frames still render
                    error = f"{where}: {_error_text(exc)}"
                    line, stream = f"bo2: error: {error}", sys.stderr
                else:
                    error = None
                    line = f"{args.engine}: {out} (rendered in {seconds:.2f} s)"
                    stream = sys.stdout
                record(blend, number, out, time.perf_counter() - began, error, warnings)
                if progress is not None:
                    progress.done += 1
                for warning in warnings:
                    if warning not in said:
                        said.add(warning)
                        say(f"bo2: warning: {blend.name}: {warning}", sys.stderr)
                say(line, stream)
    except KeyboardInterrupt:  # the finished images stay; the summary says what was done
        interrupt.settle()  # (ending by itself: the deadline must not cut the summary)
        if summary is not None:
            try:
                _write_summary(summary, args, images, time.perf_counter() - start,
                               interrupted=True)
            except CommandError as exc:
                print(f"bo2: error: {exc}", file=sys.stderr)
        raise
    finally:
        if progress is not None:
            progress.close()
    failed = sum(image["status"] != "ok" for image in images)
    if summary is not None:
        _write_summary(summary, args, images, time.perf_counter() - start)
    if batch:
        print(f"rendered {len(images) - failed} of {len(images)} images in "
              f"{time.perf_counter() - start:.2f} s"
              + (f", summary: {summary}" if summary is not None else ""))
    return 1 if failed else 0
