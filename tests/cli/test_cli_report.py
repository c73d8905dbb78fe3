"""``bo2 report`` as a pipeline runs it: a subprocess, checked by exit code, output and files."""

import json
import signal
import subprocess
import time

import pytest
from test_cli import BO2, DEMO, bo2, empty_blend, one_error_line

from bo2_lighting.addon.core.review import flip

SMALL = ("--resolution", "64x36", "--samples", "1", "--cycles-samples", "4")
needs_flip = pytest.mark.skipif(flip.unavailable() is not None, reason="no flip-evaluator")


def scenes(folder):
    return json.loads((folder / "report.json").read_text())["scenes"]


@pytest.fixture(scope="module")
def compared(tmp_path_factory):
    """A bo2 compare folder of the demo scene."""
    out = tmp_path_factory.mktemp("cmp") / "first_light"
    proc = bo2("compare", DEMO, "-o", out, *SMALL)
    assert proc.returncode == 0, proc.stderr
    return out


@needs_flip
def test_render_and_reuse(tmp_path, compared):
    out = tmp_path / "review"
    proc = bo2("report", DEMO, compared.parent, "-o", out, *SMALL, "--old-methods")
    assert proc.returncode == 0, proc.stderr
    assert proc.stdout.strip() == str(out / "index.html")
    found = scenes(out)
    # two scenes of one name are told apart by their folders
    assert sorted(s["name"] for s in found) == [f"{compared.parent.name}/first_light",
                                                "demo_blends/first_light"]
    rendered = next(s for s in found if "bo2_old" in s["variants"])
    reused = next(s for s in found if "bo2_old" not in s["variants"])
    assert rendered["folder"] == "demo_blends_first_light"
    assert reused["folder"] == f"{compared.parent.name}_first_light"
    assert reused["links"]["cycles"].endswith("cmp0/first_light/cycles.exr")
    assert (out / "scenes" / "demo_blends_first_light" / "old" / "bo2.exr").exists()
    assert not (compared / "hdr.js").exists()  # a reused folder is only read
    for s in found:
        assert 0 < s["variants"]["bo2"]["metrics"]["Combined"]["flip_ldr"] < 1


@needs_flip
def test_fail_above(tmp_path, compared):
    out = tmp_path / "review"
    proc = bo2("report", compared, "-o", out, "--fail-above", "0")
    assert proc.returncode == 1
    assert "first_light: mean FLIP" in proc.stderr and "above 0.0" in proc.stderr
    [s] = scenes(out)
    assert s["failing"] is True
    proc = bo2("report", compared, "-o", out, "--fail-above", "1")
    assert proc.returncode == 0, proc.stderr
    assert scenes(out)[0]["failing"] is False


def test_bad_input(tmp_path):
    for args, code, text in [
        (("--fail-above", "2"), 2, "between 0 and 1"),
        (("--fail-above", "x"), 2, "not a number"),
    ]:
        proc = bo2("report", DEMO, "-o", tmp_path / "r", *args)
        assert proc.returncode == code and text in one_error_line(proc)
    proc = bo2("report", tmp_path / "missing.blend", "-o", tmp_path / "r")
    assert proc.returncode == 1 and "no such file or folder" in one_error_line(proc)
    (tmp_path / "empty").mkdir()
    proc = bo2("report", tmp_path / "empty", "-o", tmp_path / "r")
    assert proc.returncode == 1 and "holds no .blend file" in one_error_line(proc)
    blend = empty_blend(tmp_path / "nocam.blend")
    proc = bo2("report", blend, "-o", tmp_path / "r")
    assert proc.returncode == 1
    lines = [s for s in proc.stderr.splitlines() if s.startswith("bo2: error:")]
    assert lines == [f"bo2: error: nocam: {blend}: the scene has no active camera",
                     "bo2: error: no scene could be compared"]


@needs_flip
def test_interrupt_keeps_the_scenes_done(tmp_path, compared):
    """Ctrl-C during the second scene's Cycles render: exit 130, the page holds the first."""
    out = tmp_path / "review"
    proc = subprocess.Popen([str(BO2), "report", str(compared), str(DEMO), "-o", str(out),
                             "--resolution", "96x54", "--samples", "1", "--cycles-samples",
                             "100000"], stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                            text=True)
    try:
        deadline = time.monotonic() + 180
        bo2_exr = out / "scenes" / "demo_blends_first_light" / "bo2.exr"
        while not bo2_exr.exists() and time.monotonic() < deadline:
            assert proc.poll() is None, proc.communicate()
            time.sleep(0.1)
        time.sleep(1.0)  # Cycles is rendering now
        proc.send_signal(signal.SIGINT)
        _, stderr = proc.communicate(timeout=30)
    finally:
        proc.kill()
    assert proc.returncode == 130
    last = stderr.strip().splitlines()[-1]
    assert last == (f"bo2: error: interrupted during demo_blends/first_light: Cycles render; "
                    f"{out / 'index.html'} holds the 1 scene done")
    data = json.loads((out / "report.json").read_text())
    assert [s["name"] for s in data["scenes"]] == [f"{compared.parent.name}/first_light"]
    assert data["pending"] == ["demo_blends/first_light"]


def test_a_folder_with_a_page_of_its_own_is_left_alone(tmp_path, compared):
    """-o into a folder whose index.html is not a review page (no report.json): refused, the
    page untouched; a review's own folder is rewritten."""
    site = tmp_path / "site"
    site.mkdir()
    (site / "index.html").write_text("<p>my page</p>")
    proc = bo2("report", compared, "-o", site)
    assert proc.returncode == 1 and "is not a review page" in one_error_line(proc)
    assert (site / "index.html").read_text() == "<p>my page</p>"
    assert sorted(p.name for p in site.iterdir()) == ["index.html"]
