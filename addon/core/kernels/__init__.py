"""Compiled kernels: the renderer's hot loops as numba-compiled Python, one job per module.

Every kernel is ``@njit(SIGNATURE, cache=True, nogil=True)``: compiled for its explicit
signature when its module is first imported (so nothing compiles in the middle of a render),
cached on disk (``configure``), and free of Python's lock, so the render's own tile threads run
kernels side by side. numba's own parallel threading layers are not used (Blender runs its
own TBB, and numba's workqueue layer aborts the process on concurrent calls). Each kernel has a
NumPy reference, the talk's formula in ``brdf.py``, ``env_brdf.py``, ``sh.py`` or the readable
NumPy of the module that calls it, which a test holds it to.

numba 0.68.1 with llvmlite 0.50.0 is bundled in the extension's zip as wheels (Python 3.11, 3.13
and 3.14); the macOS Intel zip bundles numba 0.62.1 with llvmlite 0.45.1, the last release with
wheels for it (``bundled_numba``). Another extension can bring another numba into Blender's
shared site-packages, so ``check()`` says exactly what was found.

Modules: ``indirect`` (SH irradiance, normalized prefiltered reflections), ``occlusion``
(ground-truth-based ambient occlusion), ``raster``
(projection, set-up, scan conversion with the depth test, resolve; shadow-map pyramids),
``shading`` (direct light: incidence and the talk's BRDF; the shaded points' surface; the
passes' assembly and accumulation), ``shadows`` (the shadow filter, point by point),
``textures`` (sRGB decode by table, mip chains, filtered look-ups).
"""

from __future__ import annotations

import errno
import hashlib
import importlib
import importlib.metadata
import json
import os
import pickle
import platform
import subprocess
import sys
import threading
import time
from pathlib import Path

from ..system.machine import limit_note


def bundled_numba(system: str = sys.platform, machine: str = platform.machine()) -> str:
    """The numba version the zip of this platform bundles: 0.62.1 on macOS Intel (its last
    release there), else 0.68.1."""
    intel_mac = system == "darwin" and machine.lower() in ("x86_64", "amd64", "i386")
    return "0.62.1" if intel_mac else "0.68.1"


NUMBA_VERSION = bundled_numba()
FIRST_RUN_MESSAGE = "Compiling BO2 kernels (first run only)"
LOADING_MESSAGE = "Loading BO2 kernels"
# Longest to compile first, so that side-by-side compiles end together
MODULES = ("raster", "shadows", "textures", "lightmap", "indirect", "shading", "occlusion")

__all__ = ["FIRST_RUN_MESSAGE", "KernelsUnavailable", "check", "configure", "default_cache_dir",
           "is_cached", "load", "prepare", "status", "user_cache"]


class KernelsUnavailable(RuntimeError):
    """numba is missing, of another version, or fails to load: one line for the user."""


def _found() -> str:
    try:
        import numba
    except Exception as exc:  # noqa: BLE001 - any failure to load is reported as found
        return f"none ({type(exc).__name__}: {exc})".replace("\n", " ")
    return f"numba {numba.__version__} at {Path(numba.__file__).parent}"


# What the system says when a shared library cannot be mapped for want of memory
_NO_MEMORY = ("cannot allocate memory", "failed to map segment", "out of memory")


def _load_failure(exc: BaseException) -> str:
    """The message for numba installed but failing to import: memory named when memory is
    the cause (a shared library that cannot be mapped), else the failure itself."""
    chain = []
    while exc is not None and len(chain) < 8:
        chain.append(exc)
        exc = exc.__cause__ or exc.__context__
    said = [(e, f"{type(e).__name__}: {e}".replace("\n", " ")) for e in chain]
    reasons = [r for e, r in said if str(e)]
    memory = [r for e, r in said if isinstance(e, MemoryError)
              or getattr(e, "errno", None) == errno.ENOMEM
              or any(w in str(e).lower() for w in _NO_MEMORY)]
    try:
        installed = f"numba {importlib.metadata.version('numba')}"
    except importlib.metadata.PackageNotFoundError:
        installed = "numba"
    if memory:
        return (f"BO2 Lighting ran out of memory loading its compiled kernels ({installed}: "
                f"{memory[0]}){limit_note()}; close other programs or raise the limit")
    return (f"BO2 Lighting's {installed} is installed but fails to load "
            f"({'; '.join(reasons[:3]) or type(chain[0]).__name__}); reinstall the extension "
            "from the zip of your platform")


