"""What a Dask worker runs for the ``bo2`` commands (``session`` submits it): the shipped .blend
opened once and kept, a probe bake's looks and captures, a frame, a scene's review.

A worker process holds one .blend at a time (``bpy`` has one main file): the tasks of one
command find it open; another file's task opens that one. Blender is used from one thread of
the process only, the one that imported it (Blender takes it for its main thread: another
thread's call crashes it), so every task hands its work to that thread (``_in_blender``) and
waits, and a worker's tasks run one at a time whatever its thread count. Also Dask's preload
module (``dask worker --preload bo2_lighting.addon.cluster.tasks``): ``dask_setup`` loads
Blender and the compiled kernels when the worker starts.
"""

from __future__ import annotations

import atexit
import concurrent.futures
import functools
import queue
import tempfile
import threading
from pathlib import Path

_open: dict = {}  # the open file: {"digest", "folder", "path", "probes": {key: grabbers}}
_work: queue.Queue = queue.Queue()  # (function, its future) for Blender's thread
_thread: list[threading.Thread] = []


def _blender_thread() -> None:
    while True:
        fn, future = _work.get()
        if future.set_running_or_notify_cancel():
            try:
                future.set_result(fn())
            except BaseException as exc:  # noqa: BLE001 - handed to the task's thread
                future.set_exception(exc)


def _in_blender(fn) -> concurrent.futures.Future:
    """``fn()`` on the process's Blender thread (started on first use)."""
    if not _thread:
        _thread.append(threading.Thread(target=_blender_thread, daemon=True,
                                        name="bo2 Blender"))
        _thread[0].start()
    future = concurrent.futures.Future()
    _work.put((fn, future))
    return future


class Mismatch(Exception):
    """This worker's package, code or Blender is not the client's."""


@functools.cache
def identity() -> dict:
    """What results depend on, in this process: {"BO2 Lighting": version, "code": digest of
    the core's sources and of the NumPy and numba that run them, "Blender": version or None
    without ``bpy``}. Imports ``bpy`` on the calling thread: a worker's is ``worker_identity``."""
    from .. import version
    from ..core.bakes.bounce import code_digest

    try:
        import bpy
    except ImportError:
        blender = None
    else:
        blender = bpy.app.version_string
    return {"BO2 Lighting": version(), "code": code_digest(), "Blender": blender}


def worker_identity() -> dict:
    """``identity`` of a worker, read on its Blender thread (``Client.run`` calls it on the
    worker's event loop)."""
    return _in_blender(identity).result()


def describe(who: dict) -> str:
    """``identity`` in words."""
    if who.get("Blender") is None:
        return f"BO2 Lighting {who['BO2 Lighting']} without the bpy module"
    return f"BO2 Lighting {who['BO2 Lighting']} (code {who['code']}) with Blender {who['Blender']}"


def check(expected: dict) -> None:
    """Raise ``Mismatch`` naming both when this worker is not ``expected`` (``identity``; on
    Blender's thread)."""
    mine = identity()
    if mine != expected:
        raise Mismatch(f"this worker runs {describe(mine)}, the client {describe(expected)}")


def _own_bpy_path() -> None:
    """Drop from ``sys.path`` the folders of Blender's own scripts that a parent process which
    had imported ``bpy`` passes on to the workers it spawns (a local cluster started after
    ``import bpy``): their ``bpy`` package would shadow the ``bpy`` module's."""
    import sys

    if "bpy" not in sys.modules:
        sys.path[:] = [p for p in sys.path
                       if not {"bpy", "scripts"} <= set(Path(p).parts)]


def hold(data):
    """``data`` itself: a task that holds what the tasks of a command share (``session``)."""
    return data


def _large_arrays_kept() -> None:
    """Dask's nanny starts a worker with MALLOC_TRIM_THRESHOLD_=65536 (memory given back to
    the system at once), which pins glibc's mmap threshold at 128 KiB: every large array is
    then a fresh mapping and its page faults (a reflection probe's capture and prefilter took
    1.9 times as long). Back to glibc's steady state for large arrays: mapped above 32 MiB,
    trimmed above 64 MiB (``mallopt``; glibc only)."""
    import ctypes
    import ctypes.util

    try:
        libc = ctypes.CDLL(ctypes.util.find_library("c") or "libc.so.6")
        if hasattr(libc, "mallopt") and hasattr(libc, "gnu_get_libc_version"):
            libc.mallopt(-3, 32 << 20)  # M_MMAP_THRESHOLD
            libc.mallopt(-1, 64 << 20)  # M_TRIM_THRESHOLD
    except OSError:  # no C library to tune (Windows)
        pass


