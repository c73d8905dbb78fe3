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


def empty_blend(path):
    """Save an empty scene (no camera, no objects) at ``path``; returns the path."""
    script = ("import bpy; bpy.ops.wm.read_factory_settings(use_empty=True); "
              f"bpy.ops.wm.save_as_mainfile(filepath={str(path)!r})")
    subprocess.run([sys.executable, "-c", script], check=True, capture_output=True)
    return path


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
    blend = empty_blend(tmp_path / "empty.blend")
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
              "Glossy Direct", "Diffuse Indirect", "Glossy Indirect", "Emission", "Albedo",
              "Specular Color", "Gloss")}
    assert parts["Normal"].shape == (36, 64, 3) and parts["Gloss"].shape == (36, 64, 1)
    assert parts["Diffuse Indirect"].max() > 0  # the world lights the demo
    total = sum(parts[name] for name in ("Diffuse Direct", "Glossy Direct", "Diffuse Indirect",
                                         "Glossy Indirect", "Emission"))
    ground = parts["Depth"][..., 0] < 1e9
    np.testing.assert_allclose(total[ground], combined[ground, :3], rtol=1e-4, atol=1e-5)
    # the Cryptomatte passes: every pixel that sees a surface names it with its coverage
    crypto = sum(read_exr(exr, f"CryptoObject{n:02d}")[..., [0, 2]].sum(-1)  # (a, b, g, r)
                 for n in range(3))
    assert crypto.shape == (36, 64) and (crypto[ground] > 0.99).all()


def test_env_brdf_prints_the_slide_value():
    # a004 of slide "Approximate curves: rf0 = 0.04" by hand at g = 0.5, n.v = 0.5:
    # t = min(0.2375, 2^-4.64) = 0.040107; (t + 0.0275) 0.5 + 0.015 = 0.048804
    proc = bo2("env-brdf", "--gloss", "0.5", "--nov", "0.5")
    assert proc.returncode == 0, proc.stderr
    assert float(proc.stdout) == pytest.approx(0.0488035, abs=2e-6)


def test_env_brdf_json_rgb_and_models():
    import json

    from bo2_lighting.addon.core.formulas import env_brdf

    for model in env_brdf.MODELS:
        proc = bo2("env-brdf", "--gloss", "0.3", "--nov", "0.2", "--rf0", "0", "0.04", "1",
                   "--model", model, "--json")
        assert proc.returncode == 0, proc.stderr
        out = json.loads(proc.stdout)
        assert out["model"] == model and out["rf0"] == [0.0, 0.04, 1.0]
        expected = env_brdf.environment_brdf(0.3, 0.2, np.array([0.0, 0.04, 1.0]), model)
        np.testing.assert_allclose(out["value"], expected, rtol=1e-6)


def test_env_brdf_bad_input():
    proc = bo2("env-brdf", "--gloss", "glossy", "--nov", "0.5")
    assert proc.returncode == 2 and "invalid float value: 'glossy'" in one_error_line(proc)
    proc = bo2("env-brdf", "--gloss", "0.5", "--nov", "0.5", "--rf0", "0.1", "0.2")
    assert proc.returncode == 1 and "one value or three" in one_error_line(proc)
    proc = bo2("env-brdf", "--gloss", "nan", "--nov", "0.5", "--json")  # NaN propagates
    assert proc.returncode == 0 and '"value": [null]' in proc.stdout
    out_of_range = bo2("env-brdf", "--gloss", "7", "--nov", "-2")  # clamped to 1 and 1e-4
    clamped = bo2("env-brdf", "--gloss", "1", "--nov", "0.0001")
    assert out_of_range.stdout == clamped.stdout and out_of_range.returncode == 0


# --- bo2 sh ------------------------------------------------------------------------------------

ENVMAPS = ROOT.parent / "shared" / "reference" / "envmaps"


