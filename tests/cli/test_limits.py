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
