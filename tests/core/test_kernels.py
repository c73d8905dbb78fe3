"""The kernels' set-up: numba's version checked with one clear message, compiled once into the
cache folder (a fresh folder compiles and says so; the next process loads without a word)."""

import importlib.metadata
import subprocess
import sys
import types

import pytest

from bo2_lighting.addon.core import kernels


def test_wrong_or_missing_numba_is_one_clear_message(monkeypatch):
    kernels.check()  # the pinned numba of this environment
    fake = types.ModuleType("numba")
    fake.__version__, fake.__file__ = "0.58.1", "/elsewhere/numba/__init__.py"
    monkeypatch.setitem(sys.modules, "numba", fake)
    with pytest.raises(kernels.KernelsUnavailable) as info:
        kernels.check()
    assert str(info.value).startswith(
        f"BO2 Lighting needs numba {kernels.NUMBA_VERSION}, the version its zip bundles for this "
        f"platform ({sys.platform} ")
    assert str(info.value).endswith(
        "found numba 0.58.1 at /elsewhere/numba. Reinstall the extension from the zip of your "
        "platform")
    monkeypatch.setitem(sys.modules, "numba", None)  # import fails
    with pytest.raises(kernels.KernelsUnavailable, match=r"found none \(ModuleNotFoundError"):
        kernels.check()


def test_each_platform_accepts_the_numba_its_zip_bundles():
    """The manifest's wheels: 0.62.1 for macOS Intel (numba's last there), 0.68.1 elsewhere."""
    import tomllib
    from pathlib import Path

    manifest = tomllib.loads((Path(kernels.__file__).parents[3] / "blender_manifest.toml")
                             .read_text())
    tags = {"linux": "manylinux", "win32": "win_amd64", "darwin": "macosx"}
    for system, machine, arch in (("linux", "x86_64", "x86_64"), ("win32", "AMD64", "amd64"),
                                  ("darwin", "arm64", "arm64"), ("darwin", "x86_64", "x86_64")):
        wanted = kernels.bundled_numba(system, machine)
        numbas = {w.split("-")[1] for w in manifest["wheels"]
                  if "/numba-" in w and tags[system] in w and w.endswith(f"{arch}.whl")}
        assert numbas == {wanted}, (system, machine, numbas)
    assert kernels.bundled_numba("darwin", "x86_64") == "0.62.1"
    assert kernels.bundled_numba("linux", "x86_64") == "0.68.1"


@pytest.mark.parametrize(("raised", "words"), [
    ("raise OSError('Could not find/load shared object file') from OSError("
     "'libllvmlite.so: failed to map segment from shared object')",
     "BO2 Lighting ran out of memory loading its compiled kernels (numba {v}: OSError: "
     "libllvmlite.so: failed to map segment from shared object)"),
    ("raise MemoryError()", "ran out of memory loading its compiled kernels"),
    ("raise ImportError('libllvmlite.so: undefined symbol: LLVMPY_AddSymbol')",
     "BO2 Lighting's numba {v} is installed but fails to load (ImportError: libllvmlite.so: "
     "undefined symbol: LLVMPY_AddSymbol); reinstall the extension"),
])
def test_a_numba_that_fails_to_load_is_not_called_missing(monkeypatch, tmp_path, raised, words):
    """A numba that is there but cannot load (out of memory under ulimit -v, a broken
    library) is told apart from a missing one, and memory is named when it is the cause."""
    (tmp_path / "numba").mkdir()
    (tmp_path / "numba" / "__init__.py").write_text(raised + "\n")
    monkeypatch.syspath_prepend(str(tmp_path))
    monkeypatch.delitem(sys.modules, "numba")
    with pytest.raises(kernels.KernelsUnavailable) as info:
        kernels.check()
    assert words.format(v=importlib.metadata.version("numba")) in str(info.value)
    assert "needs numba" not in str(info.value)


def test_default_cache_folder_is_per_user(monkeypatch, tmp_path):
    monkeypatch.setattr(sys, "platform", "linux")
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path))
    assert kernels.default_cache_dir() == tmp_path / "bo2_lighting" / "kernels"


LOAD = ("import sys; from bo2_lighting.addon.core import kernels; "
        "kernels.load(lambda m: print(m)); print('cached', kernels.is_cached())")