def read_rgbe(path):
    """The tests' own Radiance reader (tests/core/rgbe.py), independent of Blender."""
    import importlib.util

    spec = importlib.util.spec_from_file_location("rgbe", ROOT / "tests" / "core" / "rgbe.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module.read_rgbe(path)


def test_sh_of_a_reference_hdri():
    import json

    from bo2_lighting.addon.core.formulas import sh

    hdri = ENVMAPS / "venice_sunset_1k.hdr"
    if not hdri.is_file():
        pytest.skip(f"reference HDRI not found: {hdri}")
    expected = sh.project_equirect(read_rgbe(hdri))
    proc = bo2("sh", hdri)
    assert proc.returncode == 0, proc.stderr
    lines = proc.stdout.splitlines()
    assert len(lines) == 9
    order = [tuple(int(x) for x in line.split()[:2]) for line in lines]
    assert order == [(0, 0), (1, -1), (1, 0), (1, 1), (2, -2), (2, -1), (2, 0), (2, 1), (2, 2)]
    plain = np.array([[float(x) for x in line.split()[2:]] for line in lines])
    np.testing.assert_allclose(plain, expected, rtol=1e-3, atol=1e-3 * np.abs(expected).max())
    proc = bo2("sh", hdri, "--json")
    assert proc.returncode == 0, proc.stderr
    out = json.loads(proc.stdout)
    assert out["image"] == str(hdri)
    assert out["order"] == [list(lm) for lm in order]
    np.testing.assert_allclose(out["coefficients"], expected, rtol=1e-3,
                               atol=1e-3 * np.abs(expected).max())


def test_sh_for_an_engine_as_json_and_a_c_header(tmp_path):
    """``-o`` and ``--header`` in Y-up axes: the header compiles (the system's C compiler, when
    there is one) and its arrays hold the JSON's values; the tinted scalar SH rebuilds the RGB
    DC term (tint * scalar_0 = sh_0)."""
    import json
    import shutil

    hdri = ENVMAPS / "venice_sunset_1k.hdr"
    if not hdri.is_file():
        pytest.skip(f"reference HDRI not found: {hdri}")
    proc = bo2("sh", hdri, "--axes", "y-up", "-o", tmp_path / "sh.json",
               "--header", tmp_path / "sh.h")
    assert proc.returncode == 0, proc.stderr
    record = json.loads((tmp_path / "sh.json").read_text())
    assert record["axes"].startswith("Y up")
    rgb = np.array(record["radiance_rgb"])
    blender = np.array(json.loads(bo2("sh", hdri, "--json").stdout)["coefficients"])
    np.testing.assert_allclose(rgb[[0, 1, 2, 3]], [blender[0], blender[2], -blender[1],
                                                   blender[3]], rtol=1e-5, atol=1e-6)
    tinted = record["tinted_scalar"]
    np.testing.assert_allclose(np.array(tinted["tint"]) * tinted["scalar"][0], rgb[0],
                               rtol=1e-6)
    cc = shutil.which("cc")
    if cc is None:
        pytest.skip("no C compiler to build the header with")
    program = tmp_path / "main.c"
    program.write_text('#include <stdio.h>\n#include "sh.h"\nint main(void) {\n'
                       "  for (int i = 0; i < 9; ++i) printf(\"%.9g %.9g %.9g\\n\", "
                       "venice_sunset_1k_sh_rgb[i][0], venice_sunset_1k_sh_rgb[i][1], "
                       "venice_sunset_1k_sh_rgb[i][2]);\n"
                       '  printf("%.9g\\n", venice_sunset_1k_sh_scalar[0]);\n  return 0;\n}\n')
    subprocess.run([cc, "-std=c99", "-Wall", "-Werror", "-o", str(tmp_path / "main"),
                    str(program)], check=True, cwd=tmp_path, capture_output=True)
    lines = subprocess.run([str(tmp_path / "main")], check=True, capture_output=True,
                           text=True).stdout.split("\n")
    printed = np.array([[float(x) for x in line.split()] for line in lines[:9]])
    np.testing.assert_allclose(printed, rgb, rtol=1e-6)
    assert float(lines[9]) == pytest.approx(tinted["scalar"][0], rel=1e-6)


def test_sh_bad_inputs(tmp_path):
    proc = bo2("sh", tmp_path / "nope.hdr")
    assert proc.returncode == 2 and "no such file" in one_error_line(proc)
    noise = tmp_path / "noise.hdr"
    noise.write_bytes(np.random.default_rng(3).integers(0, 256, 4096, np.uint8).tobytes())
    proc = bo2("sh", noise)
    assert proc.returncode == 2 and "not an image Blender can read" in one_error_line(proc)
    proc = bo2("sh", tmp_path)
    assert proc.returncode == 2 and "is a directory" in one_error_line(proc)
    for args in (("sh",), ("sh", noise, "--frobnicate")):
        proc = bo2(*args)
        assert proc.returncode == 2
        one_error_line(proc)


def test_sh_writes_all_its_outputs_or_none(tmp_path):
    """A header that cannot be written leaves no JSON either (and no temporary file); the
    image itself as an output is refused."""
    write_png(tmp_path / "sky.png", np.full((8, 16, 3), 128, np.uint8))
    blocker = tmp_path / "a_file"
    blocker.write_text("not a folder")
    proc = bo2("sh", tmp_path / "sky.png", "-o", tmp_path / "sh.json", "--header",
               blocker / "sh.h")
    assert proc.returncode == 2 and "nothing was written" in one_error_line(proc)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a_file", "sky.png"]
    proc = bo2("sh", tmp_path / "sky.png", "-o", tmp_path / "sky.png")
    assert proc.returncode == 2 and "this is the input" in one_error_line(proc)


def write_png(path, rgb):
    """A minimal 8-bit RGB PNG (ISO/IEC 15948): signature, IHDR, one IDAT, IEND."""
    import struct
    import zlib

    def chunk(kind, data):
        return (struct.pack(">I", len(data)) + kind + data
                + struct.pack(">I", zlib.crc32(kind + data) & 0xFFFFFFFF))

    h, w, _ = rgb.shape
    rows = b"".join(b"\x00" + rgb[r].astype(np.uint8).tobytes() for r in range(h))
    path.write_bytes(b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", w, h, 8, 2, 0,
                                                                      0, 0))
                     + chunk(b"IDAT", zlib.compress(rows)) + chunk(b"IEND", b""))