def dask_setup(worker=None) -> None:
    """Dask's preload hook: Blender, the add-on, its modules and the kernels loaded on
    Blender's thread before the worker takes tasks (so that no other thread imports them at
    the same time, unpickling a task's arguments); large arrays allocated as alone
    (``_large_arrays_kept``)."""
    _large_arrays_kept()

    def load():
        _own_bpy_path()
        import bpy  # noqa: F401

        from .. import register
        from ..blender import bake, headless  # noqa: F401
        from ..core import kernels
        from . import names

        register()
        names.install()  # (a task sent from the extension in Blender names its modules)
        kernels.load(None, kernels.MODULES)
        identity()

    _in_blender(load).result()


def _task(fn, expected: dict):
    """``fn()`` on Blender's thread once this worker is ``expected`` (``check``)."""
    def run():
        check(expected)
        return fn()

    return _in_blender(run).result()


def _scene(blend: bytes, digest: str, name: str, purpose: str):
    """The scene of the shipped .blend ``blend`` (its sha256 ``digest``, its file ``name``),
    opened unless it is open already for the same ``purpose`` (a command's options change
    the open scene: another command's tasks open the file anew)."""
    import bpy

    if _open.get("digest") != (digest, purpose):
        from ..blender import headless

        if not _open:
            atexit.register(_close)  # (the last file's copy, when the worker ends)
        _close()
        folder = Path(tempfile.mkdtemp(prefix="bo2_worker_"))
        path = folder / name
        path.write_bytes(blend)
        headless.load_blend(path)
        _open.update(digest=(digest, purpose), folder=folder, path=path, probes={})
    return bpy.context.scene


def _close() -> None:
    import shutil

    if "folder" in _open:
        shutil.rmtree(_open["folder"], ignore_errors=True)
    _open.clear()


def _grabbers(backend: str, focus):
    """The open file's probe capture and look (``blender.bake.grabbers``), read once."""
    import bpy

    from ..blender import bake

    key = (backend, tuple(map(tuple, focus)))
    if key not in _open["probes"]:
        scene = bpy.context.scene
        core = bake.capture_scene(scene)
        _open["probes"][key] = bake.grabbers(scene, core, focus, backend)
    return _open["probes"][key]


def looks(expected, blend, digest, name, backend, focus, jobs) -> list:
    """``core.bakes.bake.look`` of each of ``jobs`` in the shipped .blend."""
    def run():
        from ..core.bakes import bake

        _scene(blend, digest, name, "bake")
        _, surfaces = _grabbers(backend, focus)
        return [bake.look(job, surfaces) for job in jobs]

    return _task(run, expected)


def shots(expected, blend, digest, name, backend, focus, seen, jobs) -> list:
    """``core.bakes.bake.shoot`` of each of ``jobs``, lit by the probes ``seen``."""
    def run():
        from ..core.bakes import bake

        _scene(blend, digest, name, "bake")
        grab, _ = _grabbers(backend, focus)
        return [bake.shoot(job, grab, seen) for job in jobs]

    return _task(run, expected)


def frame(expected, blend, digest, name, number, options: dict, suffix: str):
    """Frame ``number`` of the shipped .blend with ``bo2 render``'s ``options``
    (``headless.apply_render_options``' arguments): (the image file's bytes, in the format
    of ``suffix``, the render's seconds, its warnings)."""
    def run():
        from ..blender import headless

        scene = _scene(blend, digest, name, "render")
        headless.apply_render_options(scene, **options)
        headless.set_frame(scene, number)
        if not headless.has_camera(scene):
            raise ValueError("the scene has no active camera")
        with tempfile.TemporaryDirectory(prefix="bo2_frame_") as tmp:
            out = Path(tmp) / f"frame{suffix}"
            seconds, warnings = headless.render_frame(scene, out,
                                                      headless.IMAGE_FORMATS[suffix.lower()])
            return out.read_bytes(), seconds, warnings

    return _task(run, expected)


def review(expected, blend, digest, name, options: dict, old_methods: bool) -> dict:
    """The shipped .blend's scene compared with Cycles as ``bo2 report`` does
    (``blender.report.render_scene``; ``options``: ``headless.apply_comparison_options``'
    arguments): {path in the scene's folder: the file's bytes}."""
    def run():
        from ..blender import headless, report

        scene = _scene(blend, digest, name, "review")
        if not headless.has_camera(scene):
            raise ValueError("the scene has no active camera")
        headless.apply_comparison_options(scene, **options)
        with tempfile.TemporaryDirectory(prefix="bo2_review_") as tmp:
            report.render_scene(scene, headless.view_layer(), Path(tmp), old_methods)
            return {p.relative_to(tmp).as_posix(): p.read_bytes()
                    for p in sorted(Path(tmp).rglob("*")) if p.is_file()}

    return _task(run, expected)


def gathers(expected, g, radiance, rays: int, jobs: list) -> list:
    """``core.bakes.lightmap_bake.gather`` of each of ``jobs`` ((target, lo, hi) each) in the
    context ``g``, from the lightmapped surfaces' ``radiance``."""
    def run():
        from ..core.bakes import lightmap_bake

        return [lightmap_bake.gather(g, k, lo, hi, rays, radiance) for k, lo, hi in jobs]

    return _task(run, expected)
