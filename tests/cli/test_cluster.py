"""``--scheduler``: bakes, frames and reviews on a Dask cluster of two local worker processes
(``LocalCluster``, the workers started as ``bo2 worker`` starts them), compared with the same
commands run alone; the cluster's faults.

The scene: a floor textured from an image file beside the .blend (relative path: the workers
read it only from the shipped copy, where it is packed), a box, a sun and a point light, a
Volume probe of 5 x 4 x 2 samples and a Sphere probe; 2 bounces.
"""

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
from test_cli import BO2, bo2, one_error_line
from test_interrupt import interrupted, progress, watched

distributed = pytest.importorskip("distributed")

SCENE = r'''
import math, sys
import bpy
import numpy as np
bpy.ops.wm.read_factory_settings(use_empty=True)
import bo2_lighting
bo2_lighting.register()
scene = bpy.context.scene
scene.render.engine = "BO2_LIGHTING"
scene.render.resolution_x, scene.render.resolution_y = 96, 64
scene.bo2.samples = 2
scene.bo2.probes.bounces = 2
scene.bo2.bake_pack = False
pixels = np.indices((32, 32)).sum(0) % 2 * 0.8 + 0.1
image = bpy.data.images.new("checker", 32, 32)
image.pixels = np.repeat(pixels.reshape(-1, 1), 4, 1).astype(np.float32).ravel()
import os
os.makedirs(os.path.join(os.path.dirname(sys.argv[1]), "tex"), exist_ok=True)
image.filepath_raw = os.path.join(os.path.dirname(sys.argv[1]), "tex", "checker.png")
image.file_format = "PNG"
image.save()
def material(name, color, texture=False):
    m = bpy.data.materials.new(name)
    if m.node_tree is None:
        m.use_nodes = True
    p = m.node_tree.nodes["Principled BSDF"]
    p.inputs["Base Color"].default_value = (*color, 1)
    if texture:
        t = m.node_tree.nodes.new("ShaderNodeTexImage")
        t.image = image
        m.node_tree.links.new(t.outputs["Color"], p.inputs["Base Color"])
    return m
bpy.ops.mesh.primitive_plane_add(size=8)
bpy.context.object.data.materials.append(material("Floor", (0.8, 0.8, 0.8), texture=True))
bpy.ops.mesh.primitive_cube_add(size=1.2, location=(0.8, 0.4, 0.6))
box = bpy.context.object
box.data.materials.append(material("Box", (0.8, 0.2, 0.1)))
for frame, z in ((1, 0.0), (3, 1.0)):
    box.rotation_euler.z = z
    box.keyframe_insert("rotation_euler", index=2, frame=frame)
for kind, loc, energy in (("SUN", (0, 0, 5), 3.0), ("POINT", (-1.5, -1.0, 2.0), 300.0)):
    data = bpy.data.lights.new(kind, kind)
    data.energy = energy
    obj = bpy.data.objects.new(kind, data)
    obj.location = loc
    obj.rotation_euler = (math.radians(40), 0, math.radians(30))
    scene.collection.objects.link(obj)
bpy.ops.object.lightprobe_add(type="VOLUME", location=(0, 0, 1.2))
volume = bpy.context.object
volume.scale = (3.0, 2.5, 1.0)
volume.data.resolution_x, volume.data.resolution_y, volume.data.resolution_z = 5, 4, 2
bpy.ops.object.lightprobe_add(type="SPHERE", location=(-1.0, 0.5, 1.0))
cam = bpy.data.objects.new("Camera", bpy.data.cameras.new("Camera"))
cam.location, cam.rotation_euler = (0, -7, 4), (math.radians(62), 0, 0)
scene.collection.objects.link(cam)
scene.camera = cam
bpy.ops.wm.save_as_mainfile(filepath=sys.argv[1], relative_remap=True)
'''


def build(folder: Path) -> Path:
    folder.mkdir(parents=True, exist_ok=True)
    path = folder / "level.blend"
    subprocess.run([sys.executable, "-c", SCENE, str(path)], check=True, capture_output=True)
    assert (folder / "tex" / "checker.png").is_file()
    return path