def test_sh_of_an_srgb_png_sky(tmp_path):
    import json

    # Top half (the +Z hemisphere) 8-bit 128, sRGB-encoded: linear 0.2158605 (IEC 61966-2-1);
    # bottom half black. c00 = 0.282095 * 2 pi L, c10 = 0.488603 * pi L (integral of z over the
    # upper hemisphere is pi), every other coefficient 0. The sign of c10 checks the row order.
    rgb = np.zeros((64, 128, 3), np.uint8)
    rgb[:32] = 128
    png = tmp_path / "sky.png"
    write_png(png, rgb)
    proc = bo2("sh", png, "--json")
    assert proc.returncode == 0, proc.stderr
    c = np.array(json.loads(proc.stdout)["coefficients"])
    linear = 0.2158605
    expected = np.zeros((9, 3))
    expected[0], expected[2] = 0.282095 * 2 * np.pi * linear, 0.488603 * np.pi * linear
    np.testing.assert_allclose(c, expected, atol=1e-3)


PROBE_SCENE = r'''
import sys
import bpy
bpy.ops.wm.read_factory_settings(use_empty=True)
scene = bpy.context.scene
bpy.ops.mesh.primitive_plane_add(size=4)
sun = bpy.data.objects.new("Sun", bpy.data.lights.new("Sun", "SUN"))
scene.collection.objects.link(sun)
for name, kind, loc in (("Reflection", "SPHERE", (0, 0, 1)), ("Irradiance", "VOLUME", (0, 0, 1))):
    probe = bpy.data.objects.new(name, bpy.data.lightprobes.new(name, kind))
    probe.location = loc
    scene.collection.objects.link(probe)
scene.objects["Irradiance"].data.resolution_x = 2
scene.objects["Irradiance"].data.resolution_y = 2
scene.objects["Irradiance"].data.resolution_z = 2
if len(sys.argv) > 2:  # no probes at all
    for name in ("Reflection", "Irradiance"):
        bpy.data.objects.remove(scene.objects[name])
bpy.ops.wm.save_as_mainfile(filepath=sys.argv[1])
'''


def probe_blend(tmp_path, with_probes=True):
    blend = tmp_path / "probes.blend"
    subprocess.run([sys.executable, "-c", PROBE_SCENE, str(blend)]
                   + ([] if with_probes else ["empty"]), check=True, capture_output=True)
    return blend


