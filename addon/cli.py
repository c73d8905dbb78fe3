"""The ``bo2`` command: BO2 Lighting headless, in a Python environment with the ``bpy`` module.

    bo2 render SCENE.blend ... -o OUT.png [--frame N | --frames LIST] [--summary PATH.json]
                                          [--engine bo2|cycles] [--samples N]
                                          [--resolution WxH] [--specular-model MODEL]
                                          [--all-passes]
    bo2 env-brdf --gloss G --nov X [--rf0 R [G B]] [--model MODEL] [--json]
    bo2 sh IMAGE [--json]
    bo2 bake SCENE.blend [--probes NAME ...] [--backend bo2|cycles]
    bo2 compare SCENE.blend -o DIR [--frame N] [--samples N] [--cycles-samples N]
                                   [--resolution WxH]
    bo2 version

Errors print one line, ``bo2: error: ...``, and exit non-zero (2 for bad usage, 1 for a failed
command). ``bpy`` is imported only by the commands that need it, so ``bo2 --help`` is instant.
"""

from __future__ import annotations

import argparse
import contextlib
import os
import re
import sys
import tempfile
import time
from pathlib import Path

from .core import brdf, env_brdf

_BLEND_MAGIC = (b"BLENDER", b"\x1f\x8b", b"\x28\xb5\x2f\xfd")  # plain, gzip, zstd
_IMAGE_FORMATS = {".png": "PNG", ".exr": "OPEN_EXR", ".jpg": "JPEG", ".jpeg": "JPEG",
                  ".tif": "TIFF", ".tiff": "TIFF"}
ENGINES = {"bo2": "BO2_LIGHTING", "cycles": "CYCLES"}


class CommandError(Exception):
    """A failure to report as one line and exit code 1."""


class _Parser(argparse.ArgumentParser):
    def error(self, message):  # one clear line instead of usage + error
        self.exit(2, f"bo2: error: {message} (see 'bo2 --help')\n")


@contextlib.contextmanager
def quiet_blender():
    """Silence Blender's own C-level stdout/stderr; re-raise errors with its last line appended."""
    sys.stdout.flush()
    sys.stderr.flush()
    saved = os.dup(1), os.dup(2)
    with tempfile.TemporaryFile(mode="w+b") as log:
        os.dup2(log.fileno(), 1)
        os.dup2(log.fileno(), 2)
        try:
            yield
        except Exception as exc:
            sys.stdout.flush()
            os.dup2(saved[0], 1)
            os.dup2(saved[1], 2)
            log.seek(0)
            lines = [s.strip() for s in log.read().decode(errors="replace").splitlines()]
            detail = next((s for s in reversed(lines) if s), "")
            text = str(exc).strip()
            message = text.splitlines()[-1].removeprefix("Error: ") if text else type(exc).__name__
            if detail and detail not in message:
                message = f"{message} ({detail})"
            raise CommandError(message) from exc
        finally:
            sys.stdout.flush()
            os.dup2(saved[0], 1)
            os.dup2(saved[1], 2)
            os.close(saved[0])
            os.close(saved[1])


def check_blend(path: Path) -> None:
    """Fail clearly on a missing, unreadable or non-.blend file before Blender sees it."""
    if not path.is_file():
        raise CommandError(f"{path}: no such .blend file")
    try:
        with open(path, "rb") as fh:
            head = fh.read(8)
    except OSError as exc:
        raise CommandError(f"{path}: cannot read: {exc.strerror}") from exc
    if not any(head.startswith(m) for m in _BLEND_MAGIC):
        raise CommandError(f"{path}: not a Blender file (corrupt or wrong format)")


def load_blend(path: Path):
    """Import ``bpy``, register the add-on and open ``path``; returns the ``bpy`` module."""
    check_blend(path)
    with quiet_blender():
        import bpy

        from . import register

        register()
        bpy.ops.wm.open_mainfile(filepath=str(path.resolve()), load_ui=False)
    return bpy


