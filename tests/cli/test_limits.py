"""Out-of-range and odd arguments are refused with one line before anything loads; odd paths
are refused before anything renders; nothing is clamped silently or left half-written."""

import json

import pytest
from test_cli import DEMO, bo2, one_error_line


@pytest.mark.parametrize("args, words", [
    (("render", DEMO, "-o", "{tmp}/x.png", "--samples", "5000"), "5000 samples is more than"),
    (("compare", DEMO, "-o", "{tmp}/c", "--samples", "5000"), "5000 samples is more than"),
    (("compare", DEMO, "-o", "{tmp}/c", "--cycles-samples", "99999999"), "more than Cycles"),
    (("render", DEMO, "-o", "{tmp}/x.png", "--resolution", "100000x100000"), "too large"),
    (("render", DEMO, "-o", "{tmp}/x.png", "--frame", "99999999"), "outside Blender's frames"),
    (("compare", DEMO, "-o", "{tmp}/c", "--frame", "-99999999"), "outside Blender's frames"),
    (("render", DEMO, "-o", "{tmp}/x_####.png", "--frames", "1-1048574"), "too many frames"),
    (("render", DEMO, "-o", "{tmp}/x_####.png", "--frames", "1-2000000"), "within +-1048574"),
])
def test_out_of_range_values_exit_2_before_loading(tmp_path, args, words):
    proc = bo2(*(str(a).format(tmp=tmp_path) for a in args), timeout=60)
    assert proc.returncode == 2, proc.stderr
    assert words in one_error_line(proc)
    assert list(tmp_path.iterdir()) == []  # nothing written, nothing created


def test_odd_outputs_are_refused_before_rendering(tmp_path):
    folder = tmp_path / "taken.png"
    folder.mkdir()
    proc = bo2("render", DEMO, "-o", folder)
    assert proc.returncode == 1
    assert "is a folder" in one_error_line(proc)
    proc = bo2("render", DEMO, "-o", tmp_path / ("x" * 300 + ".png"))
    assert proc.returncode == 1
    assert "too long" in one_error_line(proc)
    summary = tmp_path / "summary"
    summary.mkdir()
    proc = bo2("render", DEMO, "-o", tmp_path / "y.png", "--summary", summary)
    assert proc.returncode == 1
    assert "--summary is a folder" in one_error_line(proc)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["summary", "taken.png"]


def test_a_folder_given_as_the_blend_file(tmp_path):
    proc = bo2("render", tmp_path, "-o", tmp_path / "x.png")
    assert proc.returncode == 1
    assert f"{tmp_path}: is a folder, not a .blend file" in one_error_line(proc)


def test_blender_load_errors_are_said_once(tmp_path):
    broken = tmp_path / "broken.blend"
    broken.write_bytes(b"BLENDER-v405" + bytes(range(256)) * 8)
    proc = bo2("render", broken, "-o", tmp_path / "x.png")
    assert proc.returncode == 1
    line = one_error_line(proc).removeprefix("bo2: error: ")
    words = line.split()
    half = len(words) // 2
    assert "(Error:" not in line and words[:half] != words[half:2 * half], line


@pytest.mark.parametrize("value", ["inf", "-inf", "nan"])
def test_env_brdf_json_is_json_for_any_input(value):
    proc = bo2("env-brdf", f"--gloss={value}", "--nov", "0.5", "--json")
    assert proc.returncode == 0, proc.stderr

    def refuse(constant):
        raise AssertionError(f"{constant} is not JSON")

    data = json.loads(proc.stdout, parse_constant=refuse)
    assert data["gloss"] is None


@pytest.mark.parametrize("size", ["1x1", "3x2", "640x2"])
def test_a_resolution_under_blenders_least_renders_exactly(tmp_path, size):
    """Blender's resolution is at least 4 pixels a side: smaller images are rendered from a
    larger size at 50 or 25 %, and come out at the size asked for."""
    from PIL import Image

    out = tmp_path / "tiny.png"
    proc = bo2("render", DEMO, "-o", out, "--resolution", size, "--samples", "1")
    assert proc.returncode == 0, proc.stderr
    assert "x".join(map(str, Image.open(out).size)) == size


def test_a_resolution_that_cannot_be_rendered_exactly_is_refused(tmp_path):
    proc = bo2("render", DEMO, "-o", tmp_path / "x.png", "--resolution", "20000x1")
    assert proc.returncode == 2
    assert "at most 16384" in one_error_line(proc)
    assert list(tmp_path.iterdir()) == []


def test_an_existing_folder_or_an_empty_output_is_named(tmp_path):
    proc = bo2("render", DEMO, "-o", tmp_path)
    assert proc.returncode == 1
    assert f"{tmp_path}: is a folder; give an image file name" in one_error_line(proc)
    proc = bo2("render", DEMO, "-o", "")
    assert proc.returncode == 2
    assert "-o '': no file name" in one_error_line(proc)
    assert list(tmp_path.iterdir()) == []


ZERO_SCALE_PROBE = r'''
import sys
import bpy
bpy.ops.wm.read_factory_settings(use_empty=True)
bpy.ops.mesh.primitive_plane_add(size=4)
probe = bpy.data.objects.new("Volume", bpy.data.lightprobes.new("Volume", "VOLUME"))
probe.scale = (0.0, 0.0, 0.0)
bpy.context.scene.collection.objects.link(probe)
bpy.ops.wm.save_as_mainfile(filepath=sys.argv[1])
'''


def test_a_bake_refused_names_its_cause(tmp_path):
    import subprocess
    import sys

    blend = tmp_path / "zero.blend"
    subprocess.run([sys.executable, "-c", ZERO_SCALE_PROBE, str(blend)], check=True,
                   capture_output=True)
    proc = bo2("bake", blend)
    assert proc.returncode == 1
    line = one_error_line(proc)
    assert "No light probe can be baked: Light probe 'Volume' has no size" in line, line
    assert not (tmp_path / "bo2_bake").exists()


def test_out_of_memory_is_named_not_a_missing_install(tmp_path):
    """Under a 1.5 GB address-space limit (ulimit -v 1500000) numba's library cannot be mapped:
    the one error line names memory and the limit, not a missing install."""
    import resource
    import subprocess

    from test_cli import BO2

    def limit():
        resource.setrlimit(resource.RLIMIT_AS, (1_500_000 * 1024, resource.RLIM_INFINITY))

    proc = subprocess.run([str(BO2), "render", str(DEMO), "-o", str(tmp_path / "x.png"),
                           "--resolution", "32x18"], capture_output=True, text=True,
                          timeout=300, preexec_fn=limit)
    assert proc.returncode == 1
    line = one_error_line(proc)
    assert "out of memory" in line and "1.4 GiB of address space" in line, line
    assert "needs numba" not in line and "reinstall" not in line
    assert list(tmp_path.iterdir()) == []