def test_bake_writes_the_bake_folder(tmp_path):
    from bo2_lighting.addon.core.files import probe_file

    blend = probe_blend(tmp_path)
    proc = bo2("bake", blend, "--probes", "Reflection")
    assert proc.returncode == 0, proc.stderr
    assert "baked 1 probe into" in proc.stdout and "100.0%" in proc.stderr
    assert "packed into the .blend); saved" in proc.stdout  # the scene's default
    folder = tmp_path / "bo2_bake" / "probes"  # the .blend's own folder
    files = list(folder.iterdir())
    assert len(files) == 1 and files[0].name.startswith("Reflection-")
    meta, sh, mips = probe_file.read(files[0])
    assert meta["backend"] == "BO2" and meta["face_size"] == 128 and len(mips["bo2"]) == 8
    proc = bo2("bake", blend, "--no-pack")
    assert proc.returncode == 0 and "baked 2 probes" in proc.stdout
    assert "packed" not in proc.stdout
    names = sorted(p.name for p in folder.iterdir())  # Reflection re-baked in place
    assert len(names) == 2 and names[1] == files[0].name and names[0].startswith("Irradiance-")


def test_export_probes_for_an_engine(tmp_path):
    """The baked probes leave as an engine loads them: the reflection probe's bo2 chain, its
    texels where the OpenGL cube table puts their directions (Y up), and the SH turned into Y-up
    axes (the l = 1 band of Blender's z is the engine's y)."""
    import json

    from bo2_lighting.addon.core.files import probe_file
    from bo2_lighting.addon.core.formulas import cubemap

    blend = probe_blend(tmp_path)
    assert bo2("bake", blend, "--no-pack").returncode == 0
    out = tmp_path / "export"
    proc = bo2("export-probes", blend, "-o", out, "--format", "dds")
    assert proc.returncode == 0, proc.stderr
    assert "exported 2 probes and the world" in proc.stdout
    manifest = json.loads((out / "probes.json").read_text())
    by_name = {p["name"]: p for p in manifest["probes"]}
    reflection, volume = by_name["Reflection"], by_name["Irradiance"]
    assert reflection["position"] == pytest.approx([0, 1, 0])  # Blender (0, 0, 1), Y up
    assert reflection["chain"] == "probe00_Reflection.dds"
    assert (out / "probe00_Reflection.json").is_file() and (out / "world.dds").is_file()
    # the volume keeps its local axes: its transform maps them to Y-up world axes (C M)
    m = np.asarray(volume["local_to_world"])
    np.testing.assert_allclose(m[:3, 3], [0, 1, 0], atol=1e-6)
    np.testing.assert_allclose(m[:3, 2], [0, 1, 0], atol=1e-6)  # local z (Blender's up)
    meta, sh, chains = probe_file.read(*(tmp_path / "bo2_bake" / "probes").glob("Reflection-*"))
    # l = 1: Blender's (y, z, x) order (1,-1) (1,0) (1,1) -> the engine's (y', z', x')
    # with x' = x, y' = z, z' = -y: c'(1,-1) = c(1,0), c'(1,0) = -c(1,-1), c'(1,1) = c(1,1)
    turned = np.asarray(reflection["sh"])
    np.testing.assert_allclose(turned[[0, 1, 2, 3]], [sh[0, 0], sh[0, 2], -sh[0, 1], sh[0, 3]],
                               atol=1e-5)
    assert np.asarray(volume["sh"]).shape == (2, 2, 2, 9, 3)
    data = (out / "probe00_Reflection.dds").read_bytes()
    size = chains["bo2"][0].shape[1]
    offset = 148
    for face in range(6):  # every texel of mip 0 where the OpenGL table (transcribed) says
        texels = np.frombuffer(data, np.float16, size * size * 4, offset).reshape(size, size, 4)
        offset += sum((size >> m) ** 2 * 8 for m in range(len(chains["bo2"])))
        sc = (2.0 * np.arange(size) + 1.0) / size - 1.0
        s_, t_ = np.meshgrid(sc, sc)
        one = np.ones_like(s_)
        gl = [(one, -t_, -s_), (-one, -t_, s_), (s_, one, t_), (s_, -one, -t_), (s_, -t_, one),
              (-s_, -t_, -one)][face]
        d = np.stack([gl[0], -gl[2], gl[1]], -1).reshape(-1, 3)  # engine (x, y, z) -> Blender
        f, x, y = cubemap.direction_to_face(d, size)
        expected = chains["bo2"][0][f, y.astype(int), x.astype(int)].reshape(size, size, 3)
        np.testing.assert_allclose(texels[..., :3], expected.astype(np.float16), rtol=1e-3)
    proc = bo2("export-probes", blend, "-o", tmp_path / "probes.blend")
    assert proc.returncode == 2 and "is a file" in one_error_line(proc)