def _resolution(text: str) -> tuple[int, int]:
    m = re.fullmatch(r"(\d+)[xX](\d+)", text)
    if not m or int(m[1]) < 1 or int(m[2]) < 1:
        raise argparse.ArgumentTypeError(f"invalid resolution {text!r}, expected WxH like 640x360")
    return int(m[1]), int(m[2])


def _positive(text: str) -> int:
    try:
        value = int(text)
    except ValueError:
        value = 0
    if value < 1:
        raise argparse.ArgumentTypeError(f"expected a positive integer, got {text!r}")
    return value


def set_output_format(settings, fmt: str) -> None:
    """Image settings for ``fmt``; EXR is written multilayer (every pass), 32-bit float."""
    if fmt != "OPEN_EXR":
        settings.file_format = fmt
    else:
        if hasattr(settings, "media_type"):  # Blender 5.0 chooses multilayer by media type
            settings.media_type = "MULTI_LAYER_IMAGE"
        settings.file_format = "OPEN_EXR_MULTILAYER"
    if fmt == "OPEN_EXR":
        settings.color_depth = "32"


def enable_all_passes(view_layer, engine: str) -> None:
    """Turn on every pass the chosen engine writes (BO2: the engine's; Cycles: the same names)."""
    for flag in ("use_pass_z", "use_pass_normal", "use_pass_position", "use_pass_uv",
                 "use_pass_material_index", "use_pass_diffuse_direct",
                 "use_pass_glossy_direct", "use_pass_diffuse_indirect",
                 "use_pass_glossy_indirect", "use_pass_emit"):
        setattr(view_layer, flag, True)
    if engine == "bo2":
        for flag in ("use_pass_albedo", "use_pass_specular_color", "use_pass_gloss"):
            setattr(view_layer.bo2, flag, True)


_MAX_FRAME = 1048574  # Blender's MAXFRAME
_FRAME_ITEM = re.compile(r"(-?\d+)(?:-(-?\d+)(?:x(\d+))?)?")


def _frame_list(text: str) -> list[int]:
    """``--frames``: ``N``, ``A-B`` or ``A-BxSTEP``, comma separated; in order, each frame once."""
    frames: dict[int, None] = {}
    for item in text.split(","):
        m = _FRAME_ITEM.fullmatch(item.strip())
        if not m:
            raise argparse.ArgumentTypeError(
                f"invalid frames {text!r}, expected e.g. 7, 1-10, 1,3,5-7 or 1-10x2")
        first, last = int(m[1]), int(m[2] if m[2] is not None else m[1])
        step = int(m[3] or 1)
        if last < first or step < 1 or max(abs(first), abs(last)) > _MAX_FRAME:
            raise argparse.ArgumentTypeError(
                f"invalid frame range {item.strip()!r}: A-BxSTEP needs A <= B, STEP >= 1 and "
                f"frames within +-{_MAX_FRAME}")
        frames.update(dict.fromkeys(range(first, last + 1, step)))
    return list(frames)


def _usage_error(message: str):
    _Parser(prog="bo2").error(message)  # one line, exit 2


def _output_path(pattern: str, scene: str, frame: int) -> Path:
    """``-o`` for one image: ``{scene}`` and ``{frame}`` (format spec allowed: ``{frame:04d}``)
    filled in, and the last run of ``#`` in the file name replaced by the frame padded to its
    length, as Blender does (``shot_####.png`` -> ``shot_0007.png``)."""
    import string

    pieces: list[list] = []  # [is literal text, text]
    for literal, field, spec, conversion in string.Formatter().parse(pattern):
        pieces.append([True, literal])
        if field is not None:
            value = {"scene": scene, "frame": frame}[field]
            if conversion:
                value = {"s": str, "r": repr, "a": ascii}[conversion](value)
            pieces.append([False, format(value, spec)])
    for piece in reversed(pieces):
        if not piece[0]:
            continue
        text = piece[1]
        cut = max(text.rfind("/"), text.rfind(os.sep))
        runs = list(re.finditer(r"#+", text[cut + 1:]))
        if runs:
            start, end = runs[-1].start() + cut + 1, runs[-1].end() + cut + 1
            piece[1] = f"{text[:start]}{frame:0{end - start}d}{text[end:]}"
            break
        if cut >= 0:
            break  # the file name has no '#'; directories keep theirs
    return Path("".join(text for _, text in pieces))


