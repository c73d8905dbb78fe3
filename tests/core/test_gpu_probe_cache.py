"""The GPU probe's answer kept on disk: a second session reads it instead of starting the
child again, unless the display, the binary or a day has changed; a damaged file is asked
again and rewritten."""

import json
import sys
import time

import pytest

from bo2_lighting.addon.gpu_backend import device


@pytest.fixture
def child(tmp_path, monkeypatch):
    """A probe command that counts its runs in a file and answers like a GPU would."""
    runs = tmp_path / "runs"
    code = (f"open({str(runs)!r}, 'a').write('x')\n"
            "print('BO2-GPU', 'OK', 'OpenGL', 'Test GPU', sep='\\t')")
    monkeypatch.setattr(device, "_probed", {})
    return [sys.executable, "-c", code], (lambda: len(runs.read_text()) if runs.exists() else 0)


def _new_session(monkeypatch):
    monkeypatch.setattr(device, "_probed", {})


def test_the_answer_is_read_from_disk_in_the_next_session(child, tmp_path, monkeypatch):
    command, runs = child
    cache = tmp_path / "gpu_device.json"
    first = device.probe(command, cache)
    assert first.ok and first.renderer == "Test GPU" and runs() == 1
    _new_session(monkeypatch)
    again = device.probe(command, cache)
    assert again == first and runs() == 1


def test_another_display_asks_again(child, tmp_path, monkeypatch):
    command, runs = child
    cache = tmp_path / "gpu_device.json"
    monkeypatch.setenv("DISPLAY", ":0")
    device.probe(command, cache)
    _new_session(monkeypatch)
    monkeypatch.delenv("DISPLAY")
    device.probe(command, cache)
    assert runs() == 2


def test_an_old_answer_is_asked_again(child, tmp_path, monkeypatch):
    command, runs = child
    cache = tmp_path / "gpu_device.json"
    device.probe(command, cache)
    entries = json.loads(cache.read_text())
    for entry in entries.values():
        entry["time"] = time.time() - device.MAX_AGE - 1
    cache.write_text(json.dumps(entries))
    _new_session(monkeypatch)
    device.probe(command, cache)
    assert runs() == 2


def test_a_damaged_file_is_asked_again_and_rewritten(child, tmp_path, monkeypatch):
    command, runs = child
    cache = tmp_path / "gpu_device.json"
    cache.write_text("{not json")
    found = device.probe(command, cache)
    assert found.ok and runs() == 1
    assert len(json.loads(cache.read_text())) == 1
    assert not list(tmp_path.glob("*.tmp"))


def test_an_unwritable_folder_is_no_error(child, tmp_path):
    command, runs = child
    blocker = tmp_path / "file"
    blocker.write_text("")
    assert device.probe(command, blocker / "gpu_device.json").ok and runs() == 1


def test_a_child_that_could_not_run_is_asked_again(tmp_path, monkeypatch):
    monkeypatch.setattr(device, "_probed", {})
    cache = tmp_path / "gpu_device.json"
    found = device.probe([str(tmp_path / "no-such-blender")], cache)
    assert not found.ok and "could not run" in found.reason
    assert not cache.exists()


def test_a_damaged_entry_is_no_error(child, tmp_path, monkeypatch):
    command, runs = child
    cache = tmp_path / "gpu_device.json"
    cache.write_text(json.dumps({"other": {"time": "soon"}, "x": 3}))
    assert device.probe(command, cache).ok and runs() == 1
    _new_session(monkeypatch)
    assert device.probe(command, cache).ok and runs() == 1


def test_a_kept_yes_for_a_display_that_is_gone_is_asked_again(child, tmp_path, monkeypatch):
    command, runs = child
    cache = tmp_path / "gpu_device.json"
    monkeypatch.setenv("DISPLAY", ":4321")  # no such X server's socket
    device.probe(command, cache)
    _new_session(monkeypatch)
    device.probe(command, cache)
    assert runs() == 2