def test_export_probes_with_a_damaged_bake(tmp_path):
    """A damaged probe file: one warning naming it once, nothing of OpenEXR's own on stdout or
    stderr; the other probe and the world are exported."""
    blend = probe_blend(tmp_path)
    assert bo2("bake", blend, "--no-pack").returncode == 0
    [damaged] = (tmp_path / "bo2_bake" / "probes").glob("Reflection-*")
    data = bytearray(damaged.read_bytes())
    data[-30:-10] = b"\xff" * 20  # the last pixels' compressed data
    damaged.write_bytes(bytes(data))
    proc = bo2("export-probes", blend, "-o", tmp_path / "export")
    assert proc.returncode == 0, proc.stderr
    assert proc.stdout.startswith("exported 1 probe and the world"), proc.stdout
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("bo2: warning: Light probe 'Reflection'")
    assert lines[0].count(damaged.name) == 1, lines[0]


def test_bake_with_cycles(tmp_path):
    from bo2_lighting.addon.core.files import probe_file

    blend = probe_blend(tmp_path)
    proc = bo2("bake", blend, "--probes", "Irradiance", "--backend", "cycles", timeout=900)
    assert proc.returncode == 0, proc.stderr
    meta, sh, _ = probe_file.read(*(tmp_path / "bo2_bake" / "probes").glob("Irradiance-*"))
    assert meta["backend"] == "CYCLES" and sh.shape == (8, 9, 3)
    assert np.isfinite(sh).all() and sh[:, 0].min() > 0  # every sample sees the sunlit plane


def test_bake_bad_input(tmp_path):
    blend = probe_blend(tmp_path)
    proc = bo2("bake", blend, "--probes", "Nope")
    assert proc.returncode == 1
    assert "no Sphere or Volume light probe named Nope" in one_error_line(proc)
    assert "Irradiance, Reflection" in one_error_line(proc)
    empty = probe_blend(tmp_path, with_probes=False)
    proc = bo2("bake", empty)
    assert proc.returncode == 1 and "no Sphere or Volume light probes" in one_error_line(proc)
    proc = bo2("bake", tmp_path / "missing.blend")
    assert proc.returncode == 1
    proc = bo2("bake", blend, "--backend", "eevee")
    assert proc.returncode == 2


def test_bake_lightmaps(tmp_path):
    from bo2_lighting.addon.core.files import lightmap_file

    blend = probe_blend(tmp_path)
    proc = bo2("bake", blend, "--lightmaps")
    assert proc.returncode == 0, proc.stderr
    assert "baked 1 lightmap into" in proc.stdout and "MiB, packed" in proc.stdout
    meta, lm = lightmap_file.read(
        *(tmp_path / "bo2_bake" / "probes" / "lightmaps").glob("Plane-*"))
    assert meta["backend"] == "BO2" and meta["uv_map"] == ""
    # a lone plane under no world: nothing but the sun, whose direct light is not baked
    assert lm.uvs.shape == (2, 3, 2) and np.isfinite(lm.image).all() and lm.image.max() == 0.0
    # an object with no faces is left out with a warning, and not counted
    script = ("import sys, bpy; bpy.ops.wm.open_mainfile(filepath=sys.argv[1]); "
              "m = bpy.data.meshes.new('Wire'); m.from_pydata([(0, 0, 0), (1, 0, 0)], [(0, 1)],"
              " []); bpy.context.scene.collection.objects.link(bpy.data.objects.new('Wire', m));"
              " bpy.ops.wm.save_mainfile()")
    subprocess.run([sys.executable, "-c", script, str(blend)], check=True, capture_output=True)
    proc = bo2("bake", blend, "--lightmaps")
    assert proc.returncode == 0, proc.stderr
    assert "baked 1 lightmap into" in proc.stdout
    assert "'Wire' has no faces that render" in proc.stderr
    proc = bo2("bake", blend, "--lightmaps", "Nope")
    assert proc.returncode == 1 and "no static mesh object named Nope" in one_error_line(proc)
    proc = bo2("bake", blend, "--lightmaps", "--probes", "Reflection")
    assert proc.returncode == 1 and "two commands" in one_error_line(proc)


# --- bo2 render: several files and frames ------------------------------------------------------

TINY = ("--resolution", "32x18", "--samples", "1")


def error_lines(proc):
    return [s for s in proc.stderr.splitlines() if s.startswith("bo2: error: ")]


