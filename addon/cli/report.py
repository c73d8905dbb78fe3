"""``bo2 report``: many scenes compared with Cycles on one static review page
(``blender/report.py``, docs/report.md), with a progress bar; Ctrl-C keeps the scenes done."""

from __future__ import annotations

import os
import sys
from pathlib import Path

from ..blender import headless, interrupt
from . import CommandError, on_cluster
from .compare import comparison_options, load_scene
from .terminal import BatchProgress, exit_on_interrupt, quiet_blender


def sources(paths: list[str]) -> list[tuple[str, Path]]:
    """("blend", file) and ("folder", comparison folder) of the command's arguments, in order:
    a .blend file, a ``bo2 compare`` folder, or a folder of either (one level down)."""
    from ..blender import report

    out = []
    for text in paths:
        path = Path(text)
        if path.is_file() and path.suffix.lower() == ".blend":
            out.append(("blend", path))
        elif path.is_dir():
            found = [("folder", p) for p in report.comparison_folders(path)]
            if not (path / "metrics.json").exists():
                found += [("blend", p) for p in sorted(path.glob("*.blend"))]
            if not found:
                raise CommandError(f"{path}: holds no .blend file and no comparison "
                                   "(a bo2 compare folder has metrics.json)")
            out += found
        elif path.exists():
            raise CommandError(f"{path}: not a .blend file or a folder")
        else:
            raise CommandError(f"{path}: no such file or folder")
    return out


def distinct_names(paths: list[Path]) -> list[str]:
    """The scenes' names on the page: each path's last part, with as many of its folders
    before it as tell two paths of the same name apart ("a/shot", "b/shot")."""
    parts = [Path(os.path.abspath(p)).parts for p in paths]
    depth = [1] * len(paths)
    while True:
        names = ["/".join(p[-d:]) for p, d in zip(parts, depth, strict=True)]
        clash = {n for n in names if names.count(n) > 1}
        grow = [k for k, n in enumerate(names) if n in clash and depth[k] < len(parts[k])]
        if not grow:
            return names
        for k in grow:
            depth[k] += 1


@on_cluster
def run(args, cluster) -> int:
    """Compare each scene with Cycles and write the review page (docs/report.md); on the
    Dask cluster of ``--scheduler``, a task per scene."""
    from ..core.review import flip

    if args.fail_above is not None and flip.unavailable():
        raise CommandError(f"--fail-above needs FLIP: {flip.unavailable()}")
    todo = sources(args.scenes)
    from ..blender import compare, report

    with quiet_blender():
        try:
            page = report.Report(Path(args.output), args.title, args.fail_above)
        except compare.CompareError as exc:
            raise CommandError(str(exc)) from None
    renders = 3 if args.old_methods else 2
    steps = [renders + 1 if kind == "blend" else 1 for kind, _ in todo]
    progress = BatchProgress(sum(steps))
    state = {"stage": "start", "written": 0, "base": 0, "end": 0, "calls": 0}

    def interrupted() -> str:
        progress.clear()
        done = state["written"]
        return (f"interrupted during {state['stage']}; {page.folder / 'index.html'} holds the "
                f"{done} scene{'s' if done != 1 else ''} done" if done else
                f"interrupted during {state['stage']}; no scene done")

    def stage(text: str) -> None:
        """A scene's next stage: its renders, then its pictures, each a step of the bar."""
        state["stage"] = text
        if state["calls"]:
            progress.done = min(state["base"] + state["calls"], state["end"] - 1)
        state["calls"] += 1
        progress.draw(text)

    # the .blend files load inside the Ctrl-C handler below: take SIGINT from bpy first, so that
    # loading them does not take it back (``interrupt.install`` runs once)
    interrupt.install(os.dup(2))
    failures = 0
    names = distinct_names([p.with_suffix("") if kind == "blend" else p for kind, p in todo])
    with exit_on_interrupt(interrupted):
        sent = {}  # on a cluster: scene index -> its task, or the error of its sending
        for i, (kind, path) in enumerate(todo):
            if cluster is not None and kind == "blend":
                state["stage"] = f"{names[i]}: sending"
                progress.draw(state["stage"])
                sent[i] = send_blend(cluster, path, args)
        for i, (kind, path) in enumerate(todo):
            pending = names[i + 1:]
            state.update(base=sum(steps[:i]), end=sum(steps[:i + 1]), calls=0)
            state["stage"] = f"{names[i]}: {'loading' if kind == 'blend' else 'reading'}"
            progress.draw(state["stage"])
            try:
                if kind == "blend" and cluster is not None:
                    stage(f"{names[i]}: on the cluster")
                    folder = receive(cluster, sent[i], page.scene_folder(names[i]))
                elif kind == "blend":
                    folder = render_blend(path, names[i], args, page, stage)
                else:
                    folder = path
                stage(f"{names[i]}: pictures")
                with quiet_blender():
                    page.add(folder, names[i], pending)
                state["written"] += 1
            except (CommandError, compare.CompareError) as exc:
                failures += 1
                page.fail(names[i], str(exc))
                progress.message(f"bo2: error: {names[i]}: {exc}", sys.stderr)
            progress.done = sum(steps[:i + 1])
            progress.draw()
        progress.close()
    if not page.entries:
        raise CommandError("no scene could be compared")
    index = page.write()
    print(index)
    bad = page.failing()
    for entry in bad:
        print(f"bo2: {entry['name']}: mean FLIP "
              f"{entry['variants']['bo2']['metrics']['Combined']['flip_ldr']:.4f} above "
              f"{args.fail_above}", file=sys.stderr)
    return 1 if bad or failures else 0


def render_blend(path: Path, name: str, args, page, stage) -> Path:
    """Open ``path`` and render its scene (the file's active scene, as ``bo2 compare``) into a
    new folder of the report for the scene ``name``; returns that folder."""
    from ..blender import report

    scene = load_scene(path, args)
    folder = page.scene_folder(name)
    with quiet_blender():
        report.render_scene(scene, headless.view_layer(), folder, args.old_methods,
                            on_stage=lambda text: stage(f"{name}: {text}"))
    return folder


def send_blend(cluster, path: Path, args):
    """``path``'s comparison sent to the cluster (``cluster.tasks.review``): its task, or the
    CommandError of its loading."""
    from ..cluster import tasks

    try:
        load_scene(path, args)  # (the checks of a scene compared here)
        with quiet_blender():
            cluster.ship()
    except CommandError as exc:
        return exc
    return cluster.submit(tasks.review, comparison_options(args), args.old_methods)


def receive(cluster, task, folder: Path) -> Path:
    """The files of a comparison done on the cluster (``send_blend``) written into
    ``folder``; returns it."""
    from ..cluster.session import ClusterError
    from ..core.system import atomic

    if isinstance(task, Exception):
        raise task
    try:
        files = cluster.result(task)
    except ClusterError as exc:
        raise CommandError(str(exc)) from None
    with interrupt.writing():
        for name, data in files.items():
            (folder / name).parent.mkdir(parents=True, exist_ok=True)
            atomic.write_bytes(folder / name, data)
    return folder
