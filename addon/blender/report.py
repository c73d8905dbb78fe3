"""The look-dev review in Blender (docs/report.md): scenes rendered by both engines with
``compare.run``, each into its own folder of the report, or ``bo2 compare`` folders read back;
then their passes through each scene's colour management and ``core.review.report`` for the page.

A report folder holds ``index.html``, ``report.json`` and ``scenes/<name>/``: the comparison's
files (``bo2.exr``, ``cycles.exr``, ``metrics.json``, ...), ``old/bo2.exr`` where the scene was
also rendered with the talk's old methods, and the page's pictures.
"""

from __future__ import annotations

import json
import shutil
import time
from pathlib import Path

import bpy

from ..core.review import compare as core_compare
from ..core.review import flip
from ..core.review import report as core
from ..core.system import atomic
from . import compare, images, passes
from . import settings as settings_of

# The talk's old (Black Ops) methods, each a scene setting of BO2 Lighting: the environment BRDF
# (slide 'Black Ops: environment map "Fresnel"'), the normalization ('Black Ops: normalization
# algorithm') and the prefilter ('Black Ops: environment map pre-filtering').
OLD_METHODS = {"env_brdf": "bo1", "normalization": "bo1", "prefilter": "bo1"}
COLOR_MANAGEMENT = ("view_transform", "look", "exposure", "gamma")


class Report:
    """One report being written: ``add`` each scene's comparison folder as it is done, and the
    page is rewritten after each (a stopped report keeps the scenes done)."""

    def __init__(self, folder: Path, title: str, fail_above: float | None = None):
        folder = Path(folder)
        if (folder / "index.html").exists() and not (folder / "report.json").exists():
            raise compare.CompareError(f"{folder} holds an index.html that is not a review "
                                       "page (no report.json beside it); choose another folder")
        self.folder = compare.prepare_folder(folder)
        self.scenes_folder = compare.prepare_folder(self.folder / "scenes")
        self.meta = {"title": title, "created": time.strftime("%Y-%m-%d %H:%M"),
                     "blender_version": bpy.app.version_string, "fail_above": fail_above,
                     "flip": flip.unavailable(), "pending": [], "failed": []}
        self.entries: list[dict] = []
        self.taken: set[str] = set()

    def scene_folder(self, name: str) -> Path:
        """A new, empty folder for the scene ``name`` inside the report (what an earlier
        review left there is removed: its old-methods render must not pass for this one's)."""
        folder = self.scenes_folder / core.slug(name, self.taken)
        if folder.is_dir():
            shutil.rmtree(folder)
        return compare.prepare_folder(folder)

    def add(self, source: Path, name: str, pending=()) -> dict:
        """Read the comparison in ``source`` (a ``bo2 compare`` folder, with ``old/`` when the
        old methods were rendered), write its pictures and the page; returns its entry."""
        source = Path(source)
        if source.parent == self.scenes_folder:  # rendered by this review, or by an earlier one
            folder = source
            self.taken.add(source.name.lower())
        else:
            folder = self.scene_folder(name)
        try:
            entry = core.analyse_scene(name, *read_comparison(source), folder, self.folder,
                                       links(source, self.folder))
            self.write(pending, [*self.entries, entry])
        except (OSError, ValueError, images.ImageError) as exc:
            raise compare.CompareError(f"cannot write its pictures or the page ({exc})") from None
        self.entries.append(entry)
        return entry

    def fail(self, name: str, message: str) -> None:
        """Note a scene that could not be compared; the page lists it."""
        self.meta["failed"].append({"name": name, "error": message})

    def write(self, pending=(), entries=None) -> Path:
        """(Re)write the page with the scenes so far; ``pending``: names still to come."""
        return core.write_page(self.folder, list(self.entries if entries is None else entries),
                               {**self.meta, "pending": list(pending)})

    def failing(self) -> list[dict]:
        return core.failing(core.ranked(self.entries), self.meta["fail_above"])


def links(source: Path, page: Path) -> dict:
    """The EXRs of a comparison folder, linked from the page's folder."""
    return {key: core.href(path, page) for key, path in (
        ("bo2", source / "bo2.exr"), ("bo2_old", source / "old" / "bo2.exr"),
        ("cycles", source / "cycles.exr")) if path.exists()}


