"""Where a frame can be drawn: whether this Blender can open a GPU context, asked of a child
process (a Blender with neither a display nor EGL aborts the whole process when asked for one,
so this process never asks first) and remembered on disk for this machine, binary and
environment, and the Device setting's choice."""

from __future__ import annotations

import contextlib
import hashlib
import json
import os
import socket
import subprocess
import sys
import tempfile
import time
from dataclasses import asdict, dataclass
from pathlib import Path

_MARK = "BO2-GPU"
# What the child runs: open a context (``gpu.init`` exists and is needed in background mode
# from Blender 5.2), compile a compute shader and draw into an offscreen target.
PROBE = f"""
import sys
try:
    import gpu
    if hasattr(gpu, "init"):
        gpu.init()
    info = gpu.types.GPUShaderCreateInfo()
    info.image(0, "RGBA32F", "FLOAT_2D", "img", qualifiers={{"WRITE"}})
    info.local_group_size(1, 1)
    info.compute_source("void main() {{ imageStore(img, ivec2(0), vec4(1.0)); }}")
    shader = gpu.shader.create_from_info(info)
    texture = gpu.types.GPUTexture((1, 1), format="RGBA32F")
    shader.bind()
    shader.image("img", texture)
    gpu.compute.dispatch(shader, 1, 1, 1)
    ok = float(texture.read()[0][0][0]) == 1.0
    print("{_MARK}", "OK" if ok else "NO", gpu.platform.backend_type_get(),
          gpu.platform.renderer_get(), sep="\\t")
except Exception as exc:
    print("{_MARK}", "NO", f"{{type(exc).__name__}}: {{exc}}", sep="\\t")
sys.stdout.flush()
"""


@dataclass(frozen=True)
class Device:
    """What the probe found: ``ok`` a GPU context can be had (``backend``, ``renderer``), or
    ``reason`` why not (one line)."""

    ok: bool
    backend: str = ""
    renderer: str = ""
    reason: str = ""

    @property
    def software(self) -> bool:
        """The GPU is a rasterizer in software on the CPU (``is_software``)."""
        return is_software(self.renderer)


# Renderers that draw on the CPU: Mesa's llvmpipe, softpipe and lavapipe, SwiftShader,
# Windows' basic render driver. The engine's CPU kernels are faster there (docs/gpu.md).
SOFTWARE = ("llvmpipe", "softpipe", "lavapipe", "swiftshader", "software rasterizer",
            "basic render")


def is_software(renderer: str) -> bool:
    """Whether a GPU of this name (``gpu.platform.renderer_get()``) is a software rasterizer."""
    name = renderer.lower()
    return any(word in name for word in SOFTWARE)


def auto_refusal(renderer: str) -> str | None:
    """Why the Auto device leaves a frame to the CPU on the GPU named ``renderer``, or None."""
    if is_software(renderer):
        return (f"the GPU is a software rasterizer ({renderer.split('(')[0].strip()}), slower "
                "than the CPU kernels: choose Device GPU to use it")
    return None


def probe_command(binary_path: str) -> list[str]:
    """The child's command: Blender itself in background mode, or (for the ``bpy`` module,
    whose ``binary_path`` is empty) this Python importing ``bpy``."""
    if binary_path:
        return [binary_path, "--background", "--factory-startup", "--python-exit-code", "1",
                "--python-expr", PROBE]
    return [sys.executable, "-c", "import bpy\n" + PROBE]


_probed: dict[tuple, Device] = {}

# What decides whether a context can be had besides the binary: the display, the GL/EGL
# loader's search and Mesa's choices.
ENVIRONMENT = ("DISPLAY", "WAYLAND_DISPLAY", "XDG_SESSION_TYPE", "XDG_RUNTIME_DIR",
               "LD_LIBRARY_PATH", "__EGL_VENDOR_LIBRARY_FILENAMES", "__GLX_VENDOR_LIBRARY_NAME",
               "EGL_PLATFORM", "LIBGL_ALWAYS_SOFTWARE", "GALLIUM_DRIVER",
               "MESA_LOADER_DRIVER_OVERRIDE", "DRI_PRIME", "__NV_PRIME_RENDER_OFFLOAD",
               "CUDA_VISIBLE_DEVICES", "VK_ICD_FILENAMES", "VK_DRIVER_FILES")
# An answer on disk is trusted this long (s): a driver installed or removed is seen next day.
MAX_AGE = 24 * 3600.0


