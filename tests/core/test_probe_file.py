"""Probe files (core/files/probe_file.py): round trip, atomic replacement, clear errors."""

import os

import numpy as np
import pytest

from bo2_lighting.addon.core.files import bake_file, probe_file


def chains(size=8):
    rng = np.random.default_rng(3)
    out = {}
    for name in ("bo2", "bo1"):
        out[name] = [rng.random((6, size >> m, size >> m, 3), dtype=np.float32)
                     for m in range(size.bit_length())]
    return out


def test_round_trip(tmp_path):
    path = tmp_path / "Probe.exr"
    sh = np.random.default_rng(1).normal(size=(1, 9, 3)).astype(np.float32)
    mips = chains()
    probe_file.write(path, {"probe": "Probe", "kind": "reflection"}, sh, mips)
    meta, sh2, mips2 = probe_file.read(path)
    assert meta["probe"] == "Probe" and meta["format"] == probe_file.FORMAT
    np.testing.assert_array_equal(sh2, sh)
    assert set(mips2) == {"bo2", "bo1"} and len(mips2["bo2"]) == 4
    for name in mips:
        for a, b in zip(mips[name], mips2[name], strict=True):
            np.testing.assert_array_equal(a, b)
    volume = np.ones((2 * 3 * 4, 9, 3), np.float32)
    probe_file.write(tmp_path / "Volume.exr", {"kind": "irradiance"}, volume)
    meta, sh3, mips3 = probe_file.read(tmp_path / "Volume.exr")
    assert sh3.shape == (24, 9, 3) and mips3 == {}  # baked before the depth: none
    depth = np.random.default_rng(2).uniform(0, 4, (24, 6, 8, 8, 2)).astype(np.float32)
    probe_file.write(tmp_path / "Volume.exr", {"kind": "irradiance"}, volume,
                     {probe_file.DEPTH: [depth]})
    meta, sh3, mips3 = probe_file.read(tmp_path / "Volume.exr")
    assert set(mips3) == {probe_file.DEPTH}
    np.testing.assert_array_equal(mips3[probe_file.DEPTH][0], depth)


def test_failed_write_keeps_the_previous_file_byte_identical(tmp_path, monkeypatch):
    path = tmp_path / "Probe.exr"
    probe_file.write(path, {"probe": "old"}, np.zeros((1, 9, 3)), chains())
    before = path.read_bytes()

    def broken_replace(src, dst):
        raise OSError("disk full")

    monkeypatch.setattr(os, "replace", broken_replace)
    with pytest.raises(OSError, match="disk full"):
        probe_file.write(path, {"probe": "new"}, np.ones((1, 9, 3)), chains())
    assert path.read_bytes() == before
    assert [p.name for p in tmp_path.iterdir()] == ["Probe.exr"]  # no temporary left behind


@pytest.mark.parametrize("content", [b"", b"garbage" * 100, None])
def test_unusable_files_give_one_clear_error(tmp_path, content):
    path = tmp_path / "Probe.exr"
    if content is not None:
        path.write_bytes(content)
    with pytest.raises(bake_file.BakeFileError) as err:
        probe_file.read(path)
    assert "Probe.exr" in str(err.value) and "\n" not in str(err.value)


def test_truncated_file_is_an_error(tmp_path):
    path = tmp_path / "Probe.exr"
    probe_file.write(path, {"probe": "p"}, np.zeros((1, 9, 3)), chains())
    data = path.read_bytes()
    path.write_bytes(data[: len(data) // 2])
    with pytest.raises(bake_file.BakeFileError):
        probe_file.read(path)


@pytest.mark.parametrize("where, value", [("sh", np.nan), ("sh", np.inf), ("mip", -np.inf),
                                          ("mip", np.nan)])
def test_non_finite_light_is_refused_though_the_checksum_holds(tmp_path, where, value):
    """A writer that put NaN or inf in the file also checksummed them: the reader refuses."""
    sh = np.ones((1, 9, 3), np.float32)
    mips = chains()
    if where == "sh":
        sh[0, 4, 1] = value
    else:
        mips["bo1"][2][3, 0, 1, 2] = value
    path = tmp_path / "Bad name.exr"
    probe_file.write(path, {"kind": "reflection"}, sh, mips)
    with pytest.raises(bake_file.BakeFileError,
                       match=r"^Bad name\.exr: part (sh|bo1\.mip2) holds NaN or infinite"):
        probe_file.read(path)


def three_probes(tmp_path, value):
    return [(tmp_path / f"P{k}.exr", {"probe": f"P{k}", "v": value},
             np.full((1, 9, 3), value, np.float32), chains()) for k in range(3)]


def snapshot(folder):
    return {p.name: p.read_bytes() for p in sorted(folder.iterdir())}


@pytest.mark.parametrize("failing", [1, 2, 3])
def test_a_failed_nth_write_keeps_every_old_file(tmp_path, monkeypatch, failing):
    probe_file.write_all(three_probes(tmp_path, 1.0))
    (tmp_path / "P1.exr").unlink()  # one probe new in this bake
    before = snapshot(tmp_path)
    real, calls = probe_file._encode, []

    def encode(path, *args):
        calls.append(path)
        if len(calls) == failing:
            raise OSError(28, "No space left on device")
        real(path, *args)

    monkeypatch.setattr(probe_file, "_encode", encode)
    with pytest.raises(OSError, match="No space left"):
        probe_file.write_all(three_probes(tmp_path, 2.0))
    assert snapshot(tmp_path) == before  # no temporary, no new file, the old ones intact


@pytest.mark.parametrize("failing", [2, 3, 4, 5])
def test_a_failed_swap_puts_every_old_file_back(tmp_path, monkeypatch, failing):
    probe_file.write_all(three_probes(tmp_path, 1.0))
    (tmp_path / "P2.exr").unlink()
    before = snapshot(tmp_path)
    real, calls = os.replace, []

    def replace(src, dst):
        calls.append((src, dst))
        if len(calls) == failing:
            raise OSError(5, "Input/output error")
        real(src, dst)

    monkeypatch.setattr(os, "replace", replace)
    with pytest.raises(OSError, match="Input/output"):
        probe_file.write_all(three_probes(tmp_path, 2.0))
    monkeypatch.setattr(os, "replace", real)
    assert snapshot(tmp_path) == before


def test_a_folder_at_a_probes_path_changes_nothing(tmp_path):
    probe_file.write_all(three_probes(tmp_path, 1.0))
    (tmp_path / "P1.exr").unlink()
    (tmp_path / "P1.exr").mkdir()
    before = {p.name: p.is_dir() or p.read_bytes() for p in tmp_path.iterdir()}
    with pytest.raises(IsADirectoryError, match="a folder stands where"):
        probe_file.write_all(three_probes(tmp_path, 2.0))
    assert {p.name: p.is_dir() or p.read_bytes() for p in tmp_path.iterdir()} == before
    probe_file.write_all(three_probes(tmp_path, 2.0)[::2])  # the others alone are fine
    assert probe_file.read(tmp_path / "P2.exr")[0]["v"] == 2.0


def test_size_bound_holds(tmp_path):
    for points, face in ((1, 128), (1, 32), (300, None)):
        sh = np.random.default_rng(0).random((points, 9, 3), dtype=np.float32)
        path = tmp_path / f"p{points}_{face}.exr"
        probe_file.write(path, {"kind": "x"}, sh, chains(face) if face else None)
        assert path.stat().st_size <= probe_file.size_bound(points, face)