@pytest.fixture(scope="module")
def cluster():
    """A scheduler and two worker processes of one thread each, Blender preloaded."""
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                                  dashboard_address=":0",
                                  preload=["bo2_lighting.addon.cluster.tasks"]) as local, \
            distributed.Client(local) as client:
        yield local, client


def baked(blend: Path) -> dict:
    """{probe name: (SH, chains)} of the bake folder beside ``blend``."""
    from bo2_lighting.addon.core.files import probe_file

    files = sorted(p for p in (blend.parent / "bo2_bake").rglob("*.exr")
                   if p.parent.name != "lightmaps")
    assert files, "no bake files"
    read = [probe_file.read(p) for p in files]
    return {meta["probe"]: (sh, chains) for meta, sh, chains in read}


def same(a: dict, b: dict) -> bool:
    return a.keys() == b.keys() and all(
        np.array_equal(a[k][0], b[k][0]) and all(
            np.array_equal(x, y) for name in (a[k][1] or {})
            for x, y in zip(a[k][1][name], b[k][1][name], strict=True))
        for k in a)


@pytest.fixture(scope="module")
def alone(tmp_path_factory):
    """The scene baked on this machine alone."""
    blend = build(tmp_path_factory.mktemp("alone"))
    proc = bo2("bake", blend)
    assert proc.returncode == 0, proc.stderr
    return blend, baked(blend)


def test_a_bake_on_two_workers_is_the_bake_made_alone(cluster, alone, tmp_path):
    """Bit-identical: the same captures, whichever worker takes them, in whatever order."""
    local, client = cluster
    blend = build(tmp_path)
    proc = bo2("bake", blend, "--scheduler", local.scheduler_address)
    assert proc.returncode == 0, proc.stderr
    assert "baked 2 probes" in proc.stdout
    assert same(baked(blend), alone[1])
    # both workers took captures, each from its own copy of the file
    opened = client.run(opened_file)
    assert len(opened) == 2 and all(opened.values()), opened
    assert blend not in {Path(p) for p in opened.values()}


def opened_file():
    """The .blend a worker has open (``cluster.tasks``), or None."""
    from bo2_lighting.addon.cluster import tasks

    return str(tasks._open.get("path") or "") or None


def lightmaps(blend: Path) -> dict:
    """{object: its lightmap image} of the bake folder beside ``blend``."""
    from bo2_lighting.addon.core.files import lightmap_file

    files = sorted((blend.parent / "bo2_bake").rglob("lightmaps/*.exr"))
    assert files, "no lightmaps"
    read = [lightmap_file.read(p) for p in files]
    return {meta["object"]: lightmap.image for meta, lightmap in read}


def test_lightmaps_baked_on_two_workers_are_the_lightmaps_baked_alone(cluster, tmp_path):
    """The floor's lightmap (the box moves: not lightmapped), its gathers sent out in blocks
    of texels, each bounce's radiance sent to the workers: the same bits."""
    local, _ = cluster
    here, there = build(tmp_path / "here"), build(tmp_path / "there")
    assert bo2("bake", here, "--lightmaps").returncode == 0
    proc = bo2("bake", there, "--lightmaps", "--scheduler", local.scheduler_address)
    assert proc.returncode == 0, proc.stderr
    a, b = lightmaps(here), lightmaps(there)
    assert a.keys() == b.keys() == {"Plane"}
    assert all(np.array_equal(a[k], b[k]) for k in a)
    assert a["Plane"].max() > 0.0


def test_frames_on_the_cluster_are_the_frames_rendered_alone(cluster, tmp_path):
    """Frames 1-3 (the box turns): the same pixels, the floor's texture read from the
    shipped copy (its file is beside the client's .blend only)."""
    from PIL import Image

    local, _ = cluster
    blend = build(tmp_path / "scene")
    there = bo2("render", blend, "--frames", "1-3", "-o", tmp_path / "there_#.png",
                "--scheduler", local.scheduler_address)
    assert there.returncode == 0, there.stderr
    here = bo2("render", blend, "--frames", "1-3", "-o", tmp_path / "here_#.png")
    assert here.returncode == 0, here.stderr
    for k in (1, 2, 3):
        a = np.asarray(Image.open(tmp_path / f"there_{k}.png"))
        b = np.asarray(Image.open(tmp_path / f"here_{k}.png"))
        assert np.array_equal(a, b), k
    floor = np.asarray(Image.open(tmp_path / "here_1.png"))[50:, :, 0].astype(float)
    assert floor.std() > 10.0  # the checker texture, not a flat colour