def read_comparison(source: Path) -> tuple[dict, dict]:
    """``core.review.report.analyse_scene``'s passes and info from a comparison folder.

    returns: ({variant: {pass label: (linear (H, W, 3), display (H, W, 3))}}, info)
    """
    path = source / "metrics.json"
    try:
        metrics = json.loads(path.read_text())
        layer = metrics["view_layer"]
        engines = metrics["engines"]
    except (OSError, ValueError, KeyError, TypeError) as exc:
        raise compare.CompareError(f"{path}: not a comparison's metrics.json ({exc})") from None
    exrs = {"bo2": source / "bo2.exr", "cycles": source / "cycles.exr"}
    old = source / "old" / "bo2.exr"
    if old.exists():
        exrs["bo2_old"] = old
    read = {}
    for key, exr in exrs.items():
        try:
            read[key] = compare.read_exr(exr, layer)
        except Exception as exc:  # noqa: BLE001 - OpenEXR raises several kinds
            raise compare.CompareError(f"{exr}: cannot be read ({exc})") from None
        if "Combined" not in read[key]:
            raise compare.CompareError(f"{exr}: no Combined pass of view layer {layer!r}")
    shapes = {k: v["Combined"].shape[:2] for k, v in read.items()}
    if len(set(shapes.values())) > 1:
        raise compare.CompareError(f"{source}: the renders differ in size {shapes}")
    cycles = read.pop("cycles")
    pairs = {k: core_compare.light_pairs(v, cycles) for k, v in read.items()}
    names = [n for n in pairs["bo2"] if all(n in p for p in pairs.values())]
    linear = {"cycles": [pairs["bo2"][n][1] for n in names]}
    linear.update({k: [p[n][0] for n in names] for k, p in pairs.items()})
    cm = metrics.get("color_management", {})
    labels = ["Combined" if n == "Combined" else passes.readable_name(n) for n in names]
    out = {}
    for k, images_k in linear.items():  # one variant at a time: a 4K frame's passes are large
        display = to_display(cm, images_k)
        out[k] = {label: (lin[..., :3], disp)
                  for label, lin, disp in zip(labels, images_k, display, strict=True)}
    seconds = {k: engines[k]["render_seconds"] for k in ("bo2", "cycles") if k in engines}
    samples = {k: engines[k].get("samples") for k in ("bo2", "cycles") if k in engines}
    old_info = source / "old" / "render.json"
    if "bo2_old" in out and old_info.exists():
        try:
            info = json.loads(old_info.read_text())
            seconds["bo2_old"], samples["bo2_old"] = info["render_seconds"], info.get("samples")
        except (OSError, ValueError, KeyError, TypeError) as exc:
            raise compare.CompareError(f"{old_info}: damaged ({exc})") from None
    info = {"source": {"blend_file": metrics.get("blend_file"), "scene": metrics.get("scene"),
                       "frame": metrics.get("frame")},
            "resolution": metrics.get("resolution"), "color_management": cm,
            "seconds": seconds, "samples": samples}
    return out, info


def to_display(cm: dict, linear: list) -> list:
    """Scene-linear images through the colour management ``cm`` (metrics.json's
    "color_management"), as Blender saves a render (``images.to_display``)."""
    scene = bpy.data.scenes.new("BO2 Report colour")
    try:
        settings = [(scene.display_settings, "display_device")]  # first: it limits the views
        settings += [(scene.view_settings, attr) for attr in COLOR_MANAGEMENT]
        for owner, attr in settings:
            if attr in cm:
                try:
                    setattr(owner, attr, cm[attr])
                except (TypeError, ValueError):
                    pass  # a display, view or look this Blender lacks: its default
        return images.to_display(scene, linear)
    finally:
        bpy.data.scenes.remove(scene)


def render_scene(scene, view_layer, folder: Path, old_methods: bool, on_stage=None) -> None:
    """Render ``scene`` into ``folder`` as ``compare.run`` does, and first, when
    ``old_methods``, BO2 Lighting with the talk's old methods into ``folder/old/``."""
    if old_methods:
        job = compare.Comparison(scene, view_layer, folder / "old")
        try:
            if on_stage:
                on_stage("BO2 Lighting render, old methods")
            with settings_of.methods(scene, **OLD_METHODS):
                job.finish("bo2", compare.render_sync(job, "bo2"))
        finally:
            job.restore()
        atomic.write_text(folder / "old" / "render.json", json.dumps(job.info["bo2"], indent=1))
    compare.run(scene, view_layer, folder, on_stage=on_stage)


def scenes_with_camera() -> list:
    """The open file's scenes that have a camera, in name order."""
    return sorted((s for s in bpy.data.scenes if s.camera is not None), key=lambda s: s.name)


def comparison_folders(folder: Path) -> list[Path]:
    """``folder`` itself when it holds a comparison, else its subfolders that do (name order)."""
    folder = Path(folder)
    if (folder / "metrics.json").exists():
        return [folder]
    if not folder.is_dir():
        return []
    return sorted(p for p in folder.iterdir() if (p / "metrics.json").exists())


def plan(context) -> tuple[Report, list[tuple[str, object]]]:
    """The review of the scene's Review settings (``scene.bo2.lookdev``), as steps to run one
    at a time: [(scene name, step())], each step rendering or reading one scene and rewriting
    the page. CompareError when there is nothing to review or nowhere to write."""
    settings = context.scene.bo2.lookdev
    folder = compare.output_folder(context.scene, "report_folder")
    if settings.report_source == "SCENES":
        todo = [(s.name, s) for s in scenes_with_camera()]
        if not todo:
            raise compare.CompareError("no scene of this file has a camera")
    else:
        source = compare.output_folder(context.scene, "report_source_folder")
        todo = [(p.name, p) for p in comparison_folders(source)]
        if not todo:
            raise compare.CompareError(f"{source}: holds no Compare with Cycles folder "
                                       "(one with metrics.json)")
    stem = Path(bpy.data.filepath).stem or "Untitled"
    page = Report(folder, f"{stem}: look-dev review")
    names = [name for name, _ in todo]
    old = settings.report_old_methods

    def step(i: int):
        name, item = todo[i]
        pending = names[i + 1:]
        if isinstance(item, Path):
            return page.add(item, name, pending)
        layer = context.view_layer if item == context.scene else item.view_layers[0]
        target = page.scene_folder(name)
        render_scene(item, layer, target, old)
        return page.add(target, name, pending)

    return page, [(name, (lambda i=i: step(i))) for i, name in enumerate(names)]
