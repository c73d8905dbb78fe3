"""The ``bo2`` command: BO2 Lighting headless, in a Python environment with the ``bpy`` module.

    bo2 render SCENE.blend -o OUT.png [--frame N] [--engine bo2|cycles] [--samples N]
                                      [--resolution WxH] [--specular-model MODEL]
                                      [--all-passes]
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

from .core import brdf

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
                 "use_pass_glossy_direct", "use_pass_emit"):
        setattr(view_layer, flag, True)
    if engine == "bo2":
        for flag in ("use_pass_albedo", "use_pass_specular_color", "use_pass_gloss"):
            setattr(view_layer.bo2, flag, True)


def cmd_render(args) -> int:
    out = Path(args.output)
    fmt = _IMAGE_FORMATS.get(out.suffix.lower())
    if fmt is None:
        raise CommandError(f"{out}: unknown image type, use one of {', '.join(_IMAGE_FORMATS)}")
    if not out.parent.exists():
        out.parent.mkdir(parents=True, exist_ok=True)
    if not os.access(out.parent, os.W_OK):
        raise CommandError(f"{out.parent}: output folder is not writable")
    bpy = load_blend(Path(args.scene))
    scene = bpy.context.scene
    if scene.camera is None:
        raise CommandError(f"{args.scene}: the scene has no active camera")
    scene.render.engine = ENGINES[args.engine]
    if args.frame is not None:
        scene.frame_set(args.frame)
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
    set_output_format(scene.render.image_settings, fmt)
    if args.all_passes:
        enable_all_passes(bpy.context.view_layer, args.engine)
    with quiet_blender():
        start = time.perf_counter()
        bpy.ops.render.render(write_still=False)
        seconds = time.perf_counter() - start
        bpy.data.images["Render Result"].save_render(filepath=str(out.resolve()), scene=scene)
    if not out.exists():
        raise CommandError(f"{out}: the render did not produce an image")
    print(f"{args.engine}: {out} (rendered in {seconds:.2f} s)")
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
    render = sub.add_parser("render", help="render one frame of a .blend file to an image",
                            description="Render one frame with BO2 Lighting or Cycles.")
    render.add_argument("scene", help=".blend file")
    render.add_argument("-o", "--output", required=True,
                        help="image to write: .png through the scene's view transform, "
                        ".exr scene-linear with every enabled pass as a layer")
    render.add_argument("--frame", type=int, help="frame number (default: the file's current)")
    render.add_argument("--engine", choices=sorted(ENGINES), default="bo2")
    render.add_argument("--samples", type=_positive, help="samples per pixel")
    render.add_argument("--resolution", type=_resolution, help="output size WxH in pixels")
    render.add_argument("--all-passes", action="store_true",
                        help="write every render pass to the EXR (default: the view layer's)")
    render.add_argument("--specular-model", choices=brdf.MODELS,
                        help="direct specular terms of the BO2 engine (default: the file's)")
    render.set_defaults(func=cmd_render)
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