def test_a_review_on_the_cluster_is_the_review_made_alone(cluster, tmp_path):
    import json

    local, _ = cluster
    blend = build(tmp_path / "scene")
    options = ("--resolution", "64x48", "--samples", "2", "--cycles-samples", "4")
    there = bo2("report", blend, "-o", tmp_path / "there", *options,
                "--scheduler", local.scheduler_address)
    assert there.returncode == 0, there.stderr
    here = bo2("report", blend, "-o", tmp_path / "here", *options)
    assert here.returncode == 0, here.stderr
    metrics = [json.loads(next((tmp_path / side).rglob("metrics.json")).read_text())
               for side in ("there", "here")]
    assert metrics[0]["passes"] == metrics[1]["passes"]
    assert (tmp_path / "there" / "index.html").is_file()


UI_BAKE = r"""
import sys, tempfile
import bpy
zip_path, blend, where, address = sys.argv[1:5]
repos = bpy.context.preferences.extensions.repos
repos.new(name="BO2 cluster test", module="bo2_cluster_test",
          custom_directory=tempfile.mkdtemp())
assert bpy.ops.extensions.package_install_files(
    filepath=zip_path, repo="bo2_cluster_test", enable_on_install=True) == {"FINISHED"}
bpy.ops.wm.open_mainfile(filepath=blend)
scene = bpy.context.scene
bpy.data.lights["POINT"].energy = 600.0  # not saved: the bake sees it
if where == "cluster":  # the preference's scheduler
    addon = bpy.context.preferences.addons["bl_ext.bo2_cluster_test.bo2_lighting"]
    addon.preferences.scheduler = address
    scene.bo2.bake_on = "CLUSTER"
elif where == "scene":  # the scene's own
    scene.bo2.bake_on, scene.bo2.scheduler = "CLUSTER", address
if where == "cancel":  # what Esc does to a modal bake: its steps closed at 20%
    import importlib
    ext = "bl_ext.bo2_cluster_test.bo2_lighting.addon.blender."
    operators, bake, probes = (importlib.import_module(ext + m)
                               for m in ("bake_operators", "bake", "probes"))
    steps = operators._on_cluster(address, True, lambda cluster: bake.bake_steps(
        scene, probes.probe_objects(scene), "BO2", cluster=cluster))
    at = next(f for f in steps if f > 0.2)
    steps.close()
    print("CANCELLED AT", at, flush=True)
    sys.exit(0)
for op in (bpy.ops.bo2.bake_probes, bpy.ops.bo2.bake_lightmaps):
    try:
        print("RESULT", op("EXEC_DEFAULT"), flush=True)
    except RuntimeError as exc:  # (a script's operator that reports an error)
        print("RESULT", exc, flush=True)
print("OPEN", bpy.data.is_dirty, bpy.data.images["checker"].packed_file is None,
      bpy.data.images["checker"].filepath, flush=True)
"""


def ui_bake(blend: Path, where: str, address: str = "") -> subprocess.CompletedProcess:
    """Blender with the extension installed from its zip (module ``bl_ext.*.bo2_lighting``)
    bakes ``blend``'s probes, then its lightmaps, with the operators of the Bake buttons, an
    unsaved change made: ``where`` "here", or "cluster" (the preferences' scheduler) or
    "scene" (the scene's) at ``address``."""
    zips = sorted((Path(__file__).resolve().parents[2] / "dist").glob("*-linux_x64.zip"))
    assert zips, "run 'make build' first"
    # a user folder of its own: the zip's wheels (Dask's too) installed there, not into the
    # user's, whose site-packages the Blender of every other test puts on its path
    env = {**os.environ, "BLENDER_USER_RESOURCES": str(blend.parent / "blender_user")}
    return subprocess.run([sys.executable, "-c", UI_BAKE, str(zips[0]), str(blend), where,
                           address], capture_output=True, text=True, timeout=600, env=env)


