"""GPU tests run in a ``bpy`` whose ``gpu`` module can open a context in background mode
(Blender 5.2 LTS, through EGL or a display). The context is probed in a child process first (a
Blender without one aborts); without one the tests are skipped, or fail when
``BO2_REQUIRE_GPU`` is set (``make test`` sets it where the machine has EGL)."""

import os
import sys
from pathlib import Path

import bpy
import pytest

from bo2_lighting.addon.gpu_backend import device

sys.path.insert(0, str(Path(__file__).resolve().parent))

_opened = []


@pytest.fixture(autouse=True, scope="session")
def gpu_context():
    found = device.probe(device.probe_command(bpy.app.binary_path))
    if not found.ok:
        if os.environ.get("BO2_REQUIRE_GPU"):
            pytest.fail(f"BO2_REQUIRE_GPU is set but no GPU context: {found.reason}")
        pytest.skip(f"no GPU context: {found.reason}")
    import gpu

    if not _opened and hasattr(gpu, "init"):
        gpu.init()
        _opened.append(True)
    return found
