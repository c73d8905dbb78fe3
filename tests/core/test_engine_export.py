"""Environment maps out to game engines: image readers, the GPU cube face layout, DDS and KTX2
files read back by a parser of their own (pyktx2; DDS by its specification's structures),
cmft's gloss mapping, the edge fixup, and ``bo2 prefilter`` on good and bad input.

Independent values: the OpenGL cube map table as the specification prints it (transcribed here,
not imported), the tests' own Radiance reader (``rgbe.py``), cmft's power formula worked by hand,
the DDS header layout of Microsoft's documentation, and pyktx2's KTX2 parser.
"""

import json
import struct
import subprocess
import sys
from enum import Enum
from pathlib import Path

import numpy as np
import pytest
from rgbe import read_rgbe

from bo2_lighting.addon.core.files import engine_export, environment_files, gpu_textures
from bo2_lighting.addon.core.formulas import cubemap, prefilter, sh

ROOT = Path(__file__).resolve().parents[2]
ENVMAPS = ROOT.parent / "shared" / "reference" / "envmaps"
BO2 = Path(sys.executable).parent / "bo2"


def gl_direction(face: int, s: float, t: float) -> np.ndarray:
    """The direction of (s, t) on a GPU face, Y up: the OpenGL 4.6 table 8.19 inverted."""
    sc, tc = 2.0 * s - 1.0, 2.0 * t - 1.0
    return np.array([(1, -tc, -sc), (-1, -tc, sc), (sc, 1, tc), (sc, -1, -tc), (sc, -tc, 1),
                     (-sc, -tc, -1)][face], np.float64)


def test_gpu_faces_follow_the_opengl_table():
    size = 8
    cube = cubemap.texel_directions(size).astype(np.float64)  # a texel holds its direction
    gpu = gpu_textures.to_gpu_faces(cube)
    for face in range(6):
        for row in range(size):
            for col in range(size):
                d = gl_direction(face, (col + 0.5) / size, (row + 0.5) / size)
                blender = np.array([d[0], -d[2], d[1]])  # glTF: (x, y, z) <- (x, -z, y)
                np.testing.assert_allclose(gpu[face, row, col], blender / np.linalg.norm(blender),
                                           atol=1e-6)
    np.testing.assert_array_equal(gpu_textures.from_gpu_faces(gpu), cube)


def rgbe_file(path: Path, rgbe: np.ndarray, rle: bool) -> None:
    """A Radiance file of (H, W, 4) uint8 texels, flat or new-style run-length encoded (literal
    packets of at most 128 and runs of at least 3), written from the format notes."""
    h, w, _ = rgbe.shape
    out = bytearray(b"#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n" + f"-Y {h} +X {w}\n".encode())
    for y in range(h):
        if not rle:
            out += rgbe[y].tobytes()
            continue
        out += bytes((2, 2, w >> 8, w & 255))
        for c in range(4):
            line, x = rgbe[y, :, c], 0
            while x < w:
                run = 1
                while x + run < w and run < 127 and line[x + run] == line[x]:
                    run += 1
                if run >= 3:
                    out += bytes((128 + run, line[x]))
                    x += run
                    continue
                n = min(128, w - x)
                out += bytes((n,)) + line[x:x + n].tobytes()
                x += n
    path.write_bytes(bytes(out))


@pytest.mark.parametrize("rle", [False, True])
def test_radiance_reader(tmp_path, rle):
    rng = np.random.default_rng(4)
    rgbe = rng.integers(0, 256, (6, 40, 4), np.uint8)
    rgbe[:, 10:30] = rgbe[:, 10:11]  # runs
    rgbe[2, :, 3] = 0  # a row of zero exponents: black
    path = tmp_path / "t.hdr"
    rgbe_file(path, rgbe, rle)
    got = environment_files.read_image(path)
    e = rgbe[..., 3:].astype(np.float64)
    expected = np.where(e > 0, rgbe[..., :3] * np.ldexp(1.0, (e - 136).astype(int)), 0.0)
    np.testing.assert_array_equal(got, expected.astype(np.float32))
    if rle:
        np.testing.assert_array_equal(got, read_rgbe(path))


