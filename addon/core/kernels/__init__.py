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

Modules: ``indirect`` (SH irradiance, normalized prefiltered reflections), ``lightmap`` (the
lightmap bakes' texels, rays and filters), ``occlusion``
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
# The modules a frame needs; "lightmap" serves the lightmap bakes alone
FRAME_MODULES = ("raster", "shadows", "textures", "indirect", "shading", "occlusion")
MODULES = (*FRAME_MODULES, "lightmap")
# Seconds each module takes to compile on one core, numba's start-up left out (numba 0.68.1,
# 2 cores at 2.2 GHz; "lightmap" with the "indirect" and "shading" it imports): the shares of
# the children that compile side by side (``_shares``)
COMPILE_SECONDS = {"raster": 13.5, "shadows": 6.5, "textures": 6.0, "indirect": 4.0,
                   "shading": 3.0, "occlusion": 1.4, "lightmap": 12.0}

__all__ = ["FIRST_RUN_MESSAGE", "FRAME_MODULES", "MODULES", "KernelsUnavailable", "check",
           "configure", "default_cache_dir", "is_cached", "load", "prepare", "status",
           "user_cache"]


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


def loaded(modules=MODULES) -> bool:
    """Whether every module of ``modules`` is imported (ready to run)."""
    return all(f"{__name__}.{module}" in sys.modules for module in modules) and (
        _worker is None or not _worker.is_alive() or set(modules) <= _ready)


def load(notify=None, modules=MODULES) -> None:
    """Check numba (``check``) and import ``modules`` (a render: ``FRAME_MODULES``),
    compiling what the cache does not hold (side by side, one child process per core:
    ``_compile_apart``); ``notify(FIRST_RUN_MESSAGE)`` is called first when that takes a while
    (here, or in ``prepare``'s worker, which this waits for until it has ``modules``). Cheap
    once loaded."""
    check()
    if loaded(modules):  # (an import under way on another thread: the caller's import waits)
        return
    worker, said = _worker, False
    # a module is in sys.modules from its import's start: the worker's are ready at its word
    while worker is not None and worker.is_alive() and not set(modules) <= _ready:
        if notify is not None and not said and status() == FIRST_RUN_MESSAGE:  # while it runs
            notify(FIRST_RUN_MESSAGE)
            said = True
        worker.join(0.05)
    if all(f"{__name__}.{module}" in sys.modules for module in modules):
        for module in modules:  # (waits for an import under way on another thread)
            _imported(module)
        return
    missing = [m for m in modules if not _cached(m)]
    if notify is not None and missing:
        notify(FIRST_RUN_MESSAGE)
    if len(missing) > 1:  # side by side in child processes, then imported from the cache
        _compile_apart(missing, _cores())
    for module in modules:
        _imported(module)


_worker: threading.Thread | None = None
_ready: set[str] = set()  # the modules the worker has imported
_status = ""
_start = threading.Lock()


def status() -> str:
    """What ``prepare``'s worker is doing: ``FIRST_RUN_MESSAGE``, ``LOADING_MESSAGE``, or ""
    when it is done (or was never started)."""
    return _status


def prepare(jobs: int | None = None) -> bool:
    """Make the kernels ready off the calling thread, once per session: compile the modules
    the cache lacks in ``jobs`` child processes side by side (default: one per core), the
    frame's first, importing each group on a background thread as it is ready. ``load``
    waits for it; a failure is left for ``load`` to report. Returns whether a worker was
    started (not when numba is unusable or everything is loaded)."""
    global _status, _worker
    with _start:
        if _worker is not None or loaded():
            return False
        try:
            check()
        except KernelsUnavailable:
            return False
        _status = LOADING_MESSAGE
        worker = threading.Thread(target=_prepare, args=(jobs or _cores(),),
                                  name="bo2-kernels", daemon=True)
        worker.start()
        _worker = worker
        return True


def _cores() -> int:
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except AttributeError:  # macOS, Windows
        return max(1, os.cpu_count() or 1)


def _prepare(jobs: int) -> None:
    global _status
    try:
        later = tuple(m for m in MODULES if m not in FRAME_MODULES)
        for group in (FRAME_MODULES, later):
            missing = [m for m in group if not _cached(m)]
            if missing:
                _status = FIRST_RUN_MESSAGE
                _compile_apart(missing, jobs)
            _status = LOADING_MESSAGE
            for module in group:
                _imported(module)
            if group is later:
                _status = ""  # (before the word that every module is ready)
            _ready.update(group)
    except Exception:  # noqa: BLE001, S110 - ``load`` meets the same failure and reports it
        pass
    finally:
        _status = ""


# A child process that compiles kernel modules into the cache, imported under the name the
# package has here (numba's cache refers to it): the packages above it stand in as empty ones,
# the one holding it as its folder (Blender's ``bl_ext.<repository>``)
_CHILD = """
import importlib, json, sys, types
paths, package, folder, modules = json.loads(sys.argv[1])
sys.path[:0] = paths
parts = package.split(".")
for k in range(1, len(parts)):
    stub = types.ModuleType(".".join(parts[:k]))
    stub.__path__ = [folder] if k == len(parts) - 1 else []
    sys.modules[stub.__name__] = stub
kernels = importlib.import_module(package + ".addon.core.kernels")
for module in modules:
    try:
        kernels._imported(module)
    except Exception:  # the parent meets it again, and reports it
        pass
"""


def _shares(modules: list[str], jobs: int) -> list[list[str]]:
    """``modules`` dealt to at most ``jobs`` children, each next longest to the child with
    the least to do (``COMPILE_SECONDS``), so that they end together; each child starts
    numba once."""
    shares: list[list[str]] = [[] for _ in range(min(jobs, len(modules)))]
    for module in sorted(modules, key=lambda m: -COMPILE_SECONDS.get(m, 10.0)):
        min(shares, key=lambda s: sum(COMPILE_SECONDS.get(m, 10.0) for m in s)).append(module)
    return shares


def _compile_apart(modules: list[str], jobs: int) -> None:
    """Compile ``modules`` into the cache in up to ``jobs`` child processes at once (the
    compiler holds Python's lock, so threads would take turns; ``_shares``). Without a Python
    to run (``sys.executable`` is not one), nothing: the import compiles instead; so do the
    modules of a child that fails or is still at it after ``CHILD_TIMEOUT`` seconds (it is
    stopped)."""
    if jobs < 2 or "python" not in Path(sys.executable or "").name.lower():
        return
    package = __name__.removesuffix(".addon.core.kernels")
    # kernels, core, addon, the package: as imported (numba names its cache folder by it)
    folder = str(Path(os.path.abspath(__file__)).parents[4])
    running = []
    for share in _shares(modules, jobs):
        try:
            running.append((subprocess.Popen(
                [sys.executable, "-c", _CHILD, json.dumps([sys.path, package, folder, share])],
                stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL), time.monotonic()))
        except OSError:  # (no process to spare: the ones started go on, the import does
            break        # the rest)
    while running:
        time.sleep(0.05)
        for child, started in running:
            if child.poll() is None and time.monotonic() - started > CHILD_TIMEOUT:
                child.kill()
                child.wait()
        running = [(child, started) for child, started in running if child.poll() is None]


CHILD_TIMEOUT = 900.0  # seconds a child may take to compile its modules (about 25 s on 2 cores)


if "NUMBA_CACHE_DIR" not in os.environ:  # until the host configures its own folder
    os.environ["NUMBA_CACHE_DIR"] = str(default_cache_dir())
    if "numba" in sys.modules:  # (another extension imported it first)
        sys.modules["numba"].config.CACHE_DIR = os.environ["NUMBA_CACHE_DIR"]


def is_cached() -> bool:
    """Whether every kernel module has compiled code in the cache folder (else the first
    import compiles, for some seconds: show ``FIRST_RUN_MESSAGE``)."""
    return all(_cached(module) for module in MODULES)


def _marker(module: str) -> Path | None:
    """The file that says ``module``'s kernels are all in the cache: in numba's folder for the
    kernels' source folder (its name and the SHA-1 of its path as imported, symbolic links
    kept, as numba names it), named by what numba's cache entries depend on: the module's
    content, modification time and size (numba 0.62 checks those), numba's and Python's
    versions and the host's processor. None without a writable cache folder (numba then caches
    elsewhere) or a readable source."""
    folder = os.environ.get("NUMBA_CACHE_DIR")
    if not folder or not os.access(folder, os.W_OK):
        return None
    here = os.path.dirname(os.path.abspath(__file__))
    source = Path(here, f"{module}.py")
    try:
        stat = source.stat()
        key = hashlib.sha256(source.read_bytes())
    except OSError:
        return None
    key.update(f"{stat.st_mtime} {stat.st_size} {_processor()}".encode())
    sub = Path(folder) / f"kernels_{hashlib.sha1(here.encode()).hexdigest()}"
    return sub / (f"{module}.{key.hexdigest()[:20]}.numba{NUMBA_VERSION}"
                  f".py{sys.version_info[0]}{sys.version_info[1]}.ready")


def _processor() -> str:
    """The host's processor as numba compiles for it (its name and features)."""
    try:
        from llvmlite import binding
        from numba.core import config
    except Exception:  # noqa: BLE001 - no numba: no marker matters
        return ""
    return (f"{config.CPU_NAME or binding.get_host_cpu_name()} "
            f"{config.CPU_FEATURES or binding.get_host_cpu_features().flatten()}")


def _cached(module: str) -> bool:
    """Whether the cache holds every kernel of ``module``'s source as it is now, for this
    numba, Python and processor (``_marker``; numba writes its index per kernel as each
    compiles, so a compile cut short leaves some)."""
    marker = _marker(module)
    return marker is not None and marker.is_file()


def _imported(module: str) -> None:
    """Import ``module``, compiling what the cache lacks (the module marks itself whole in
    the cache at its end: ``mark_cached``)."""
    importlib.import_module(f"{__name__}.{module}")


def mark_cached(name: str) -> None:
    """Called at the end of each kernel module ``name`` (its ``__name__``): every kernel of it
    is compiled or loaded, so the cache holds them all (``_marker``)."""
    marker = _marker(name.rpartition(".")[2])
    if marker is not None and not marker.is_file():
        try:
            marker.parent.mkdir(parents=True, exist_ok=True)
            marker.touch()
        except OSError:  # (the marker is a saving only)
            pass