# The extension's start: compiled in child processes, a frame's modules first, then loaded
# here from their cache (numba counts a cache hit, and no compile, for every kernel)
PREPARE = """
import sys
from bo2_lighting.addon.core import kernels
print("started", kernels.prepare(2))
kernels.load(print, kernels.FRAME_MODULES)  # a render: the frame's modules, compiled first
print("frame", all(kernels._cached(m) for m in kernels.FRAME_MODULES),
      f"{kernels.__name__}.lightmap" in sys.modules)
kernels.load(print)  # a lightmap bake: waits for the lightmap bakes' module, still compiling
print("cached", kernels.is_cached(), "status", repr(kernels.status()))
import importlib
hits = misses = 0
for module in kernels.MODULES:
    mod = importlib.import_module(f"{kernels.__name__}.{module}")
    for f in vars(mod).values():
        stats = getattr(f, "stats", None)
        if stats is not None and getattr(f, "signatures", None):
            hits += sum(stats.cache_hits.values())
            misses += sum(stats.cache_misses.values())
print("hits", hits > 0, "misses", misses)
"""

# After compiling: every helper of the kernels compiled once, for float32 data where the kernel
# works in float32 (a stray float64 constant silently doubles a helper's compile and changes
# its rounding); the multi-typed kernels are the ones declared so (textures: float32 and
# 8-bit texels; the casters' extents and depth maps: float32 as frames hold them, float64).
TYPES = """
import importlib
from bo2_lighting.addon.core import kernels
kernels.load()
several = {("raster", "project"), ("raster", "survivors"), ("raster", "_permute"),
           ("raster", "_permute_row"),
           ("raster", "_rejection"), ("textures", "sample"), ("textures", "_value"),
           ("raster", "extent"), ("raster", "distances"), ("raster", "clipped_depths"),
           ("raster", "sample_survivors"), ("raster", "ortho_depths"),
           ("raster", "perspective_depths")}
for module in kernels.MODULES:
    mod = importlib.import_module(f"{kernels.__name__}.{module}")
    for name, f in vars(mod).items():
        sigs = getattr(f, "signatures", None)
        if sigs is None or (module, name) in several:
            continue
        if len(sigs) > 1:
            print("several", module, name, len(sigs))
        if module == "shadows" and any("float64" in str(s) for s in sigs):
            print("float64", module, name)
print("done")
"""


def test_kernels_compile_once_into_the_cache_folder(tmp_path):
    env = {"NUMBA_CACHE_DIR": str(tmp_path), "PATH": "/usr/bin:/bin"}
    first = subprocess.run([sys.executable, "-c", PREPARE], env=env, capture_output=True,
                           text=True, timeout=600)
    assert first.returncode == 0, first.stderr
    assert first.stdout.splitlines() == [
        "started True", kernels.FIRST_RUN_MESSAGE, "frame True False",
        kernels.FIRST_RUN_MESSAGE, "cached True status ''", "hits True misses 0"]
    assert list(tmp_path.rglob("*.nbi")) and list(tmp_path.rglob("*.nbc"))
    second = subprocess.run([sys.executable, "-c", LOAD], env=env, capture_output=True,
                            text=True, timeout=600)
    assert second.stdout.splitlines() == ["cached True"]


def test_each_helper_compiles_once_in_its_types(tmp_path):
    env = {"NUMBA_CACHE_DIR": str(tmp_path), "PATH": "/usr/bin:/bin"}
    run = subprocess.run([sys.executable, "-c", TYPES], env=env, capture_output=True, text=True,
                         timeout=600)
    assert run.returncode == 0, run.stderr
    assert run.stdout.splitlines() == ["done"]


def test_a_hung_compile_child_is_stopped(monkeypatch):
    """A child that does not end within ``CHILD_TIMEOUT`` is killed (its module then compiles
    on import, as without children), so the first render never waits on it forever."""
    children = []
    popen = subprocess.Popen

    def recorded(*args, **kwargs):
        children.append(popen(*args, **kwargs))
        return children[-1]

    monkeypatch.setattr(kernels, "_CHILD", "import time; time.sleep(120)")
    monkeypatch.setattr(kernels, "CHILD_TIMEOUT", 0.5)
    monkeypatch.setattr(kernels.subprocess, "Popen", recorded)
    kernels._compile_apart(["shading", "raster", "shadows"], 2)
    assert len(children) == 2 and all(child.returncode is not None and child.returncode < 0
                                      for child in children)


def test_children_share_the_modules_to_end_together():
    """One child per core, each starting numba once, the modules dealt longest first to the
    child with the least to do."""
    shares = kernels._shares(list(kernels.FRAME_MODULES), 2)
    assert shares == [["raster", "shading", "occlusion"], ["shadows", "textures", "indirect"]]
    assert kernels._shares(["shading", "lightmap"], 4) == [["lightmap"], ["shading"]]
    assert sorted(sum(kernels._shares(list(kernels.MODULES), 3), [])) == sorted(kernels.MODULES)