def _check_pattern(pattern: str) -> None:
    """Usage error for an ``-o`` pattern with other fields than {scene} and {frame}."""
    import string

    try:
        fields = [(f, s) for _, f, s, _ in string.Formatter().parse(pattern) if f is not None]
        for field, spec in fields:
            if field not in ("scene", "frame") or "{" in spec:
                raise ValueError(f"unknown field {{{field}}}, use {{scene}} and {{frame}} "
                                 "(write {{ and }} for a brace)")
        _output_path(pattern, "scene", 1)
    except (ValueError, TypeError) as exc:
        _usage_error(f"-o {pattern!r}: {exc}")


def _check_output(out: Path, create: bool = True) -> str:
    """The image format of ``out``; CommandError if it cannot be written. ``create`` makes its
    folder, otherwise the nearest existing folder above it must be writable."""
    fmt = _IMAGE_FORMATS.get(out.suffix.lower())
    if fmt is None:
        raise CommandError(f"{out}: unknown image type, use one of {', '.join(_IMAGE_FORMATS)}")
    folder = out.parent
    if create:
        folder.mkdir(parents=True, exist_ok=True)
    while not folder.exists() and folder != folder.parent:
        folder = folder.parent
    if not folder.is_dir() or not os.access(folder, os.W_OK):
        raise CommandError(f"{folder}: output folder is not writable")
    return fmt


def _apply_render_options(bpy, scene, args) -> None:
    """--engine, --resolution, --specular-model, --samples and --all-passes on a loaded file."""
    scene.render.engine = ENGINES[args.engine]
    if args.resolution:
        scene.render.resolution_x, scene.render.resolution_y = args.resolution
        scene.render.resolution_percentage = 100
    if args.specular_model:
        scene.bo2.specular_model = args.specular_model
    if args.samples:
        if args.engine == "cycles":
            scene.cycles.samples = args.samples
        else:
            scene.bo2.samples = args.samples
    if args.all_passes:
        enable_all_passes(bpy.context.view_layer, args.engine)


def _render_frame(bpy, scene, out: Path) -> float:
    """Render the scene's current frame to ``out``; returns the render time in seconds."""
    set_output_format(scene.render.image_settings, _check_output(out))
    with quiet_blender():
        start = time.perf_counter()
        bpy.ops.render.render(write_still=False)
        seconds = time.perf_counter() - start
        bpy.data.images["Render Result"].save_render(filepath=str(out.resolve()), scene=scene)
    if not out.exists():
        raise CommandError(f"{out}: the render did not produce an image")
    return seconds


class _BatchProgress:
    """The progress bar of a batch render: one self-overwriting line on a duplicate of stderr
    (it passes ``quiet_blender``), with messages printed above it."""

    def __init__(self, total: int):
        sys.stderr.flush()
        self.terminal = os.fdopen(os.dup(2), "w")
        self.total, self.done, self.label, self.width = total, 0, "", 0
        self.start = time.perf_counter()

    def draw(self, label: str | None = None) -> None:
        import io

        if label is not None:  # the whole line fits in 80 columns
            self.label = label if len(label) <= 28 else "..." + label[-25:]
        bar = io.StringIO()
        _progress_bar(bar, self.done / self.total, self.start, width=20)
        line = f"{bar.getvalue()}  {self.done}/{self.total}  {self.label}"
        self.terminal.write(line.ljust(self.width))  # spaces over a longer previous line
        self.terminal.flush()
        self.width = len(line)

    def message(self, text: str, stream) -> None:
        self.terminal.write("\r" + " " * self.width + "\r")
        self.terminal.flush()
        print(text, file=stream, flush=True)
        self.draw()

    def close(self) -> None:
        self.draw("")
        self.terminal.write("\n")
        self.terminal.close()


