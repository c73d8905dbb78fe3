"""The core never imports Blender: every module under addon/core and every core test is parsed
(not imported) and its imports are checked against bpy, mathutils and gpu."""

import ast
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
FORBIDDEN = {"bpy", "mathutils", "gpu", "bmesh", "bl_math"}
FILES = sorted((ROOT / "addon" / "core").rglob("*.py")) + sorted(
    (ROOT / "tests" / "core").rglob("*.py")
)


def imported_roots(path: Path) -> set[str]:
    roots = set()
    for node in ast.walk(ast.parse(path.read_text(), filename=str(path))):
        if isinstance(node, ast.Import):
            roots.update(alias.name.split(".")[0] for alias in node.names)
        elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
            roots.add(node.module.split(".")[0])
    return roots


def test_core_files_exist():
    assert len(FILES) >= 5


@pytest.mark.parametrize("path", FILES, ids=lambda p: str(p.relative_to(ROOT)))
def test_no_blender_imports(path):
    assert not imported_roots(path) & FORBIDDEN


def test_checker_catches_an_import(tmp_path):
    bad = tmp_path / "bad.py"
    bad.write_text("def f():\n    from bpy import data\n    import mathutils.geometry\n")
    assert imported_roots(bad) & FORBIDDEN == {"bpy", "mathutils"}
