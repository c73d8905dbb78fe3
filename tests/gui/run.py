"""``make test-gui``: the walk through the artist's Blender (``walk.py``) in a real window.

Usage: python tests/gui/run.py ZIP [--out out/gui] [--docs docs/images]

Runs the windowed Blender that ``tools/gui_blender.sh`` provides with a fresh user folder (the
zip is installed into it as a user would), prints each check, and exits 1 when one failed, 0
when all passed. With ``--docs``, the screenshots the user guide shows are copied there too.
"""

from __future__ import annotations

import argparse
import contextlib
import json
import os
import shutil
import signal
import socket
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
# screenshot -> the user guide's picture
DOCS = {"render_tab": "ui_render_tab.png", "spot_light_tab": "ui_light_tab.png",
        "volume_probe_tab": "ui_probe_tab.png", "material_preview": "ui_material_tab.png",
        "shader_editor": "ui_shader_editor.png", "viewport_rendered": "ui_viewport.png",
        "viewport_studio_light": "ui_viewport_studio_light.png",
        "viewport_lookdev_albedo": "ui_viewport_lookdev.png",
        "viewport_world_of_nodes": "ui_viewport_world.png", "world_tab_(nodes)": "ui_world_tab.png",
        "render_tab_lightmaps": "ui_lightmaps.png",
        "object_tab_lightmap": "ui_object_lightmap.png",
        "viewport_lightmap_texels": "ui_viewport_lightmap_texels.png",
        "probe_bake_packed": "ui_probe_bake_packed.png",
        "render_tab_cluster": "ui_bake_on_cluster.png",
        "render_tab_review": "ui_review.png"}


def farm_check(runner: str, zip_path: Path, env: dict, folder: Path, out: Path) -> dict:
    """A render farm's task as the README gives it: the extension installed from its zip
    with Blender's command line, then one frame rendered in the background with BO2
    Lighting (``blender -b FILE -E BO2_LIGHTING -o PATTERN -f N``)."""
    name = "a farm's command line renders frame 2 with BO2 Lighting"
    install = subprocess.run([runner, "--command", "extension", "install-file", "-r",
                              "user_default", "-e", str(zip_path)], cwd=ROOT, env=env,
                             capture_output=True, text=True, timeout=600)
    if install.returncode != 0:
        return {"check": name, "ok": False, "detail": install.stdout[-1500:]}
    frame = subprocess.run([runner, "-b", str(ROOT / "demo_blends" / "first_light.blend"),
                            "-E", "BO2_LIGHTING", "-o", str(folder / "farm_####"), "-f", "2"],
                           cwd=ROOT, env=env, capture_output=True, text=True, timeout=600)
    image = folder / "farm_0002.png"
    ok = (frame.returncode == 0 and image.is_file() and image.stat().st_size > 1000
          and "BO2_LIGHTING" not in frame.stdout)  # (Blender names an engine it lacks)
    if ok:
        shutil.copy(image, out / "farm_0002.png")
    return {"check": name, "ok": ok, "detail": frame.stdout[-1500:]}


def dask_scheduler() -> tuple[subprocess.Popen, str]:
    """A Dask scheduler on 127.0.0.1, of this Python (the window's Blender runs another): the
    process and its address, once it listens."""
    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        port = probe.getsockname()[1]
    proc = subprocess.Popen([sys.executable, "-m", "distributed.cli.dask_scheduler", "--host",
                             "127.0.0.1", "--port", str(port), "--dashboard-address", ":0"],
                            stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    for _ in range(200):
        with socket.socket() as s, contextlib.suppress(OSError):
            s.connect(("127.0.0.1", port))
            break
        time.sleep(0.1)
    return proc, f"tcp://127.0.0.1:{port}"


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("zip", type=Path)
    parser.add_argument("--out", type=Path, default=ROOT / "out" / "gui")
    parser.add_argument("--docs", type=Path)
    parser.add_argument("--timeout", type=float, default=1200.0)
    args = parser.parse_args(argv)
    runner = subprocess.run([str(ROOT / "tools" / "gui_blender.sh")], capture_output=True,
                            text=True)
    if runner.returncode != 0:
        print(f"test-gui: no windowed Blender: {runner.stderr.strip()}", file=sys.stderr)
        return 2 if runner.returncode == 2 else 1
    out = args.out.resolve()
    shutil.rmtree(out, ignore_errors=True)
    out.mkdir(parents=True)
    # inside the window's chroot only the working folder and /tmp are seen
    with tempfile.TemporaryDirectory(prefix="bo2-gui-", dir="/tmp") as user:
        zip_copy = Path(user) / args.zip.name
        shutil.copy(args.zip, zip_copy)
        scheduler = dask_scheduler()
        env = {**os.environ, "BLENDER_USER_RESOURCES": str(Path(user) / "blender"),
               "BO2_GUI_SCHEDULER": scheduler[1]}
        cmd = [runner.stdout.strip(), "--factory-startup", "--python",
               str(ROOT / "tests" / "gui" / "walk.py"), "--", str(zip_copy), str(out)]
        # its own process group: a walk that hangs is ended with everything it started
        proc = subprocess.Popen(cmd, cwd=ROOT, env=env, stdout=subprocess.PIPE,
                                stderr=subprocess.STDOUT, text=True, start_new_session=True)
        try:
            log, _ = proc.communicate(timeout=args.timeout)
        except subprocess.TimeoutExpired:
            os.killpg(proc.pid, signal.SIGKILL)
            log, _ = proc.communicate()
            log += f"\ntest-gui: the walk did not end within {args.timeout:.0f} s"
        scheduler[0].kill()
        scheduler[0].wait()
        farm = farm_check(runner.stdout.strip(), zip_copy, env, Path(user), out)
    (out / "blender.log").write_text(log)
    results = out / "results.json"
    if not results.exists():
        print(log[-3000:])
        print("test-gui: the walk wrote no results (see out/gui/blender.log)", file=sys.stderr)
        return 1
    data = json.loads(results.read_text())
    data["checks"].append(farm)
    failed = [c for c in data["checks"] if not c["ok"]]
    for c in data["checks"]:
        print(f"{'ok  ' if c['ok'] else 'FAIL'} {c['check']}"
              + (f"\n     {c['detail']}" if not c["ok"] else ""))
    print(f"test-gui: {len(data['checks']) - len(failed)} of {len(data['checks'])} checks "
          f"passed; screenshots in {out.relative_to(ROOT) if out.is_relative_to(ROOT) else out}")
    if args.docs is not None:
        for shot in data["screenshots"]:
            name = shot.split("_", 1)[1].removesuffix(".png")
            if name in DOCS:
                shutil.copy(out / shot, args.docs / DOCS[name])
    return 1 if failed or not data["checks"] else 0


if __name__ == "__main__":
    raise SystemExit(main())