def _error_text(exc: Exception) -> str:
    text = str(exc) if isinstance(exc, CommandError) else f"{type(exc).__name__}: {exc}"
    return " ".join(text.split())


def _write_summary(path: Path, args, images: list[dict], seconds: float) -> None:
    import json

    ok = sum(image["status"] == "ok" for image in images)
    summary = {"engine": args.engine, "output": args.output, "total": len(images), "ok": ok,
               "failed": len(images) - ok, "seconds": round(seconds, 3), "images": images}
    temporary = path.with_name(path.name + ".part")
    temporary.write_text(json.dumps(summary, indent=2) + "\n")
    os.replace(temporary, path)  # a farm polling the file never reads half of it


def cmd_render(args) -> int:
    """Render frames of .blend files, one image each; the others go on when one fails."""
    _check_pattern(args.output)
    blends = [Path(name) for name in args.scenes]
    frames = args.frames or ([args.frame] if args.frame is not None else None)
    per_file = frames or [None]  # None: the file's current frame, known once it is loaded
    batch = len(blends) * len(per_file) > 1
    uses_frame = _output_path(args.output, "s", 1) != _output_path(args.output, "s", 2)
    # Every path is planned before anything renders (for current frames, the same frame in
    # every file is assumed); folders are checked now when the paths are known, made later.
    planned: dict[str, tuple[Path, str]] = {}
    for blend in blends:
        for frame in per_file:
            out = _output_path(args.output, blend.stem, 1 if frame is None else frame)
            key = os.path.normcase(os.path.abspath(out))
            image = f"{blend}" if frame is None else f"{blend} frame {frame}"
            if key in planned:
                same = "the same path" if frame is None and uses_frame else out
                _usage_error(f"-o {args.output!r} gives {same} for both {planned[key][1]} and "
                             f"{image}; use {{scene}}, {{frame}} or #### so that every image "
                             "has its own path")
            planned[key] = out, image
    for out, _ in planned.values():
        if frames or not uses_frame or _IMAGE_FORMATS.get(out.suffix.lower()) is None:
            _check_output(out, create=False)  # e.g. an unknown image type: before loading
    summary = Path(args.summary) if args.summary else None
    if summary is not None:
        summary.parent.mkdir(parents=True, exist_ok=True)
        if not os.access(summary.parent, os.W_OK):
            raise CommandError(f"{summary.parent}: summary folder is not writable")

    start = time.perf_counter()
    images: list[dict] = []
    written: set[str] = set()
    progress = _BatchProgress(len(planned)) if batch else None

    def record(blend, frame, out, seconds, error=None):
        images.append({"file": str(blend), "scene": blend.stem, "frame": frame,
                       "output": None if out is None else str(out),
                       "status": "ok" if error is None else "failed",
                       "seconds": round(seconds, 3), "error": error})

    def say(line, stream):
        if progress is None:
            print(line, file=stream)
        else:
            progress.message(line, stream)

    try:
        for blend in blends:
            if progress is not None:
                progress.draw(f"{blend.name} (loading)")
            try:
                bpy = load_blend(blend)  # once per file
                scene = bpy.context.scene
                _apply_render_options(bpy, scene, args)
            except Exception as exc:  # noqa: BLE001 - the other files still render
                for frame in per_file:
                    record(blend, frame, None, 0.0, _error_text(exc))
                if progress is not None:
                    progress.done += len(per_file)
                say(f"bo2: error: {_error_text(exc)}", sys.stderr)
                continue
            for frame in per_file:
                began, out = time.perf_counter(), None
                number = scene.frame_current if frame is None else frame
                where = f"{blend} frame {number}" if batch else f"{blend}"
                if progress is not None:
                    progress.draw(f"{blend.name} frame {number}")
                try:
                    if frame is not None:
                        with quiet_blender():
                            scene.frame_set(frame)
                    if scene.camera is None:  # checked per frame: markers can bind cameras
                        raise CommandError("the scene has no active camera")
                    out = _output_path(args.output, blend.stem, number)
                    key = os.path.normcase(os.path.abspath(out))
                    if key in written:
                        raise CommandError(f"{out}: already written by this command")
                    seconds = _render_frame(bpy, scene, out)
                    written.add(key)
                except Exception as exc:  # noqa: BLE001 - the other frames still render
                    error = f"{where}: {_error_text(exc)}"
                    line, stream = f"bo2: error: {error}", sys.stderr
                else:
                    error = None
                    line = f"{args.engine}: {out} (rendered in {seconds:.2f} s)"
                    stream = sys.stdout
                record(blend, number, out, time.perf_counter() - began, error)
                if progress is not None:
                    progress.done += 1
                say(line, stream)
    finally:
        if progress is not None:
            progress.close()
    failed = sum(image["status"] != "ok" for image in images)
    if summary is not None:
        _write_summary(summary, args, images, time.perf_counter() - start)
    if batch:
        print(f"rendered {len(images) - failed} of {len(images)} images in "
              f"{time.perf_counter() - start:.2f} s"
              + (f", summary: {summary}" if summary is not None else ""))
    return 1 if failed else 0