def test_the_uis_bakes_on_the_cluster_are_the_bakes_made_here(cluster, tmp_path):
    """The extension (its modules named ``bl_ext.<repository>.bo2_lighting``) bakes on workers
    of the pip package: the probes and the lightmaps are the same bits as its bakes here, the
    unsaved change seen by both; the open file is not packed by the shipping."""
    local, _ = cluster
    here, there = build(tmp_path / "here"), build(tmp_path / "there")
    alone = ui_bake(here, "here")
    assert alone.stdout.count("RESULT {'FINISHED'}") == 2, alone.stdout + alone.stderr
    proc = ui_bake(there, "cluster", local.scheduler_address)
    assert proc.stdout.count("RESULT {'FINISHED'}") == 2, proc.stdout + proc.stderr
    assert f"on {local.scheduler_address}" in proc.stdout
    assert "OPEN True True //tex/checker.png" in proc.stdout, proc.stdout
    assert same(baked(there), baked(here))
    a, b = lightmaps(here), lightmaps(there)
    assert a.keys() == b.keys() == {"Plane"}
    assert all(np.array_equal(a[k], b[k]) for k in a)


def test_esc_cancels_the_uis_bake_on_the_cluster(cluster, tmp_path):
    """A modal bake's steps closed (Esc) at 20%: the scheduler forgets the bake's tasks and
    nothing is written."""
    local, client = cluster
    blend = build(tmp_path)
    proc = ui_bake(blend, "cancel", local.scheduler_address)
    assert "CANCELLED AT 0." in proc.stdout, proc.stdout + proc.stderr
    deadline = time.monotonic() + 20
    while client.run_on_scheduler(tasks_known) and time.monotonic() < deadline:
        time.sleep(0.5)
    assert client.run_on_scheduler(tasks_known) == 0
    assert not list(tmp_path.rglob("*.exr"))


def tasks_known(dask_scheduler) -> int:
    return len(dask_scheduler.tasks)


def test_the_uis_bake_on_an_unreachable_or_unset_scheduler_is_one_error(tmp_path):
    blend = build(tmp_path)
    proc = ui_bake(blend, "scene", "tcp://127.0.0.1:9")
    said = proc.stdout + proc.stderr
    assert said.count("RESULT Error: Bake failed: cannot reach the Dask scheduler at "
                      "tcp://127.0.0.1:9 within 8 s") == 2, said
    assert "previous bakes kept" in said
    assert not (tmp_path / "bo2_bake").exists() or not any((tmp_path / "bo2_bake").rglob("*.exr"))
    proc = ui_bake(blend, "scene", "")
    assert (proc.stdout + proc.stderr).count("RESULT Error: Bake On is Dask Cluster but no "
                                             "scheduler is set") == 2


def test_a_worker_killed_during_a_bake_loses_nothing(cluster, alone, tmp_path):
    """A worker process killed while it captures: Dask runs its tasks again elsewhere (the
    nanny starts a new worker) and the bake is the same."""
    local, client = cluster
    blend = build(tmp_path)
    pids = list(client.run(os.getpid).values())
    killed = []

    def look(said, _):
        if progress(said) > 20.0 and not killed:
            os.kill(pids[0], signal.SIGKILL)
            killed.append(pids[0])

    proc = watched(("bake", blend, "--scheduler", local.scheduler_address), look)
    assert proc.returncode == 0, proc.stderr_text
    assert killed, "the bake ended before a worker could be killed"
    assert same(baked(blend), alone[1])
    client.wait_for_workers(2, timeout=60)