def test_render_batch_pattern_and_summary(tmp_path):
    import json
    import shutil

    blends = [tmp_path / "shot_a.blend", tmp_path / "shot_b.blend"]
    for blend in blends:
        shutil.copy(DEMO, blend)
    summary = tmp_path / "report.json"
    proc = bo2("render", *blends, "--frames", "1-2",
               "-o", tmp_path / "out" / "{scene}.{frame:03d}.png", "--summary", summary, *TINY)
    assert proc.returncode == 0, proc.stderr
    names = ["shot_a.001.png", "shot_a.002.png", "shot_b.001.png", "shot_b.002.png"]
    assert sorted(p.name for p in (tmp_path / "out").iterdir()) == names
    assert "4/4" in proc.stderr and "100.0%" in proc.stderr  # the progress bar
    assert not error_lines(proc) and "rendered 4 of 4 images" in proc.stdout
    report = json.loads(summary.read_text())
    assert (report["total"], report["ok"], report["failed"]) == (4, 4, 0)
    assert [(i["scene"], i["frame"], i["status"], i["error"]) for i in report["images"]] == [
        ("shot_a", 1, "ok", None), ("shot_a", 2, "ok", None), ("shot_b", 1, "ok", None),
        ("shot_b", 2, "ok", None)]
    assert [Path(i["output"]).name for i in report["images"]] == names
    assert all(i["seconds"] > 0 for i in report["images"])


def test_render_batch_hash_padding_and_frame_lists(tmp_path):
    proc = bo2("render", DEMO, "--frames", "1-5x2,8", "-o", tmp_path / "shot_####.png", *TINY)
    assert proc.returncode == 0, proc.stderr
    assert sorted(p.name for p in tmp_path.iterdir()) == [
        "shot_0001.png", "shot_0003.png", "shot_0005.png", "shot_0008.png"]


def test_render_batch_goes_on_after_failures(tmp_path):
    import json

    missing, corrupt = tmp_path / "missing.blend", tmp_path / "corrupt.blend"
    corrupt.write_bytes(b"BLENDER-v405" + b"\xff" * 500)
    no_camera = empty_blend(tmp_path / "empty.blend")
    summary = tmp_path / "summary.json"
    proc = bo2("render", missing, DEMO, corrupt, no_camera, "--frames", "1,2",
               "-o", tmp_path / "out" / "{scene}_{frame}.png", "--summary", summary, *TINY)
    assert proc.returncode == 1
    assert sorted(p.name for p in (tmp_path / "out").iterdir()) == [
        "first_light_1.png", "first_light_2.png"]
    errors = error_lines(proc)  # one line per failure: each file that fails to load, each frame
    assert len(errors) == 4, proc.stderr
    assert "missing.blend: no such .blend file" in errors[0]
    assert "corrupt.blend" in errors[1]
    assert errors[2:] == [f"bo2: error: {no_camera} frame {n}: the scene has no active camera"
                          for n in (1, 2)]
    assert "rendered 2 of 8 images" in proc.stdout and "8/8" in proc.stderr
    report = json.loads(summary.read_text())
    assert (report["total"], report["ok"], report["failed"]) == (8, 2, 6)
    failed = [(i["scene"], i["frame"]) for i in report["images"] if i["status"] == "failed"]
    assert failed == [("missing", 1), ("missing", 2), ("corrupt", 1), ("corrupt", 2),
                      ("empty", 1), ("empty", 2)]
    assert all(i["error"] for i in report["images"] if i["status"] == "failed")


@pytest.mark.parametrize("args", [
    (DEMO, DEMO, "-o", "{scene}.png"),  # the same file twice
    (DEMO, "--frames", "1-3", "-o", "{scene}.png"),  # frames without {frame} or #
    (DEMO, "--frames", "1-3", "-o", "a/b#/{scene}.png"),  # '#' in a folder is not the frame
    (DEMO, "other.blend", "-o", "{frame}.png"),  # both files at their current frame
])
def test_render_batch_duplicate_paths_are_usage_errors(tmp_path, args):
    proc = subprocess.run([str(BO2), "render", *map(str, args), *TINY], capture_output=True,
                          text=True, cwd=tmp_path, timeout=60)
    assert proc.returncode == 2
    assert "so that every image has its own path" in one_error_line(proc)
    assert list(tmp_path.iterdir()) == []  # nothing rendered, no folder made


