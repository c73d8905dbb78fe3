"""The GPU backend's modules load nothing heavy when imported (the engine imports them in
every session): not Blender's ``bpy`` or ``gpu`` (imported inside the functions that draw),
not numba (the kernels load with their progress and their errors: ``kernels.load``)."""

import ast
import subprocess
import sys
from pathlib import Path

GPU_BACKEND = Path(__file__).resolve().parents[2] / "addon" / "gpu_backend"


def test_no_module_imports_bpy():
    for path in GPU_BACKEND.glob("*.py"):
        for node in ast.walk(ast.parse(path.read_text())):
            names = ([a.name for a in node.names] if isinstance(node, ast.Import) else
                     [node.module or ""] if isinstance(node, ast.ImportFrom) else [])
            assert not any(n == "bpy" or n.startswith("bpy.") for n in names), path.name


def test_importing_loads_neither_gpu_nor_numba():
    modules = [f"bo2_lighting.addon.gpu_backend.{p.stem}" for p in GPU_BACKEND.glob("*.py")
               if p.stem != "__init__"]
    code = ("import sys\n" + "".join(f"import {m}\n" for m in modules)
            + "print(sorted(m for m in ('bpy', 'gpu', 'numba', 'llvmlite') if m in sys.modules))")
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          timeout=120)
    assert done.returncode == 0, done.stderr
    assert done.stdout.strip() == "[]", done.stdout