def test_ctrl_c_cancels_the_clusters_tasks_and_keeps_the_previous_bake(cluster, alone,
                                                                       tmp_path):
    local, client = cluster
    blend = build(tmp_path)
    assert bo2("bake", blend).returncode == 0
    before = {p: p.read_bytes() for p in (blend.parent / "bo2_bake").rglob("*.exr")}
    proc = interrupted(("bake", blend, "--scheduler", local.scheduler_address),
                       ready=lambda said: progress(said) > 10.0)
    assert proc.returncode == 130, proc.stderr_text
    assert {p: p.read_bytes() for p in (blend.parent / "bo2_bake").rglob("*.exr")} == before
    for _ in range(100):  # the scheduler forgets the cancelled tasks
        if not client.run_on_scheduler(lambda dask_scheduler: len(dask_scheduler.tasks)):
            break
        time.sleep(0.1)
    assert not client.run_on_scheduler(lambda dask_scheduler: len(dask_scheduler.tasks))


def test_an_unreachable_scheduler_is_one_error(alone):
    start = time.monotonic()
    proc = bo2("bake", alone[0], "--scheduler", "tcp://127.0.0.1:9")
    print(f"refused after {time.monotonic() - start:.1f} s")
    assert proc.returncode == 1
    assert "cannot reach the Dask scheduler at tcp://127.0.0.1:9" in one_error_line(proc)


def test_the_scheduler_lost_during_a_bake_is_one_error_and_the_previous_bake_stays(
        alone, tmp_path):
    blend = build(tmp_path)
    assert bo2("bake", blend).returncode == 0
    before = {p: p.read_bytes() for p in (blend.parent / "bo2_bake").rglob("*.exr")}
    dask = Path(sys.executable).parent / "dask"
    scheduler = subprocess.Popen([str(dask), "scheduler", "--host", "127.0.0.1", "--port",
                                  "0", "--no-dashboard", "--scheduler-file",
                                  str(tmp_path / "s.json")], stderr=subprocess.DEVNULL)
    worker = None
    try:
        for _ in range(100):
            if (tmp_path / "s.json").exists():
                break
            time.sleep(0.1)
        import json

        address = json.loads((tmp_path / "s.json").read_text())["address"]
        worker = subprocess.Popen([str(BO2), "worker", address], stdout=subprocess.DEVNULL,
                                  stderr=subprocess.DEVNULL)
        proc = watched(("bake", blend, "--scheduler", address),
                       lambda said, _: progress(said) > 10.0 and scheduler.kill())
    finally:
        scheduler.kill()
        if worker is not None:
            worker.kill()
    assert proc.returncode == 1, proc.stderr_text
    assert "lost the Dask scheduler" in proc.stderr_text, proc.stderr_text
    assert "previous bake files are as they were" in proc.stderr_text
    assert {p: p.read_bytes() for p in (blend.parent / "bo2_bake").rglob("*.exr")} == before


OTHER_VERSION = ('''
from bo2_lighting.addon.cluster import tasks

def dask_setup(worker):
    tasks.identity = lambda: {"BO2 Lighting": "0.0.9", "code": "0", "Blender": "4.2.0"}
''', "runs BO2 Lighting 0.0.9 (code 0) with Blender 4.2.0")
WITHOUT_BPY = ('''
from bo2_lighting.addon.cluster import tasks

def dask_setup(worker):
    found = tasks.identity
    tasks.identity = lambda: {**found(), "Blender": None}
''', "runs BO2 Lighting 0.1.0 without the bpy module")


@pytest.mark.parametrize(("preload", "said"), [OTHER_VERSION, WITHOUT_BPY],
                         ids=["another version", "without bpy"])
def test_a_worker_of_another_version_or_without_bpy_is_refused_naming_both(
        alone, tmp_path, preload, said):
    from bo2_lighting.addon.cluster.tasks import identity

    (tmp_path / "worker_setup.py").write_text(preload)
    with distributed.LocalCluster(n_workers=1, threads_per_worker=1, processes=True,
                                  dashboard_address=":0",
                                  preload=[str(tmp_path / "worker_setup.py")]) as local:
        proc = bo2("bake", alone[0], "--scheduler", local.scheduler_address)
    assert proc.returncode == 1
    line = one_error_line(proc)
    assert said in line and f"with Blender {identity()['Blender']}" in line, line