def probe(command: list[str], cache_file: str | os.PathLike | None = None,
          timeout: float = 120.0) -> Device:
    """Run ``command`` (``probe_command``) once per session and read what it printed; with
    ``cache_file`` (JSON), an answer of the last ``MAX_AGE`` seconds for the same host,
    command, binary and ``ENVIRONMENT`` is read from there instead (the child costs 1-2 s).
    A child that could not run or did not end in time is asked again next session, and a
    kept "yes" is not trusted when the X display it was given is gone."""
    key = tuple(command)
    if key not in _probed:
        found = _recall(cache_file, _cache_key(command)) if cache_file else None
        if found is None:
            found, answered = _run(command, timeout)
            if cache_file and answered:
                _remember(cache_file, _cache_key(command), found)
        _probed[key] = found
    return _probed[key]


def _display_gone() -> bool:
    """Whether ``DISPLAY`` names a local X server whose socket is not there."""
    display = os.environ.get("DISPLAY", "")
    if not display.startswith(":"):
        return False
    number = display[1:].split(".")[0]
    return number.isdigit() and not Path(f"/tmp/.X11-unix/X{number}").exists()


def _cache_key(command: list[str]) -> str:
    """The host, the command, the stamps of the programs it runs (the binary; for the ``bpy``
    module, its file too) and ``ENVIRONMENT``, hashed."""
    stamps = []
    module = sys.modules.get("bpy")
    for path in (command[0], getattr(module, "__file__", None) if command[0] == sys.executable
                 else None):
        try:
            stat = os.stat(path) if path else None
            stamps.append([path, stat.st_mtime_ns, stat.st_size] if stat else None)
        except OSError:
            stamps.append(None)
    parts = [socket.gethostname(), command, stamps,
             [os.environ.get(name, "") for name in ENVIRONMENT]]
    return hashlib.sha256(json.dumps(parts).encode()).hexdigest()


def _recall(cache_file, key: str) -> Device | None:
    try:
        entry = json.loads(Path(cache_file).read_text()).get(key)
        if entry and 0 <= time.time() - float(entry["time"]) < MAX_AGE:
            found = Device(**entry["device"])
            return None if found.ok and _display_gone() else found
    except (OSError, ValueError, TypeError, KeyError, AttributeError):
        pass  # no answer yet, or an unreadable file: ask the child
    return None


def _fresh(entry, now: float) -> bool:
    try:
        return now - float(entry["time"]) < MAX_AGE
    except (TypeError, ValueError, KeyError):
        return False


def _remember(cache_file, key: str, found: Device) -> None:
    """Add the answer to ``cache_file``, replaced atomically; a cache that cannot be
    written is no error (the next session asks again)."""
    path = Path(cache_file)
    try:
        entries = json.loads(path.read_text())
        if not isinstance(entries, dict):
            entries = {}
    except (OSError, ValueError):
        entries = {}
    now = time.time()
    entries = {k: v for k, v in entries.items() if _fresh(v, now)}
    entries[key] = {"time": now, "device": asdict(found)}
    tmp = None
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=path.name, suffix=".tmp")
        with os.fdopen(fd, "w") as fh:
            json.dump(entries, fh)
        os.replace(tmp, path)
        tmp = None
    except OSError:
        pass
    finally:
        if tmp is not None:
            with contextlib.suppress(OSError):
                os.unlink(tmp)


def _run(command: list[str], timeout: float) -> tuple[Device, bool]:
    """(what the child says, whether that is its answer to keep: not when it could not run
    or did not end in time)."""
    try:
        done = subprocess.run(command, capture_output=True, text=True, timeout=timeout,
                              stdin=subprocess.DEVNULL)
    except (OSError, subprocess.SubprocessError) as exc:
        return Device(False, reason=f"the GPU probe could not run: {exc}"), False
    for line in done.stdout.splitlines():
        parts = line.split("\t")
        if parts[0] == _MARK:
            if parts[1] == "OK":
                return Device(True, parts[2], parts[3] if len(parts) > 3 else ""), True
            return Device(False, reason=parts[2] if len(parts) > 2 else "unknown"), True
    lines = [s for s in done.stderr.splitlines() if s.strip() and "EGL Error" not in s]
    last = lines[-1].strip() if lines else ""
    return Device(False, reason=f"Blender stopped while opening a GPU context (exit "
                               f"{done.returncode}){': ' + last if last else ''}"), True


_opened: list[bool] = []


def open_context(binary_path: str, cache_file: str | os.PathLike | None = None) -> Device:
    """Probe this Blender (``probe``) and, when a context can be had, open it in this
    process once (``gpu.init``, which background mode needs from Blender 5.2)."""
    found = probe(probe_command(binary_path), cache_file)
    if found.ok and not _opened:
        import gpu

        if hasattr(gpu, "init"):
            gpu.init()
        _opened.append(True)
    return found
