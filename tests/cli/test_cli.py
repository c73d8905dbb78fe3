"""The ``bo2`` command, run as a user runs it: a subprocess, checked by exit code and output."""

import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[2]
BO2 = Path(sys.executable).parent / "bo2"
DEMO = ROOT / "demo_blends" / "first_light.blend"


def bo2(*args, timeout=300):
    return subprocess.run([str(BO2), *map(str, args)], capture_output=True, text=True,
                          timeout=timeout)


def one_error_line(proc):
    lines = [s for s in proc.stderr.splitlines() if s.strip()]
    assert len(lines) == 1, proc.stderr
    assert lines[0].startswith("bo2: error: ")
    return lines[0]


def test_help_lists_commands():
    proc = bo2("--help")
    assert proc.returncode == 0
    assert "render" in proc.stdout and "version" in proc.stdout


def test_version():
    proc = bo2("version")
    assert proc.returncode == 0
    assert proc.stdout.startswith("BO2 Lighting 0.")


@pytest.mark.parametrize("args", [
    ("frobnicate",),
    (),
    ("render",),
    ("render", "x.blend", "-o", "x.png", "--samples", "zero"),
    ("render", "x.blend", "-o", "x.png", "--resolution", "12by7"),
    ("render", "x.blend", "-o", "x.png", "--engine", "eevee"),
])
def test_bad_usage_is_one_line_exit_2(args):
    proc = bo2(*args)
    assert proc.returncode == 2
    one_error_line(proc)


def test_missing_blend(tmp_path):
    proc = bo2("render", tmp_path / "nope.blend", "-o", tmp_path / "x.png")
    assert proc.returncode == 1
    assert "no such .blend file" in one_error_line(proc)


@pytest.mark.parametrize("content", [b"\x00garbage" * 100, b"BLENDER-v405" + b"\xff" * 500])
def test_corrupt_blend(tmp_path, content):
    bad = tmp_path / "bad.blend"
    bad.write_bytes(content)
    proc = bo2("render", bad, "-o", tmp_path / "x.png")
    assert proc.returncode == 1
    line = one_error_line(proc)
    assert "bad.blend" in line or "ead" in line  # names the file or says it cannot be read
    assert not (tmp_path / "x.png").exists()


def test_scene_without_camera(tmp_path):
    blend = tmp_path / "empty.blend"
    script = ("import bpy; bpy.ops.wm.read_factory_settings(use_empty=True); "
              f"bpy.ops.wm.save_as_mainfile(filepath={str(blend)!r})")
    subprocess.run([sys.executable, "-c", script], check=True, capture_output=True)
    proc = bo2("render", blend, "-o", tmp_path / "x.png")
    assert proc.returncode == 1
    assert "no active camera" in one_error_line(proc)


def read_exr(path, layer="Combined"):
    """One pass of a multilayer EXR written by Blender: (H, W, C) float32."""
    import OpenEXR

    for part in OpenEXR.File(str(path)).parts:
        if part.name() == f"ViewLayer.{layer}":
            channels = list(part.channels.values())
            if len(channels) == 1:
                return channels[0].pixels.reshape(*channels[0].pixels.shape[:2], -1)
            return np.stack([c.pixels for c in channels], -1)
    raise KeyError(layer)


def test_specular_model_changes_the_image(tmp_path):
    images = {}
    for model in ("reference", "none", "reference"):
        out = tmp_path / f"{model}.exr"
        proc = bo2("render", DEMO, "-o", out, "--resolution", "64x36", "--samples", "1",
                   "--specular-model", model)
        assert proc.returncode == 0, proc.stderr
        image = read_exr(out)
        if model in images:
            np.testing.assert_array_equal(image, images[model])  # deterministic
        images[model] = image
    assert images["reference"].shape == (36, 64, 4)
    # No visibility term makes grazing highlights dimmer: the images differ.
    assert np.abs(images["reference"] - images["none"]).max() > 0.01


def test_unknown_output_type(tmp_path):
    proc = bo2("render", DEMO, "-o", tmp_path / "x.gif")
    assert proc.returncode == 1
    assert "unknown image type" in one_error_line(proc)


def test_render_demo_png_and_exr(tmp_path):
    png, exr = tmp_path / "a.png", tmp_path / "a.exr"
    proc = bo2("render", DEMO, "-o", png, "--resolution", "64x36", "--samples", "1")
    assert proc.returncode == 0, proc.stderr
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    proc = bo2("render", DEMO, "-o", exr, "--resolution", "64x36", "--samples", "1",
               "--all-passes")
    assert proc.returncode == 0, proc.stderr
    assert exr.read_bytes()[:4] == b"\x76\x2f\x31\x01"  # OpenEXR magic
    combined = read_exr(exr)
    assert combined.shape == (36, 64, 4) and np.isfinite(combined).all()
    # Every pass is a layer; the light passes add up to Combined where there is geometry.
    parts = {name: read_exr(exr, name) for name in  # Blender 5.0's pass names
             ("Depth", "Normal", "Position", "UV", "Material Index", "Diffuse Direct",
              "Glossy Direct", "Emission", "Albedo", "Specular Color", "Gloss")}
    assert parts["Normal"].shape == (36, 64, 3) and parts["Gloss"].shape == (36, 64, 1)
    total = parts["Diffuse Direct"] + parts["Glossy Direct"] + parts["Emission"]
    ground = parts["Depth"][..., 0] < 1e9
    np.testing.assert_allclose(total[ground], combined[ground, :3], rtol=1e-4, atol=1e-5)