def test_radiance_reader_agrees_with_the_tests_reader_on_reference_maps():
    paths = sorted(ENVMAPS.glob("*.hdr"))
    if not paths:
        pytest.skip(f"no reference HDR maps in {ENVMAPS}")
    for path in paths:
        np.testing.assert_array_equal(environment_files.read_image(path), read_rgbe(path))


def test_crosses_and_faces_give_the_same_cube():
    size = 16
    cube = cubemap.texel_directions(size).astype(np.float32) + 2.0
    gpu = gpu_textures.to_gpu_faces(cube)
    h = np.zeros((3 * size, 4 * size, 3), np.float32)
    v = np.zeros((4 * size, 3 * size, 3), np.float32)
    for f, (r, c) in enumerate(((1, 2), (1, 0), (0, 1), (2, 1), (1, 1), (1, 3))):
        h[r * size:(r + 1) * size, c * size:(c + 1) * size] = gpu[f]
    for f, (r, c) in enumerate(((1, 2), (1, 0), (0, 1), (2, 1), (1, 1), (3, 1))):
        v[r * size:(r + 1) * size, c * size:(c + 1) * size] = gpu[f] if f != 5 else gpu[f, ::-1,
                                                                                          ::-1]
    for images in ([h], [v], list(gpu)):
        np.testing.assert_array_equal(environment_files.to_cube(images), cube)
    # Each cross unfolds a cube: across every border between two of its faces the pixels on
    # either side look in neighbouring directions (within two texels' angle), whatever table
    # placed them; the horizontal cross wraps around from -Z back to -X.
    limit = np.cos(2.0 * 2.0 / size)
    for image in (h, v):
        filled = (np.abs(image).sum(-1) > 0).reshape(image.shape[0] // size, size,
                                                     image.shape[1] // size, size).any((1, 3))
        seams = 0
        for r, c in zip(*np.nonzero(filled), strict=True):
            for dr, dc in ((0, 1), (1, 0)):
                rr, cc = r + dr, (c + dc) % filled.shape[1] if image is h else c + dc
                if rr >= filled.shape[0] or cc >= filled.shape[1] or not filled[rr, cc]:
                    continue
                if dc:
                    a = image[r * size:(r + 1) * size, (c + 1) * size - 1] - 2.0
                    b = image[rr * size:(rr + 1) * size, cc * size] - 2.0
                else:
                    a = image[(r + 1) * size - 1, c * size:(c + 1) * size] - 2.0
                    b = image[rr * size, cc * size:(cc + 1) * size] - 2.0
                assert (np.einsum("nc,nc->n", a, b) > limit).all(), (r, c, rr, cc)
                seams += 1
        assert seams == (6 if image is h else 5)


def test_cmft_powers_by_hand():
    # cmft's defaults (gloss scale 10, bias 1) over 7 mips: mip 0 2^11, mip 3 2^6, mip 6 2^1
    np.testing.assert_allclose(prefilter.cmft_powers(7, 10, 1, "phong")[[0, 3, 6]],
                               [2048, 64, 2])
    np.testing.assert_allclose(prefilter.cmft_powers(7, 10, 1, "blinnbrdf")[[0, 6]],
                               [2048 / 4 + 1, 2 / 4 + 1])
    np.testing.assert_allclose(prefilter.cmft_powers(7, 10, 1, "phongbrdf")[6], 3.0)
    # the talk's chain is cmft's blinn with 8192^gloss = 2^(13 gloss)
    np.testing.assert_allclose(prefilter.cmft_powers(8, 13, 0, "blinn"),
                               prefilter.mip_powers(128))


def smooth_cube(size):
    d = cubemap.texel_directions(size).astype(np.float32)
    return np.stack([1.0 + d[..., 0] ** 2, 2.0 + d[..., 1], 1.5 + d[..., 2] * d[..., 0]], -1)


def test_edge_warp_makes_the_faces_agree_along_their_edges():
    size = 16
    cube = smooth_cube(size)
    powers = prefilter.cmft_powers(3, 10, 1, "phong")
    seamless = prefilter.prefilter_powers(cube, powers)
    warped = prefilter.prefilter_powers(cube, powers, warp=True)
    for mips in (seamless, warped):
        level = gpu_textures.to_gpu_faces(mips[1])
        top_z, bottom_y = level[4, 0], level[2, -1]  # GPU +Z top row meets +Y bottom row
        gap = np.abs(top_z - bottom_y).max()
        if mips is warped:
            assert gap < 1e-4, gap
        else:
            assert gap > 1e-3, gap  # neighbouring texel centres, not the edge
    # at the face centres the warp moves the directions by 1 / (S - 1) of a half face: little
    c = size // 4
    np.testing.assert_allclose(warped[1][:, c - 1:c + 1, c - 1:c + 1],
                               seamless[1][:, c - 1:c + 1, c - 1:c + 1], rtol=0.03)


def test_the_talks_chain_is_cmfts_blinn_13_0():
    cube = smooth_cube(16)
    a = prefilter.prefilter_cosine_power(cube)
    b = prefilter.prefilter_powers(cube, prefilter.cmft_powers(5, 13, 0, "blinn"))
    for x, y in zip(a, b, strict=True):
        np.testing.assert_array_equal(x, y)


class _Models(Enum):  # pyktx2 0.3.1 lists only 0 and the Basis models (KHR DF spec 1.3, 5.6)
    NONE = 0
    KHR_DF_MODEL_RGBSDA = 1
    KHR_DF_MODEL_ETC1S = 163
    KHR_DF_MODEL_UASTC = 166


def chain():
    cube = smooth_cube(8)
    mips = [cube]
    while mips[-1].shape[1] > 1:
        mips.append(cubemap.downsample(mips[-1]))
    return mips


def test_ktx2_read_back_by_pyktx2(tmp_path, monkeypatch):
    parser = pytest.importorskip("pyktx2.parser")
    monkeypatch.setattr(parser, "ColorModel", _Models)
    mips = chain()
    meta = engine_export.chain_metadata("bo2", prefilter.mip_powers(8), 8,
                                        engine_export.cube_sh(mips[0]))
    path = tmp_path / "c.ktx2"
    assert engine_export.write_chain(path, mips, meta) == [path]
    k = parser.parse_path(path)
    assert k.vkFormat.name == "VK_FORMAT_R16G16B16A16_SFLOAT"
    assert (k.pixelWidth, k.pixelHeight, k.faceCount, k.levelCount, k.layerCount) == (
        8, 8, 6, 4, 0)
    dfd, samples = k.dfd
    assert dfd.colorModel.value == 1 and dfd.transferFunction.name == "KHR_DF_TRANSFER_LINEAR"
    assert len(samples) == 4 and dfd.bytesPlane0 == 8
    assert all(i.byteOffset % 8 == 0 for i in k.levelIndices)
    assert json.loads(k.kv["bo2.meta"].rstrip(b"\0")) == json.loads(json.dumps(meta))
    assert k.kv["KTXwriter"].rstrip(b" \0") == b"BO2 Lighting"
    images = iter(k.levelImages)
    for m, level in enumerate(mips):  # level m: its six faces, +X first
        gpu = gpu_textures.to_gpu_faces(level)
        for face in range(6):
            image = next(images)
            assert (image.width, image.height) == (8 >> m, 8 >> m)
            texels = np.frombuffer(image.data, np.float16).reshape(8 >> m, 8 >> m, 4)
            np.testing.assert_array_equal(texels[..., :3], gpu[face].astype(np.float16))
            assert (texels[..., 3] == 1).all()


def test_dds_by_its_documented_layout(tmp_path):
    mips = chain()
    path = tmp_path / "c.dds"
    meta = {"x": 1}
    assert engine_export.write_chain(path, mips, meta) == [path, tmp_path / "c.json"]
    assert json.loads((tmp_path / "c.json").read_text()) == meta
    data = path.read_bytes()
    assert data[:4] == b"DDS "
    # DDS_HEADER (Microsoft Learn, "DDS_HEADER structure")
    (size, flags, height, width, pitch, depth, mip_count) = struct.unpack_from("<7I", data, 4)
    assert (size, height, width, mip_count, pitch) == (124, 8, 8, 4, 8 * 8)
    assert flags & 0x20000 and flags & 0x1007 == 0x1007  # MIPMAPCOUNT, CAPS HEIGHT WIDTH PIXFMT
    pf_size, pf_flags, fourcc = struct.unpack_from("<II4s", data, 4 + 72)
    assert (pf_size, pf_flags, fourcc) == (32, 0x4, b"DX10")
    caps, caps2 = struct.unpack_from("<II", data, 4 + 104)
    assert caps & 0x401008 == 0x401008 and caps2 & 0xFE00 == 0xFE00  # mipmap complex texture
    # DDS_HEADER_DXT10: DXGI_FORMAT_R16G16B16A16_FLOAT, TEXTURE2D, TEXTURECUBE, one cube
    assert struct.unpack_from("<5I", data, 128) == (10, 3, 0x4, 1, 0)
    offset = 148
    for face in range(6):  # face by face, each face's mips largest first
        for m, level in enumerate(mips):
            s = 8 >> m
            texels = np.frombuffer(data, np.float16, s * s * 4, offset).reshape(s, s, 4)
            gpu = gpu_textures.to_gpu_faces(level)
            np.testing.assert_array_equal(texels[..., :3], gpu[face].astype(np.float16))
            offset += s * s * 8
    assert offset == len(data)


def test_sh_rotate_to_y_up_matches_a_projection_in_y_up_axes():
    cube = smooth_cube(32)
    direct = engine_export.cube_sh(cube)
    size = cube.shape[1]
    d = cubemap.texel_directions(size).reshape(-1, 3)
    omega = np.broadcast_to(cubemap.texel_solid_angles(size), (6, size, size)).reshape(-1)
    blender = sh.project(d, cube.reshape(-1, 3), omega)
    np.testing.assert_allclose(sh.rotate(blender, gpu_textures.Y_UP), direct, atol=1e-6)


def bo2(*args):
    return subprocess.run([str(BO2), *map(str, args)], capture_output=True, text=True,
                          timeout=600)


def one_error(proc) -> str:
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("bo2: error: "), proc.stderr
    return lines[0]


def latlong(path: Path, h=32):
    u = (np.arange(2 * h) + 0.5) / (2 * h)
    v = (np.arange(h) + 0.5) / h
    img = np.stack(np.broadcast_arrays(u[None, :], v[:, None], 0.5), -1).astype(np.float32)
    rgbe = np.zeros(img.shape[:2] + (4,), np.uint8)
    m, e = np.frexp(img.max(-1))
    rgbe[..., 3] = e + 128
    rgbe[..., :3] = np.clip(img / np.ldexp(1.0, e - 8)[..., None], 0, 255).astype(np.uint8)
    rgbe_file(path, rgbe, rle=True)


def test_prefilter_command_without_blender(tmp_path):
    src = tmp_path / "sky.hdr"
    latlong(src)
    code = ("import sys; from bo2_lighting.addon.cli import main; r = main(sys.argv[1:]); "
            "assert 'bpy' not in sys.modules, 'bpy imported'; sys.exit(r)")
    proc = subprocess.run([sys.executable, "-c", code, "prefilter", str(src), "-o",
                           str(tmp_path / "a.ktx2"), "-o", str(tmp_path / "a.exr"), "--size",
                           "16", "--json"], capture_output=True, text=True, timeout=600)
    assert proc.returncode == 0, proc.stderr
    out = json.loads(proc.stdout.splitlines()[-1])
    assert out["mips"] == 5 and out["gloss_to_lod"] == "lod = 4 - gloss * 4"
    assert out["mip_phong_power"][0] == pytest.approx(2048)
    import OpenEXR

    parts = OpenEXR.File(str(tmp_path / "a.exr")).parts
    assert [p.name() for p in parts] == [f"mip{m}" for m in range(5)]
    assert parts[0].channels["RGB"].pixels.shape == (6 * 16, 16, 3)
    proc = bo2("prefilter", src, "-o", tmp_path / "b.dds", "--filter", "blinnbrdf",
               "--gloss-scale", "11", "--gloss-bias", "0", "--size", "8", "--mips", "3",
               "--edge-fixup", "warp", "--exclude-base")
    assert proc.returncode == 0, proc.stderr
    meta = json.loads((tmp_path / "b.json").read_text())
    assert meta["mip_phong_power"] == pytest.approx([2048 / 4 + 1, 2 ** 5.5 / 4 + 1, 1.25])
    assert meta["edge_fixup"] == "warp" and meta["exclude_base"]


def test_prefilter_bad_input_is_one_line_and_exit_2(tmp_path):
    src = tmp_path / "sky.hdr"
    latlong(src)
    good = src.read_bytes()
    cases = {
        "truncated.hdr": good[:len(good) // 2],
        "noise.exr": b"\x76\x2f\x31\x01" + bytes(range(256)) * 4,
        "header.hdr": b"#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n",
        "text.hdr": b"hello",
    }
    for name, data in cases.items():
        (tmp_path / name).write_bytes(data)
        proc = bo2("prefilter", tmp_path / name, "-o", tmp_path / "x.ktx2")
        assert proc.returncode == 2, (name, proc.stderr)
        one_error(proc)
    wide = tmp_path / "wide.hdr"  # 5:3, neither lat-long nor cross
    rgbe_file(wide, np.full((30, 50, 4), 128, np.uint8), rle=True)
    tiny = tmp_path / "tiny.hdr"
    rgbe_file(tiny, np.full((1, 1, 4), 128, np.uint8), rle=False)
    for image, what in ((wide, "neither a lat-long"), (tiny, "too small"),
                        (tmp_path / "missing.hdr", "no such file")):
        proc = bo2("prefilter", image, "-o", tmp_path / "x.ktx2")
        assert proc.returncode == 2 and what in one_error(proc), proc.stderr
    proc = bo2("prefilter", src, "-o", tmp_path / "nowhere" / "x.ktx2")
    assert proc.returncode == 2 and "no such folder" in one_error(proc)
    proc = bo2("prefilter", src, "-o", tmp_path / "x.png")
    assert proc.returncode == 2 and "unknown format" in one_error(proc)
    assert not list(tmp_path.glob("x.*")) and not list(tmp_path.glob(".*tmp"))  # nothing half
    nan = tmp_path / "nan.exr"
    import OpenEXR

    img = np.ones((16, 32, 3), np.float32)
    img[3, 4] = np.nan
    OpenEXR.File({}, {"RGB": img}).write(str(nan))
    proc = bo2("prefilter", nan, "-o", tmp_path / "n.ktx2", "--size", "8")
    assert proc.returncode == 0 and "1 texels are NaN or infinite" in proc.stderr


def test_prefilter_refuses_what_would_lose_data(tmp_path):
    """Its own input as output is refused before anything is written; a non-finite gloss
    mapping is refused up front; negative texels are read as 0 with a warning."""
    src = tmp_path / "sky.exr"
    import OpenEXR

    img = np.ones((16, 32, 3), np.float32)
    img[2, 3] = -5.0
    OpenEXR.File({}, {"RGB": img}).write(str(src))
    before = src.read_bytes()
    for out in (src, tmp_path / "." / "sky.exr"):
        proc = bo2("prefilter", src, "-o", out, "--size", "8")
        assert proc.returncode == 2 and "this is the input" in one_error(proc)
        assert src.read_bytes() == before
    for value in ("nan", "inf", "-inf"):
        proc = bo2("prefilter", src, "-o", tmp_path / "g.ktx2", "--filter", "phong",
                   f"--gloss-scale={value}")
        assert proc.returncode == 2 and "finite" in proc.stderr, proc.stderr
    proc = bo2("prefilter", src, "-o", tmp_path / "n.exr", "--size", "8")
    assert proc.returncode == 0 and "1 texels are negative; read as 0" in proc.stderr
    parts = OpenEXR.File(str(tmp_path / "n.exr")).parts
    assert min(float(p.channels["RGB"].pixels.min()) for p in parts) >= 0.0


def test_prefilter_says_when_half_floats_clip_and_scales(tmp_path):
    """A sun of 10^6 in a KTX2 (half floats, at most 65504): one warning that names the
    brightest value and the --scale that fits; with that scale nothing clips and the files
    record it."""
    import OpenEXR

    src = tmp_path / "sun.exr"
    img = np.full((16, 32, 3), 0.5, np.float32)
    img[4, 10] = 1e6
    OpenEXR.File({}, {"RGB": img}).write(str(src))
    proc = bo2("prefilter", src, "-o", tmp_path / "a.ktx2", "--size", "8", "--json")
    assert proc.returncode == 0, proc.stderr
    warning = [w for w in proc.stderr.splitlines() if "65504" in w]
    assert len(warning) == 1 and "clipped" in warning[0] and "--scale" in warning[0]
    scale = float(warning[0].split("--scale ")[1].split()[0])
    assert 0.0 < scale < 1.0
    proc = bo2("prefilter", src, "-o", tmp_path / "b.ktx2", "--size", "8", "--json",
               "--scale", scale)
    assert proc.returncode == 0 and "65504" not in proc.stderr, proc.stderr
    meta = json.loads(proc.stdout.splitlines()[-1])
    assert meta["scale"] == pytest.approx(scale)
    proc = bo2("prefilter", src, "-o", tmp_path / "c.exr", "--size", "8")
    assert proc.returncode == 0 and "65504" not in proc.stderr  # float32: nothing clips
    for bad in ("0", "-1", "nan"):
        proc = bo2("prefilter", src, "-o", tmp_path / "d.ktx2", f"--scale={bad}")
        assert proc.returncode == 2


def test_a_damaged_bake_file_is_named_once_and_the_library_is_silent(tmp_path):
    """OpenEXR's own complaints about a damaged file stay out of stdout and stderr; the
    error names the file once."""
    from bo2_lighting.addon.core.files import probe_file

    path = tmp_path / "probe.exr"
    probe_file.write(path, {"kind": "reflection"}, np.zeros((1, 9, 3), np.float32),
                     {"bo2": [np.ones((6, 4, 4, 3), np.float32)]})
    data = bytearray(path.read_bytes())
    for k, at in enumerate((len(data) - 30, len(data) // 2)):
        broken = bytearray(data)
        broken[at:at + 20] = b"\xff" * 20
        bad = tmp_path / f"bad{k}.exr"
        bad.write_bytes(bytes(broken))
        code = ("import sys; from bo2_lighting.addon.core.files import bake_file, probe_file\n"
                "try: probe_file.read(sys.argv[1])\n"
                "except bake_file.BakeFileError as e: print('refused:', e, file=sys.stderr)")
        proc = subprocess.run([sys.executable, "-c", code, str(bad)], capture_output=True,
                              text=True, timeout=120)
        assert proc.stdout == "", proc.stdout
        lines = proc.stderr.strip().splitlines()
        assert len(lines) == 1 and lines[0].startswith("refused: "), proc.stderr
        assert lines[0].count(bad.name) == 1 and str(tmp_path) not in lines[0], lines[0]