def cmd_env_brdf(args) -> int:
    """Print the environment BRDF of one (gloss, n.v, rf0): one value per rf0 channel."""
    import json

    import numpy as np

    if len(args.rf0) not in (1, 3):
        raise CommandError(f"--rf0 takes one value or three (R G B), got {len(args.rf0)}")
    values = env_brdf.environment_brdf(np.float64(args.gloss), np.float64(args.nov),
                                       np.array(args.rf0, np.float64), args.model)
    values = [float(x) for x in np.atleast_1d(values)]
    if args.json:
        def num(x):
            return None if x != x else x  # NaN is not JSON: null

        print(json.dumps({"model": args.model, "gloss": num(args.gloss), "nov": num(args.nov),
                          "rf0": [num(x) for x in args.rf0], "value": [num(x) for x in values]}))
    else:
        print(" ".join(f"{x:.6f}" for x in values))
    return 0


def read_equirect(path: Path):
    """Read an image as Blender does (``bpy.data.images.load``), for SH projection.

    Float images (HDR, EXR) are scene-linear already; 8-bit images in the sRGB colour space are
    decoded to linear (``Image.pixels`` holds their encoded values), other 8-bit images are
    taken as linear data. Blender's row 0 is the bottom row: flipped to row 0 at the top.

    path:    image file
    returns: (H, W, 3) float32 linear RGB, row 0 at the top (a greyscale image is repeated)
    """
    import numpy as np

    from .core import texture

    if path.is_dir():
        raise CommandError(f"{path}: is a directory, not an image")
    if not path.is_file():
        raise CommandError(f"{path}: no such image file")
    if not os.access(path, os.R_OK):
        raise CommandError(f"{path}: cannot read the file (permission denied)")
    with quiet_blender():
        import bpy

        image = bpy.data.images.load(str(path.resolve()), check_existing=False)
        width, height = image.size  # reading the size loads the pixels (or fails to)
        channels = image.channels
    try:
        if width == 0 or height == 0 or not image.has_data:
            raise CommandError(f"{path}: not an image Blender can read")
        pixels = np.empty(width * height * channels, np.float32)
        image.pixels.foreach_get(pixels)
        pixels = pixels.reshape(height, width, channels)[::-1]
        rgb = pixels[..., :3] if channels >= 3 else np.repeat(pixels[..., :1], 3, -1)
        if not image.is_float and image.colorspace_settings.name == "sRGB":
            rgb = texture.srgb_to_linear(rgb)
        return np.ascontiguousarray(rgb, np.float32)
    finally:
        bpy.data.images.remove(image)