def check() -> None:
    """Raise ``KernelsUnavailable`` unless numba ``NUMBA_VERSION`` loads: one message for a
    missing or other numba, one for a numba that fails to load (naming memory when memory is
    the cause)."""
    try:
        import numba
        version = numba.__version__
    except ModuleNotFoundError as exc:
        if exc.name != "numba":  # numba is there, something it needs is not (llvmlite)
            raise KernelsUnavailable(_load_failure(exc)) from None
        version = None
    except Exception as exc:  # noqa: BLE001 - a broken llvmlite, a library that cannot map
        raise KernelsUnavailable(_load_failure(exc)) from None
    if version != NUMBA_VERSION:
        raise KernelsUnavailable(
            f"BO2 Lighting needs numba {NUMBA_VERSION}, the version its zip bundles for this "
            f"platform ({sys.platform} {platform.machine()}); found {_found()}. Reinstall the "
            "extension from the zip of your platform")


def default_cache_dir() -> Path:
    """The per-user cache folder of compiled kernels outside Blender (the ``bo2`` command):
    ``%LOCALAPPDATA%`` on Windows, ``~/Library/Caches`` on macOS, else ``$XDG_CACHE_HOME``
    or ``~/.cache``; then ``bo2_lighting/kernels``."""
    if sys.platform == "win32":
        base = Path(os.environ.get("LOCALAPPDATA") or Path.home() / "AppData" / "Local")
    elif sys.platform == "darwin":
        base = Path.home() / "Library" / "Caches"
    else:
        base = Path(os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache")
    return base / "bo2_lighting" / "kernels"


def user_cache(name: str) -> Path:
    """A file or folder ``name`` of the engine's other caches, beside the compiled kernels'
    folder (``configure``; by default ``default_cache_dir``)."""
    return Path(os.environ.get("NUMBA_CACHE_DIR") or default_cache_dir()).parent / name


def configure(cache_dir: str | os.PathLike) -> None:
    """Cache compiled kernels in ``cache_dir``; call before the first kernel module is
    imported (a module already imported keeps the folder it compiled into)."""
    path = Path(cache_dir)
    path.mkdir(parents=True, exist_ok=True)
    os.environ["NUMBA_CACHE_DIR"] = str(path)
    if "numba" in sys.modules:
        import numba

        numba.config.CACHE_DIR = str(path)


def loaded() -> bool:
    """Whether every kernel module is imported (ready to run)."""
    return all(f"{__name__}.{module}" in sys.modules for module in MODULES)


def load(notify=None) -> None:
    """Check numba (``check``) and import every kernel module, compiling what the cache does not
    hold (the modules side by side, one child process per core: ``_compile_apart``);
    ``notify(FIRST_RUN_MESSAGE)`` is called first when that takes a while (here, or in
    ``prepare``'s worker, which this waits for). Cheap once loaded."""
    check()
    if loaded():
        return
    worker, said = _worker, False
    while worker is not None and worker.is_alive():  # to its end: a module is in sys.modules
        if notify is not None and not said and status() == FIRST_RUN_MESSAGE:  # while it runs
            notify(FIRST_RUN_MESSAGE)
            said = True
        worker.join(0.05)
    if loaded():
        return
    missing = [m for m in MODULES if not _cached(m)]
    if notify is not None and missing:
        notify(FIRST_RUN_MESSAGE)
    if len(missing) > 1:  # side by side in child processes, then imported from the cache
        _compile_apart(missing, _cores())
    for module in MODULES:
        importlib.import_module(f"{__name__}.{module}")


_worker: threading.Thread | None = None
_status = ""
_start = threading.Lock()


def status() -> str:
    """What ``prepare``'s worker is doing: ``FIRST_RUN_MESSAGE``, ``LOADING_MESSAGE``, or ""
    when it is done (or was never started)."""
    return _status


def prepare(jobs: int | None = None) -> bool:
    """Make the kernels ready off the calling thread, once per session: compile the modules
    the cache lacks in ``jobs`` child processes side by side (default: one per core), then
    import every module on a background thread. ``load`` waits for it; a failure is left for
    ``load`` to report. Returns whether a worker was started (not when numba is unusable or
    everything is loaded)."""
    global _status, _worker
    with _start:
        if _worker is not None or loaded():
            return False
        try:
            check()
        except KernelsUnavailable:
            return False
        _status = LOADING_MESSAGE
        _worker = threading.Thread(target=_prepare, args=(jobs or _cores(),),
                                   name="bo2-kernels", daemon=True)
        _worker.start()
        return True


def _cores() -> int:
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except AttributeError:  # macOS, Windows
        return max(1, os.cpu_count() or 1)


def _prepare(jobs: int) -> None:
    global _status
    try:
        missing = [m for m in MODULES if not _cached(m)]
        if missing:
            _status = FIRST_RUN_MESSAGE
            _compile_apart(missing, jobs)
        _status = LOADING_MESSAGE
        for module in MODULES:
            importlib.import_module(f"{__name__}.{module}")
    except Exception:  # noqa: BLE001, S110 - ``load`` meets the same failure and reports it
        pass
    finally:
        _status = ""


# A child process that compiles one kernel module into the cache, imported under the name the
# package has here (numba's cache refers to it): the packages above it stand in as empty ones,
# the one holding it as its folder (Blender's ``bl_ext.<repository>``)
_CHILD = """
import importlib, json, sys, types
paths, package, folder, module = json.loads(sys.argv[1])
sys.path[:0] = paths
parts = package.split(".")
for k in range(1, len(parts)):
    stub = types.ModuleType(".".join(parts[:k]))
    stub.__path__ = [folder] if k == len(parts) - 1 else []
    sys.modules[stub.__name__] = stub
importlib.import_module(package + ".addon.core.kernels." + module)
"""


def _compile_apart(modules: list[str], jobs: int) -> None:
    """Compile ``modules`` into the cache in up to ``jobs`` child processes at once (the
    compiler holds Python's lock, so threads would take turns). Without a Python to run
    (``sys.executable`` is not one), nothing: the import compiles instead; so does a module
    whose child fails or is still at it after ``CHILD_TIMEOUT`` seconds (it is stopped)."""
    if jobs < 2 or "python" not in Path(sys.executable or "").name.lower():
        return
    package = __name__.removesuffix(".addon.core.kernels")
    # kernels, core, addon, the package: as imported (numba names its cache folder by it)
    folder = str(Path(os.path.abspath(__file__)).parents[4])
    todo, running = list(modules), []  # running: (child, when it started)
    while todo or running:
        while todo and len(running) < jobs:
            args = json.dumps([sys.path, package, folder, todo.pop(0)])
            running.append((subprocess.Popen([sys.executable, "-c", _CHILD, args],
                                             stdout=subprocess.DEVNULL,
                                             stderr=subprocess.DEVNULL), time.monotonic()))
        time.sleep(0.05)
        for child, started in running:
            if child.poll() is None and time.monotonic() - started > CHILD_TIMEOUT:
                child.kill()
                child.wait()
        running = [(child, started) for child, started in running if child.poll() is None]


CHILD_TIMEOUT = 900.0  # seconds a child may take to compile one module (about 60 s on 2 cores)


if "NUMBA_CACHE_DIR" not in os.environ:  # until the host configures its own folder
    os.environ["NUMBA_CACHE_DIR"] = str(default_cache_dir())


def is_cached() -> bool:
    """Whether every kernel module has compiled code in the cache folder (else the first
    import compiles, for some seconds: show ``FIRST_RUN_MESSAGE``)."""
    return all(_cached(module) for module in MODULES)


def _cached(module: str) -> bool:
    """Whether the cache holds code of ``module``'s source as it is now, for this Python: an
    index of numba's folder for this source folder (its name and the SHA-1 of its path) whose
    stamp is the source's, as numba checks it: the SHA-256 of its content (numba 0.68), its
    modification time and size (0.62). A module's kernels compile together; functions it no
    longer has leave old indexes."""
    folder = os.environ.get("NUMBA_CACHE_DIR")
    if not folder:
        return False
    # the folder as numba names it: the module's path as imported, symbolic links kept (an
    # extension folder reached through a linked config folder)
    source = Path(os.path.dirname(os.path.abspath(__file__))) / f"{module}.py"
    here = os.path.dirname(os.path.abspath(source))
    sub = Path(folder) / f"kernels_{hashlib.sha1(here.encode()).hexdigest()}"
    try:
        stat = source.stat()
        stamps = (hashlib.sha256(source.read_bytes()).digest(), (stat.st_mtime, stat.st_size))
        for index in sub.glob(f"{module}.*.py{sys.version_info[0]}{sys.version_info[1]}.nbi"):
            with open(index, "rb") as fh:
                pickle.load(fh)  # numba's version
                if pickle.loads(fh.read())[0] in stamps:
                    return True
    except Exception:  # noqa: BLE001 - an unreadable index: not cached
        return False
    return False