@pytest.mark.parametrize("args", [
    ("--frame", "1", "--frames", "1-2"),
    ("--frames", "5-1"),
    ("--frames", "1-9x0"),
    ("--frames", "one"),
    ("-o", "{name}.png"),
    ("-o", "{scene:03d}.png"),
])
def test_render_batch_bad_usage(tmp_path, args):
    proc = bo2("render", DEMO, "-o", tmp_path / "x_{frame}.png", *args)
    assert proc.returncode == 2
    one_error_line(proc)
    assert list(tmp_path.iterdir()) == []


# --- bo2 compare -------------------------------------------------------------------------------

def png_size(path):
    """(width, height) from a PNG's IHDR chunk."""
    import struct

    data = path.read_bytes()
    assert data[:8] == b"\x89PNG\r\n\x1a\n"
    return struct.unpack(">II", data[16:24])


def test_compare_demo(tmp_path):
    import json

    out = tmp_path / "cmp"
    proc = bo2("compare", DEMO, "-o", out, "--resolution", "64x36", "--samples", "1",
               "--cycles-samples", "4")
    assert proc.returncode == 0, proc.stderr
    lines = proc.stdout.splitlines()
    assert lines[0].startswith("BO2 ") and "Cycles" in lines[0] and "RMSE" in lines[0]
    assert "PSNR" in lines[0] and "SSIM" in lines[0]
    names = ["bo2.exr", "cycles.exr", "side_by_side.png", "split.png", "difference.png",
             "metrics.json"]
    assert [s.strip() for s in lines[1:]] == [str(out / n) for n in names]
    assert sorted(p.name for p in out.iterdir()) == sorted(names)
    metrics = json.loads((out / "metrics.json").read_text())
    assert metrics["resolution"] == [64, 36] and metrics["cycles_times_color"] is True
    assert metrics["engines"]["bo2"]["samples"] == 1
    assert metrics["engines"]["cycles"]["samples"] == 4
    assert metrics["scene"] and metrics["frame"] == 1 and metrics["blender_version"]
    assert 0 < metrics["image"]["ssim"] <= 1
    assert "Diffuse Direct" in metrics["passes"] and "Glossy Indirect" in metrics["passes"]
    assert png_size(out / "split.png") == (64, 36)
    assert png_size(out / "side_by_side.png") == (2 * 64 + 2, 36 + 12)
    width, height = png_size(out / "difference.png")
    assert width >= 64 and height > 36
    assert read_exr(out / "bo2.exr").shape == (36, 64, 4)
    assert read_exr(out / "cycles.exr", "Diffuse Color").shape == (36, 64, 3)


def test_compare_bad_input(tmp_path):
    proc = bo2("compare", DEMO, "-o", tmp_path / "x", "--cycles-samples", "0")
    assert proc.returncode == 2
    one_error_line(proc)
    blocker = tmp_path / "file"
    blocker.write_text("")
    proc = bo2("compare", DEMO, "-o", blocker / "sub")
    assert proc.returncode == 1
    assert "cannot create the output folder" in one_error_line(proc)
    blend = empty_blend(tmp_path / "empty.blend")
    proc = bo2("compare", blend, "-o", tmp_path / "cmp")
    assert proc.returncode == 1
    assert "no active camera" in one_error_line(proc)
    assert list((tmp_path / "cmp").iterdir()) == []


def test_compare_interrupted_during_cycles_keeps_bo2(tmp_path):
    import signal
    import time

    out = tmp_path / "cmp"
    proc = subprocess.Popen([str(BO2), "compare", str(DEMO), "-o", str(out), "--resolution",
                             "96x54", "--samples", "1", "--cycles-samples", "100000"],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        deadline = time.monotonic() + 120
        while not (out / "bo2.exr").exists() and time.monotonic() < deadline:
            assert proc.poll() is None, proc.communicate()
            time.sleep(0.1)
        time.sleep(1.0)  # Cycles is rendering now
        proc.send_signal(signal.SIGINT)
        stdout, stderr = proc.communicate(timeout=30)
    finally:
        proc.kill()
    assert proc.returncode == 130
    lines = [s for s in stderr.splitlines() if s.strip()]
    assert len(lines) == 1, stderr
    assert lines[0] == f"bo2: error: interrupted during the Cycles render; kept {out / 'bo2.exr'}"
    assert sorted(p.name for p in out.iterdir()) == ["bo2.exr"]
    assert stdout == ""