def test_a_worker_out_of_memory_fails_the_bake_with_its_limit(tmp_path):
    """A Sphere probe of 512 px faces on workers limited to 900 MiB: each worker running its
    capture is ended by Dask's nanny, four in turn (Dask's allowed failures, 3, and one);
    one error with the limit, and the previous bake stays."""
    blend = build(tmp_path)
    subprocess.run([sys.executable, "-c",
                    "import sys, bpy, bo2_lighting; bo2_lighting.register(); "
                    "bpy.ops.wm.open_mainfile(filepath=sys.argv[1]); "
                    "bpy.context.scene.bo2.probes.face_size = '512'; "
                    "bpy.ops.wm.save_mainfile()", str(blend)], check=True, capture_output=True)
    (blend.parent / "bo2_bake").mkdir()
    kept = blend.parent / "bo2_bake" / "kept.txt"
    kept.write_text("a previous bake")
    # (no pausing at 80%: a worker paused before its task starts would wait, and the
    # client's wait for paused workers is a minute)
    import dask

    with dask.config.set({"distributed.worker.memory.pause": False,
                          "distributed.worker.memory.spill": False,
                          "distributed.worker.memory.target": False}), \
            distributed.LocalCluster(n_workers=1, threads_per_worker=1, processes=True,
                                     dashboard_address=":0", memory_limit="900MiB",
                                     preload=["bo2_lighting.addon.cluster.tasks"]) as local:
        proc = bo2("bake", blend, "--scheduler", local.scheduler_address, timeout=240)
    assert proc.returncode == 1
    line = proc.stderr.strip().splitlines()[-1]  # (after the progress bar)
    assert line.startswith("bo2: error: a task ended 4 workers in turn"), proc.stderr
    assert "out of memory: their memory limit is 0.88 GiB" in line
    assert "previous bake files are as they were" in line
    assert not list((blend.parent / "bo2_bake").rglob("*.exr"))
    assert kept.read_text() == "a previous bake"


def test_workers_paused_for_long_fail_the_bake_with_their_limit(tmp_path, monkeypatch):
    """The worker paused by Dask during a bake (its pause fraction lowered under its memory:
    it takes no new task) for ``bo2.paused-seconds`` (5 s here): one error with its limit, the
    previous bake kept; a bake sent to it while it is paused: one error at once."""
    blend = build(tmp_path)
    (blend.parent / "bo2_bake").mkdir()
    kept = blend.parent / "bo2_bake" / "kept.txt"
    kept.write_text("a previous bake")
    monkeypatch.setenv("DASK_BO2__PAUSED_SECONDS", "5")
    import dask

    with dask.config.set({"distributed.worker.memory.terminate": False}), \
            distributed.LocalCluster(n_workers=1, threads_per_worker=1, processes=True,
                                     dashboard_address=":0", memory_limit="2GiB",
                                     preload=["bo2_lighting.addon.cluster.tasks"]) as local, \
            distributed.Client(local) as client:
        paused = []

        def look(said, _):
            if progress(said) > 10.0 and not paused:
                paused.append(client.run(pause))

        proc = watched(("bake", blend, "--scheduler", local.scheduler_address), look)
        again = bo2("bake", blend, "--scheduler", local.scheduler_address)
    assert paused, "the bake ended before the worker could be paused"
    assert proc.returncode == 1, proc.stderr_text
    line = proc.stderr_text.strip().splitlines()[-1]  # (after the progress bar)
    assert line.startswith("bo2: error: every worker has been paused by Dask for 5 s, out of "
                           "memory (their memory limit is 2.00 GiB)"), proc.stderr_text
    assert again.returncode == 1
    assert again.stderr.strip().splitlines()[-1].startswith(
        "bo2: error: every worker of tcp://127.0.0.1:"), again.stderr
    assert "is paused by Dask, out of memory (their memory limit is 2.00 GiB)" in again.stderr
    assert not list((blend.parent / "bo2_bake").rglob("*.exr"))
    assert kept.read_text() == "a previous bake"


def pause(dask_worker) -> None:
    """Pause the worker as Dask does past its pause fraction (its memory now over it)."""
    dask_worker.memory_manager.memory_pause_fraction = 0.01
