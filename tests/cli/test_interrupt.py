"""Ctrl-C: every command stops, exits 130, keeps what it finished and leaves nothing half-done.

Run as a user runs it: the command in a subprocess, SIGINT sent once work is under way.
"""

import hashlib
import json
import re
import shutil
import signal
import subprocess
import threading
import time
import zlib

import numpy as np
from test_cli import BO2, ROOT, bo2


def watched(cmd, look, limit=300.0):
    """Run ``bo2 cmd`` to its end (or ``limit`` seconds), ``look(said, proc)`` called as its
    stderr comes (``said``: its stderr so far); returns the finished process, its output in
    ``stdout_text`` and ``stderr_text``."""
    proc = subprocess.Popen([str(BO2), *map(str, cmd)], stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True)
    said = []
    reader = threading.Thread(target=lambda: said.extend(iter(lambda: proc.stderr.read(1), "")))
    reader.start()
    start = time.monotonic()
    while proc.poll() is None and time.monotonic() - start < limit:
        look("".join(said), proc)
        time.sleep(0.05)
    proc.stdout_text = proc.stdout.read()  # (stderr is the reader's)
    proc.wait(timeout=limit)
    reader.join(timeout=limit)
    proc.stderr_text = "".join(said)
    return proc


def interrupted(cmd, ready, limit=120.0):
    """Run ``cmd``, send SIGINT once ``ready(said)`` is true (``said``: its stderr so far),
    return the finished process (``watched``)."""
    sent = []

    def look(said, proc):
        if not sent and ready(said):
            proc.send_signal(signal.SIGINT)
            sent.append(True)

    return watched(cmd, look, limit)


def progress(said: str) -> float:
    """The last percentage a progress bar printed in ``said``, 0 before the first."""
    found = re.findall(r"(\d+(?:\.\d+)?)%", said)
    return float(found[-1]) if found else 0.0


def test_render_stops_keeps_finished_frames_and_writes_no_partial_one(tmp_path):
    out = tmp_path / "f_#.png"
    summary = tmp_path / "s.json"
    proc = interrupted(("render", ROOT / "demo_blends" / "room.blend", "--frames", "1-4",
                        "-o", out, "--samples", "8", "--resolution", "320x180",
                        "--summary", summary),
                       ready=lambda said: (tmp_path / "f_1.png").exists())
    assert proc.returncode == 130, proc.stderr_text
    assert proc.stderr_text.strip().splitlines()[-1] == "bo2: interrupted"
    names = sorted(p.name for p in tmp_path.iterdir())
    assert "f_1.png" in names and "f_4.png" not in names and "s.json" in names
    assert not [n for n in names if n.startswith(".") or n.endswith((".tmp", ".part"))]
    report = json.loads(summary.read_text())
    assert report["interrupted"] is True
    assert [i["status"] for i in report["images"]] == ["ok"] * (len(names) - 1)


def digests(folder):
    return {p.name: hashlib.sha256(p.read_bytes()).hexdigest() for p in folder.iterdir()}


def test_bake_stops_and_keeps_the_previous_files(tmp_path):
    blend = tmp_path / "closed_room.blend"
    shutil.copyfile(ROOT / "demo_blends" / "closed_room.blend", blend)
    assert bo2("bake", blend).returncode == 0
    folder = tmp_path / "bo2_bake" / "closed_room"
    before = digests(folder)
    saved = blend.read_bytes()
    # under way: a third of the bake done, far from its end (a time could fall after it)
    proc = interrupted(("bake", blend), ready=lambda said: progress(said) > 30.0)
    assert proc.returncode == 130, proc.stderr_text
    assert proc.stderr_text.strip().splitlines()[-1] == "bo2: interrupted"
    assert digests(folder) == before  # nothing replaced, no temporary file left
    assert blend.read_bytes() == saved  # the .blend is saved only after a finished bake


def test_lightmap_bake_stops_and_keeps_the_previous_lightmaps(tmp_path):
    blend = tmp_path / "closed_room.blend"
    shutil.copyfile(ROOT / "demo_blends" / "closed_room.blend", blend)
    assert bo2("bake", blend, "--lightmaps", "--backend", "bo2").returncode == 0
    folder = tmp_path / "bo2_bake" / "closed_room" / "lightmaps"
    before = digests(folder)
    proc = interrupted(("bake", blend, "--lightmaps"),
                       ready=lambda said: progress(said) > 30.0)
    assert proc.returncode == 130, proc.stderr_text
    assert proc.stderr_text.strip().splitlines()[-1] == "bo2: interrupted"
    assert digests(folder) == before  # nothing replaced, no temporary file left


def test_the_finished_frame_is_whole(tmp_path):
    """The kept image is a whole frame: equal to the same frame rendered without Ctrl-C."""
    args = ("--samples", "8", "--resolution", "320x180")
    proc = interrupted(("render", ROOT / "demo_blends" / "room.blend", "--frames", "1-3",
                        "-o", tmp_path / "a_#.png", *args),
                       ready=lambda said: (tmp_path / "a_1.png").exists())
    assert proc.returncode == 130
    assert bo2("render", ROOT / "demo_blends" / "room.blend", "--frame", "1",
               "-o", tmp_path / "b.png", *args).returncode == 0
    a = png_pixels(tmp_path / "a_1.png")
    b = png_pixels(tmp_path / "b.png")
    np.testing.assert_array_equal(a, b)


def png_pixels(path):
    """The decompressed scanlines of a PNG file (equal images, equal bytes)."""
    data = path.read_bytes()
    assert data[:8] == b"\x89PNG\r\n\x1a\n"
    chunks, at = [], 8
    while at < len(data):
        n = int.from_bytes(data[at:at + 4], "big")
        kind = data[at + 4:at + 8]
        if kind == b"IDAT":
            chunks.append(data[at + 8:at + 8 + n])
        at += 12 + n
    return np.frombuffer(zlib.decompress(b"".join(chunks)), np.uint8)


def test_a_cycles_render_is_ended_too(tmp_path):
    """Cycles does not poll Python: the deadline ends it, with nothing written."""
    began = time.monotonic()
    proc = interrupted(("render", ROOT / "demo_blends" / "room.blend", "--engine", "cycles",
                        "--samples", "100000", "-o", tmp_path / "c.png"),
                       ready=lambda said: time.monotonic() - began > 6.0)
    assert proc.returncode == 130, proc.stderr_text
    assert proc.stderr_text.strip().splitlines()[-1] == "bo2: interrupted"
    assert list(tmp_path.iterdir()) == []


def test_the_deadline_exit_removes_the_copies_of_packed_bakes(tmp_path):
    """Ctrl-C while work does not poll (a lightmap bake's last 5%): the process is ended at
    the deadline, skipping atexit; the copies of packed bakes in the temporary folder go too."""
    import os
    import sys

    code = ("import sys, time, bpy\n"
            "from bo2_lighting.addon.blender import bake_files, interrupt\n"
            "interrupt.install()\n"
            "print(bake_files._copies(), flush=True)\n"
            "time.sleep(60)\n")
    proc = subprocess.Popen([sys.executable, "-c", code], stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True,
                            env={**os.environ, "TMPDIR": str(tmp_path)})
    folder = proc.stdout.readline().strip()
    assert folder.startswith(str(tmp_path)) and os.path.isdir(folder)
    proc.send_signal(signal.SIGINT)
    _, err = proc.communicate(timeout=60)
    assert proc.returncode == 130 and "bo2: interrupted" in err
    assert not list(tmp_path.glob("bo2_packed_*"))