def cmd_sh(args) -> int:
    """Print the 9 RGB SH coefficients of the radiance of a lat-long (equirectangular) image."""
    import json

    from .core import sh

    path = Path(args.image)
    coefficients = sh.project_equirect(read_equirect(path))
    if args.json:
        print(json.dumps({"image": str(args.image), "order": [list(lm) for lm in sh.ORDER],
                          "coefficients": [[float(x) for x in row] for row in coefficients]}))
    else:
        for (l, m), (r, g, b) in zip(sh.ORDER, coefficients, strict=True):
            print(f"{l} {m:2d}  {r:.7g} {g:.7g} {b:.7g}")
    return 0


def _progress_bar(out, fraction: float, start: float, width: int = 30) -> None:
    """One self-overwriting line on ``out``: [#####.....]  42.0%  12.3 s."""
    filled = int(round(fraction * width))
    out.write(f"\r[{'#' * filled}{'.' * (width - filled)}] {fraction * 100:5.1f}%  "
              f"{time.perf_counter() - start:6.1f} s")
    out.flush()


def cmd_bake(args) -> int:
    """Bake the light probes of a .blend file into its bake folder."""
    bpy = load_blend(Path(args.scene))
    from .blender import probes

    scene = bpy.context.scene
    objs = probes.probe_objects(scene)
    if args.probes:
        names = {o.name for o in objs}
        unknown = [n for n in args.probes if n not in names]
        if unknown:
            raise CommandError(f"no Sphere or Volume light probe named {', '.join(unknown)} "
                               f"(have: {', '.join(sorted(names)) or 'none'})")
        objs = [o for o in objs if o.name in args.probes]
    if not objs:
        raise CommandError(f"{args.scene}: the scene has no Sphere or Volume light probes")
    start = time.perf_counter()
    warnings: list[str] = []
    sys.stderr.flush()
    terminal = os.fdopen(os.dup(2), "w")  # the progress bar passes Blender's silencing
    try:
        folder = probes.bake_folder(scene)
        depsgraph = bpy.context.evaluated_depsgraph_get()
        with quiet_blender():
            steps = probes.bake_steps(scene, depsgraph, objs, args.backend.upper(),
                                      report=warnings.append)
            for fraction in steps:
                _progress_bar(terminal, fraction, start)
    except probes.BakeError as exc:
        raise CommandError(str(exc)) from None
    finally:
        terminal.write("\n")
        terminal.close()
    for message in warnings:
        print(f"bo2: warning: {message}", file=sys.stderr)
    print(f"baked {len(objs)} probe{'s' * (len(objs) != 1)} into {folder} "
          f"in {time.perf_counter() - start:.2f} s")
    return 0


@contextlib.contextmanager
def _exit_on_interrupt(describe):
    """Ctrl-C ends the process at once with one error line, even inside a render.

    A render started from Python in the ``bpy`` module does not return to Python before it
    finishes, and the KeyboardInterrupt raised in Blender's callbacks is swallowed. So a thread
    woken by the signal's wakeup file descriptor prints ``bo2: error: <describe()>`` on the
    terminal and exits with 130 (files already written stay).
    """
    import signal
    import socket
    import threading

    reader, writer = socket.socketpair()
    writer.setblocking(False)
    terminal = os.dup(2)
    done = threading.Event()

    def watch():
        while True:
            data = reader.recv(1)
            if done.is_set() or not data:
                return
            if data[0] == signal.SIGINT:
                os.write(terminal, f"bo2: error: {describe()}\n".encode())
                os._exit(130)

    previous = signal.signal(signal.SIGINT, lambda *_: None)
    previous_fd = signal.set_wakeup_fd(writer.fileno(), warn_on_full_buffer=False)
    thread = threading.Thread(target=watch, daemon=True)
    thread.start()
    try:
        yield
    finally:
        done.set()
        signal.set_wakeup_fd(previous_fd)
        signal.signal(signal.SIGINT, previous)
        writer.send(b"\0")
        thread.join()
        reader.close()
        writer.close()
        os.close(terminal)


def cmd_compare(args) -> int:
    """Render one frame with BO2 Lighting and with Cycles and compare them (docs/compare.md)."""
    folder = Path(args.output)
    try:
        folder.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise CommandError(f"{folder}: cannot create the output folder "
                           f"({exc.strerror or exc})") from None
    if not os.access(folder, os.W_OK | os.X_OK):
        raise CommandError(f"{folder}: output folder is not writable")
    bpy = load_blend(Path(args.scene))
    from .blender import compare

    scene = bpy.context.scene
    if scene.camera is None:
        raise CommandError(f"{args.scene}: the scene has no active camera")
    if args.frame is not None:
        scene.frame_set(args.frame)
    if args.resolution:
        scene.render.resolution_x, scene.render.resolution_y = args.resolution
        scene.render.resolution_percentage = 100
    if args.samples:
        scene.bo2.samples = args.samples
    if args.cycles_samples:
        scene.cycles.samples = args.cycles_samples
    stage = ["start"]

    def interrupted() -> str:
        kept = [str(folder / e[2]) for e in compare.ENGINES.values() if (folder / e[2]).exists()]
        return (f"interrupted during the {stage[0]}; "
                + (f"kept {', '.join(kept)}" if kept else "nothing written"))

    failure = result = None
    with _exit_on_interrupt(interrupted), quiet_blender():
        try:
            result = compare.run(scene, bpy.context.view_layer, folder,
                                 on_stage=lambda text: stage.__setitem__(0, text))
        except compare.CompareError as exc:
            failure = str(exc)
    if failure:
        raise CommandError(failure)
    print(compare.headline(result))
    for path in result["files"].values():
        print(f"  {path}")
    return 0


def cmd_version(args) -> int:
    import tomllib

    manifest = Path(__file__).resolve().parent.parent / "blender_manifest.toml"
    with open(manifest, "rb") as fh:
        print(f"BO2 Lighting {tomllib.load(fh)['version']}")
    return 0


def build_parser() -> argparse.ArgumentParser:
    parser = _Parser(prog="bo2", description="BO2 Lighting: Black Ops II lighting for Blender.")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", parser_class=_Parser)
    sub.required = True
    render = sub.add_parser(
        "render", help="render frames of .blend files to images",
        description="Render frames of one or more .blend files with BO2 Lighting or Cycles. "
        "Each file is loaded once and its frames rendered in order; a file or frame that fails "
        "prints one error line, the others still render, and the exit code is 1.")
    render.add_argument("scenes", nargs="+", metavar="SCENE", help=".blend file(s)")
    render.add_argument("-o", "--output", required=True, metavar="OUT",
                        help="image to write: .png through the scene's view transform, "
                        ".exr scene-linear with every enabled pass as a layer. A pattern: "
                        "{scene} is the .blend's name without .blend, {frame} the frame "
                        "({frame:04d} pads it), and the last run of # in the file name the "
                        "frame padded to its length; with several images every path must differ")
    which = render.add_mutually_exclusive_group()
    which.add_argument("--frame", type=int, help="frame number (default: the file's current)")
    which.add_argument("--frames", type=_frame_list, metavar="LIST",
                       help="frames to render: 1-10, 1,3,5-7 or 1-10x2 (every second)")
    render.add_argument("--summary", metavar="PATH.json",
                        help="write a JSON report: per image the file, scene, frame, output, "
                        "status (ok or failed), seconds and error; totals")
    render.add_argument("--engine", choices=sorted(ENGINES), default="bo2")
    render.add_argument("--samples", type=_positive, help="samples per pixel")
    render.add_argument("--resolution", type=_resolution, help="output size WxH in pixels")
    render.add_argument("--all-passes", action="store_true",
                        help="write every render pass to the EXR (default: the view layer's)")
    render.add_argument("--specular-model", choices=brdf.MODELS,
                        help="direct specular terms of the BO2 engine (default: the file's)")
    render.set_defaults(func=cmd_render)
    env = sub.add_parser(
        "env-brdf", help="print the environment BRDF of a gloss, n.v and rf0",
        description="The environment BRDF E(gloss, n.v, rf0) of Lazarov 2013 (docs/env_brdf.md): "
        "the fraction of a uniform environment's radiance reflected towards the eye. Gloss and "
        "n.v are clamped to [0, 1] and [1e-4, 1], rf0 to [0, 1]; NaN gives NaN.")
    env.add_argument("--gloss", type=float, required=True, help="gloss g in [0, 1]")
    env.add_argument("--nov", type=float, required=True, help="cosine of the view to the normal")
    env.add_argument("--rf0", type=float, nargs="+", default=[0.04], metavar="R",
                     help="specular colour: one value, or three (R G B); default 0.04")
    env.add_argument("--model", choices=env_brdf.MODELS, default="bo2",
                     help="truth (quadrature), table, bo1, bo2 (default) or fit")
    env.add_argument("--json", action="store_true", help="print a JSON object")
    env.set_defaults(func=cmd_env_brdf)
    sh_cmd = sub.add_parser(
        "sh", help="print the order-3 SH coefficients of an environment image",
        description="Project a lat-long (equirectangular) radiance image, read as Blender reads "
        "it and mapped as the Environment Texture node maps it (Blender world axes, Z up), on "
        "the 9 real SH of docs/sh.md. Prints one line per coefficient: l m  r g b.")
    sh_cmd.add_argument("image", help="equirectangular image (.hdr, .exr, .png, ...)")
    sh_cmd.add_argument("--json", action="store_true", help="print a JSON object")
    sh_cmd.set_defaults(func=cmd_sh)
    bake = sub.add_parser(
        "bake", help="bake the light probes of a .blend file",
        description="Bake the Sphere and Volume light probes of a .blend file (SH irradiance and "
        "prefiltered cube maps) into its bake folder (the scene's Bake Folder, '//bo2_bake/' "
        "by default), one OpenEXR file per probe. Nothing is written unless every probe "
        "finishes.")
    bake.add_argument("scene", help=".blend file")
    bake.add_argument("--probes", nargs="+", metavar="NAME",
                      help="only these light probe objects (default: all)")
    bake.add_argument("--backend", choices=("bo2", "cycles"), default="bo2",
                      help="captures rendered by BO2 Lighting (default) or Cycles")
    bake.set_defaults(func=cmd_bake)
    compare = sub.add_parser(
        "compare", help="render a frame with BO2 Lighting and Cycles and compare them",
        description="Render one frame of a .blend file with BO2 Lighting and with Cycles (same "
        "camera and resolution) and write into DIR: bo2.exr and cycles.exr (every pass), "
        "side_by_side.png, split.png and difference.png (through the scene's view transform) "
        "and metrics.json (RMSE, mean relative error, PSNR, SSIM, per pass too). Prints the "
        "headline metrics and the paths (docs/compare.md).")
    compare.add_argument("scene", help=".blend file")
    compare.add_argument("-o", "--output", required=True, metavar="DIR",
                         help="output folder (created if missing)")
    compare.add_argument("--frame", type=int, help="frame number (default: the file's current)")
    compare.add_argument("--samples", type=_positive,
                         help="BO2 Lighting samples per pixel (default: the file's)")
    compare.add_argument("--cycles-samples", type=_positive,
                         help="Cycles samples per pixel (default: the file's)")
    compare.add_argument("--resolution", type=_resolution, help="size WxH in pixels of both")
    compare.set_defaults(func=cmd_compare)
    version = sub.add_parser("version", help="print the add-on version")
    version.set_defaults(func=cmd_version)
    return parser


def main(argv: list[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    try:
        return args.func(args)
    except CommandError as exc:
        print(f"bo2: error: {exc}", file=sys.stderr)
        return 1
    except KeyboardInterrupt:
        print("bo2: interrupted", file=sys.stderr)
        return 130
    except Exception as exc:  # noqa: BLE001 - one line for the user, never a traceback
        print(f"bo2: error: {type(exc).__name__}: {exc}", file=sys.stderr)
        return 1


if __name__ == "__main__":
    raise SystemExit(main())
