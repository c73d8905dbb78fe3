"""The ``bo2`` command: BO2 Lighting headless, in a Python environment with the ``bpy`` module.

    bo2 render SCENE.blend ... -o OUT.png [--frame N | --frames LIST] [--summary PATH.json]
                                          [--engine bo2|cycles] [--samples N]
                                          [--resolution WxH] [--specular-model MODEL]
                                          [--all-passes]
    bo2 env-brdf --gloss G --nov X [--rf0 R [G B]] [--model MODEL] [--json]
    bo2 sh IMAGE [--json] [-o SH.json] [--header SH.h] [--axes blender|y-up]
    bo2 bake SCENE.blend [--probes NAME ...] [--backend bo2|cycles] [--pack | --no-pack]
    bo2 bake SCENE.blend --lightmaps [NAME ...] [--pack | --no-pack]
    bo2 prefilter IMAGE [IMAGE x 5] -o OUT.ktx2|.dds|.exr [--filter F] [--size S] [--mips N]
    bo2 export-probes SCENE.blend -o DIR [--format ktx2|dds|exr|json]
    bo2 compare SCENE.blend -o DIR [--frame N] [--samples N] [--cycles-samples N]
                                   [--resolution WxH]
    bo2 worker ADDRESS [--nworkers N] [--memory-limit LIMIT]
    bo2 version

``bo2 bake``, ``bo2 render`` and ``bo2 report`` take ``--scheduler ADDRESS``: their work on a
Dask cluster (``cluster``), their files written here.

This module holds the argument parser, ``main`` and the error handling: errors print one line,
``bo2: error: ...``, and exit non-zero (2 for bad usage or input, 1 for a failed command, 130 when
interrupted). Each command is a module (``render``, ``env_brdf``, ``sh``, ``bake``, ``compare``,
``prefilter``, ``export_probes``)
with ``run(args) -> exit code``; ``terminal`` holds the terminal handling, ``patterns`` the
``-o`` pattern language. Everything Blender is ``blender/headless.py`` and the other Blender
modules; ``bpy`` is imported only by the commands that need it, so ``bo2 --help`` is instant.
"""

from __future__ import annotations

import argparse
import functools
import math
import os
import re
import sys
from pathlib import Path

# NumPy's BLAS on one thread, set before NumPy loads: the commands' own threads share the
# cores (the demo room baked in 11.0 s, not 11.7-12.2 s), and sums that depend on the BLAS's
# thread count come out the same on any machine and on a Dask cluster's workers, which run
# one BLAS thread too
for _name in ("OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_name, "1")

from ..blender import headless  # noqa: E402 (no bpy: it imports Blender where it needs it)


class CommandError(Exception):
    """A failure to report as one line and exit code 1."""

    code = 1


class BadInput(CommandError):
    """Input that cannot be used (a damaged image, an unwritable output): one line, exit 2."""

    code = 2


class _Parser(argparse.ArgumentParser):
    def error(self, message):  # one clear line instead of usage + error
        self.exit(2, f"bo2: error: {message} (see 'bo2 --help')\n")


def usage_error(message: str):
    """Print ``bo2: error: <message>`` and exit with 2, as for bad arguments."""
    _Parser(prog="bo2").error(message)


def load_blend(path: Path, bakes: bool = False):
    """Open the .blend file ``path`` with the add-on registered, Blender silenced, and load the
    compiled kernels a frame needs (``bakes``: the lightmap bakes' too), saying so on stderr
    when they compile; returns its scene. CommandError for a missing, unreadable or corrupt
    file, or numba missing."""
    from ..blender import interrupt
    from ..core import kernels
    from .terminal import quiet_blender

    # Ctrl-C's last word reaches the user through Blender's silencing (one copy per process)
    terminal = 2 if interrupt.installed() else os.dup(2)
    with quiet_blender():
        scene = headless.load_blend(path, terminal)
    from ..blender import adoption

    for message in adoption.notices:  # bakes of earlier versions, adopted on load
        print(f"bo2: note: {message}", file=sys.stderr)
    try:
        kernels.load(lambda message: print(f"bo2: {message}", file=sys.stderr, flush=True),
                     kernels.MODULES if bakes else kernels.FRAME_MODULES)
    except kernels.KernelsUnavailable as exc:
        raise CommandError(str(exc)) from None
    return scene


def on_cluster(command):
    """``command(args, cluster)`` as a command ``run(args)``: ``cluster`` the Dask cluster of
    ``--scheduler ADDRESS`` (``cluster.session.Cluster``, closed after), or None without it;
    CommandError when it cannot be used."""
    @functools.wraps(command)
    def run(args) -> int:
        if not args.scheduler:
            return command(args, None)
        from ..cluster.session import Cluster, ClusterError

        try:
            cluster = Cluster(args.scheduler)
        except ClusterError as exc:
            raise CommandError(str(exc)) from None
        try:
            return command(args, cluster)
        except ClusterError as exc:  # (the shipping of the file)
            raise CommandError(str(exc)) from None
        finally:
            cluster.close()
    return run


MAX_RESOLUTION = headless.MAX_SIDE
MAX_SAMPLES = {"bo2": 1024, "cycles": 1 << 24}  # the engines' sample settings' maxima
MAX_FRAMES = 100_000  # frames one command renders


def _resolution(text: str) -> tuple[int, int]:
    m = re.fullmatch(r"(\d+)[xX](\d+)", text)
    if not m or int(m[1]) < 1 or int(m[2]) < 1:
        raise argparse.ArgumentTypeError(f"invalid resolution {text!r}, expected WxH like 640x360")
    if max(int(m[1]), int(m[2])) > MAX_RESOLUTION:
        raise argparse.ArgumentTypeError(f"resolution {text!r} is too large: at most "
                                         f"{MAX_RESOLUTION} pixels a side (Blender's limit)")
    if headless.render_size(int(m[1]), int(m[2])) is None:
        grow = -(-headless.MIN_SIDE // min(int(m[1]), int(m[2])))
        raise argparse.ArgumentTypeError(
            f"resolution {text!r}: a side under {headless.MIN_SIDE} pixels is rendered from "
            f"{grow} times the size, so the other side can be at most {MAX_RESOLUTION // grow}")
    return int(m[1]), int(m[2])


def _positive(text: str) -> int:
    try:
        value = int(text)
    except ValueError:
        value = 0
    if value < 1:
        raise argparse.ArgumentTypeError(f"expected a positive integer, got {text!r}")
    return value


def too_many_samples(value: int, engine: str) -> str | None:
    """Why ``value`` samples per pixel are refused for ``engine`` ("bo2" or "cycles"), or
    None when it takes them."""
    if value <= MAX_SAMPLES[engine]:
        return None
    name = "BO2 Lighting" if engine == "bo2" else "Cycles"
    return f"{value} samples is more than {name} takes ({MAX_SAMPLES[engine]})"


def _samples(engine: str):
    def parse(text: str) -> int:
        value = _positive(text)
        if reason := too_many_samples(value, engine):
            raise argparse.ArgumentTypeError(reason)
        return value
    return parse


def _fraction(text: str) -> float:
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"not a number: {text!r}") from None
    if not 0.0 <= value <= 1.0:
        raise argparse.ArgumentTypeError(f"must be between 0 and 1, got {text}")
    return value


def _finite(text: str) -> float:
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"not a number: {text!r}") from None
    if not math.isfinite(value):
        raise argparse.ArgumentTypeError(f"must be a finite number, got {text}")
    return value


def _scale(text: str) -> float:
    value = _finite(text)
    if not value > 0.0:
        raise argparse.ArgumentTypeError(f"must be above 0, got {text}")
    return value


def _frame(text: str) -> int:
    from .patterns import MAX_FRAME

    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"invalid frame {text!r}, expected a whole number") \
            from None
    if abs(value) > MAX_FRAME:
        raise argparse.ArgumentTypeError(f"frame {value} is outside Blender's frames "
                                         f"(+-{MAX_FRAME})")
    return value


def _frames(text: str) -> list[int]:
    from .patterns import frame_list

    try:
        return frame_list(text, MAX_FRAMES)
    except ValueError as exc:
        raise argparse.ArgumentTypeError(str(exc)) from None


def cmd_version(args) -> int:
    """Print the add-on version."""
    from .. import version

    print(f"BO2 Lighting {version()}")
    return 0


def _comparison_options(cmd, default: str, which: str) -> None:
    """--samples, --cycles-samples and --resolution of a comparison with Cycles."""
    cmd.add_argument("--samples", type=_samples("bo2"),
                     help=f"BO2 Lighting samples per pixel (default: {default})")
    cmd.add_argument("--cycles-samples", type=_samples("cycles"),
                     help=f"Cycles samples per pixel (default: {default})")
    cmd.add_argument("--resolution", type=_resolution, help=f"size WxH in pixels {which}")


def _scheduler_option(cmd, what: str) -> None:
    cmd.add_argument("--scheduler", metavar="ADDRESS",
                     help=f"run {what} on the Dask cluster whose scheduler is at ADDRESS "
                     "(tcp://host:8786; workers started with 'bo2 worker ADDRESS'); the "
                     "files are written here (docs/distributed.md)")


def build_parser() -> argparse.ArgumentParser:
    from ..core.formulas import brdf, env_brdf
    from . import bake, compare, export_probes, render, report, sh, worker
    from . import env_brdf as env_brdf_cmd
    from . import prefilter as prefilter_cmd

    parser = _Parser(prog="bo2", description="BO2 Lighting: Black Ops II lighting for Blender.")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", parser_class=_Parser)
    sub.required = True
    render_cmd = sub.add_parser(
        "render", help="render frames of .blend files to images",
        description="Render frames of one or more .blend files with BO2 Lighting or Cycles. "
        "Each file is loaded once and its frames rendered in order; a file or frame that fails "
        "prints one error line, the others still render, and the exit code is 1.")
    render_cmd.add_argument("scenes", nargs="+", metavar="SCENE", help=".blend file(s)")
    render_cmd.add_argument("-o", "--output", required=True, metavar="OUT",
                            help="image to write: .png through the scene's view transform, "
                            ".exr scene-linear with every enabled pass as a layer. A pattern: "
                            "{scene} is the .blend's name without .blend, {frame} the frame "
                            "({frame:04d} pads it), and the last run of # in the file name the "
                            "frame padded to its length; with several images every path must "
                            "differ")
    which = render_cmd.add_mutually_exclusive_group()
    which.add_argument("--frame", type=_frame,
                       help="frame number (default: the file's current)")
    which.add_argument("--frames", type=_frames, metavar="LIST",
                       help="frames to render: 1-10, 1,3,5-7 or 1-10x2 (every second); "
                       f"at most {MAX_FRAMES:,}")
    render_cmd.add_argument("--summary", metavar="PATH.json",
                            help="write a JSON report: per image the file, scene, frame, output, "
                            "status (ok or failed), seconds and error; totals")
    render_cmd.add_argument("--engine", choices=sorted(headless.ENGINES), default="bo2")
    render_cmd.add_argument("--samples", type=_positive,
                            help=f"samples per pixel (BO2 Lighting: at most {MAX_SAMPLES['bo2']})")
    render_cmd.add_argument("--resolution", type=_resolution, help="output size WxH in pixels")
    render_cmd.add_argument("--all-passes", action="store_true",
                            help="write every render pass to the EXR (default: the view "
                            "layer's)")
    render_cmd.add_argument("--specular-model", choices=brdf.MODELS,
                            help="direct specular terms of the BO2 engine (default: the file's)")
    _scheduler_option(render_cmd, "the frames")
    render_cmd.set_defaults(func=render.run)
    worker_cmd = sub.add_parser(
        "worker", help="run a Dask worker for --scheduler",
        description="Become a Dask worker of the scheduler at ADDRESS for the bo2 commands' "
        "--scheduler (dask worker ADDRESS --nthreads 1 --preload "
        "bo2_lighting.addon.cluster.tasks): one task at a time per process, Blender and the "
        "compiled kernels loaded as it starts. Needs this package, bpy and Dask "
        "(docs/distributed.md).")
    worker_cmd.add_argument("address", help="the scheduler, tcp://host:8786")
    worker_cmd.add_argument("--nworkers", type=_positive, default=1,
                            help="worker processes (default 1: a task uses every core)")
    worker_cmd.add_argument("--memory-limit", metavar="LIMIT",
                            help="each process's memory limit, as dask worker takes it "
                            "('8GiB', 'auto')")
    worker_cmd.add_argument("--name", help="the worker's name")
    worker_cmd.set_defaults(func=worker.run)
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
    env.set_defaults(func=env_brdf_cmd.run)
    sh_cmd = sub.add_parser(
        "sh", help="print the order-3 SH coefficients of an environment image",
        description="Project a lat-long (equirectangular) radiance image, read as Blender reads "
        "it and mapped as the Environment Texture node maps it (Blender world axes, Z up), on "
        "the 9 real SH of docs/sh.md. Prints one line per coefficient: l m  r g b.")
    sh_cmd.add_argument("image", help="equirectangular image (.hdr, .exr, .png, ...)")
    sh_cmd.add_argument("--json", action="store_true", help="print a JSON object")
    sh_cmd.add_argument("-o", "--output", metavar="SH.json",
                        help="write the SH and the tinted scalar SH as JSON")
    sh_cmd.add_argument("--header", metavar="SH.h",
                        help="write them as a C header of static const float arrays")
    sh_cmd.add_argument("--axes", choices=("blender", "y-up"), default="blender",
                        help="axes of the coefficients: Blender's (Z up, default) or Y up "
                        "as glTF, for an engine")
    sh_cmd.set_defaults(func=sh.run)
    pre = sub.add_parser(
        "prefilter", help="prefilter an environment image into a cube map mip chain",
        description="Prefilter an environment (a lat-long .hdr/.exr, a horizontal or vertical "
        "cube cross, or six face images +X -X +Y -Y +Z -Z) into the mip chain a game engine "
        "samples by gloss, written as KTX2 or DDS (RGBA16F cube, every mip) or OpenEXR, with "
        "the gloss-to-mip mapping and the environment map normalization's SH in the metadata. "
        "Faces are in the GPU's cube map orientation, axes Y up as glTF. Filters: bo2, the "
        "talk's cosine power with 8192^gloss (cmft's blinn, gloss scale 13, bias 0); bo1, "
        "CubeMapGen's angular Gaussian; and cmft's phong, phongbrdf, blinn, blinnbrdf with "
        "--gloss-scale and --gloss-bias.")
    pre.add_argument("images", nargs="+", metavar="IMAGE",
                     help="one lat-long or cross image, or six face images")
    pre.add_argument("-o", "--output", action="append", required=True, metavar="OUT",
                     help="file to write: .ktx2, .dds (with a .json beside it) or .exr; "
                     "repeat for several")
    pre.add_argument("--filter", choices=prefilter_cmd.FILTERS, default="bo2")
    pre.add_argument("--size", type=_positive, metavar="S",
                     help="face size of mip 0, a power of two (default: 128 for bo2, the "
                     "talk's, else the input's)")
    pre.add_argument("--mips", type=_positive, metavar="N",
                     help="number of mips (default: down to 1 x 1)")
    pre.add_argument("--gloss-scale", type=_finite, default=10.0,
                     help="cmft filters: specular power 2^(scale gloss + bias) (default 10)")
    pre.add_argument("--gloss-bias", type=_finite, default=1.0, help="(default 1)")
    pre.add_argument("--scale", type=_scale, default=1.0, metavar="K",
                     help="multiply the environment's radiance by K before filtering (the "
                     "SH too): brings a sun's texels under 65504, the largest value of the "
                     "half floats of KTX2 and DDS; the metadata records K (default 1)")
    pre.add_argument("--edge-fixup", choices=("none", "warp"), default="none",
                     help="warp: edge texels filtered at the edge's direction, for GPUs "
                     "without seamless cube filtering (the shader scales the lookup's minor "
                     "axes by 1 - 1/S_mip); default none (seamless)")
    pre.add_argument("--exclude-base", action="store_true",
                     help="mip 0 is the input, unfiltered (as cmft's --excludeBase)")
    pre.add_argument("--json", action="store_true", help="print a JSON summary")
    pre.set_defaults(func=prefilter_cmd.run)
    bake_cmd = sub.add_parser(
        "bake", help="bake the light probes or lightmaps of a .blend file",
        description="Bake the Sphere and Volume light probes of a .blend file (SH irradiance and "
        "prefiltered cube maps) into the .blend's own folder inside its bake folder (the "
        "scene's Bake Folder, '//bo2_bake/' by default: '//bo2_bake/<file name>/'), one "
        "OpenEXR file per probe; with --lightmaps, the lightmaps of its static objects into "
        "'lightmaps' there. Then the .blend is saved: it declares each bake file as an image "
        "datablock, or packs it (--pack). Nothing is written unless every one finishes.")
    bake_cmd.add_argument("scene", help=".blend file")
    bake_cmd.add_argument("--probes", nargs="+", metavar="NAME",
                          help="only these light probe objects (default: all)")
    bake_cmd.add_argument("--backend", choices=("bo2", "cycles"), default="bo2",
                          help="captures rendered by BO2 Lighting (default) or Cycles")
    bake_cmd.add_argument("--lightmaps", nargs="*", metavar="NAME",
                          help="bake the lightmaps of the static mesh objects instead of the "
                          "probes (these objects only, if named); bake the probes first, "
                          "they light the dynamic objects the lightmaps see")
    bake_cmd.add_argument("--pack", action=argparse.BooleanOptionalAction, default=None,
                          help="store the bakes inside the .blend too (default: the scene's "
                          "Pack Bakes setting)")
    _scheduler_option(bake_cmd, "the captures")
    bake_cmd.set_defaults(func=bake.run)
    export = sub.add_parser(
        "export-probes", help="export the baked probes of a .blend file for a game engine",
        description="Write every baked light probe of a .blend file, and its world, as a game "
        "engine loads them: the reflection probes' and the world's BO2 prefiltered chains "
        "(KTX2 or DDS RGBA16F cubes, or OpenEXR; none with --format json) and probes.json: "
        "each probe's SH, placement, parallax proxy, influence and falloff, the volumes' SH "
        "grids, the gloss-to-mip mapping and the normalization data, in Y-up axes as glTF.")
    export.add_argument("scene", help=".blend file")
    export.add_argument("-o", "--output", required=True, metavar="DIR",
                        help="output folder (created if missing)")
    export.add_argument("--format", choices=("ktx2", "dds", "exr", "json"), default="ktx2")
    export.set_defaults(func=export_probes.run)
    compare_cmd = sub.add_parser(
        "compare", help="render a frame with BO2 Lighting and Cycles and compare them",
        description="Render one frame of a .blend file with BO2 Lighting and with Cycles (same "
        "camera and resolution) and write into DIR: bo2.exr and cycles.exr (every pass), "
        "side_by_side.png, split.png and difference.png (through the scene's view transform) "
        "and metrics.json (RMSE, mean relative error, PSNR, SSIM, per pass too). Prints the "
        "headline metrics and the paths (docs/compare.md).")
    compare_cmd.add_argument("scene", help=".blend file")
    compare_cmd.add_argument("-o", "--output", required=True, metavar="DIR",
                             help="output folder (created if missing)")
    compare_cmd.add_argument("--frame", type=_frame,
                             help="frame number (default: the file's current)")
    _comparison_options(compare_cmd, "the file's", "of both")
    compare_cmd.set_defaults(func=compare.run)
    report_cmd = sub.add_parser(
        "report", help="compare many scenes with Cycles on one review page",
        description="Render each .blend file's scene with BO2 Lighting and with Cycles (as bo2 "
        "compare does), or read bo2 compare folders back, and write DIR/index.html: a static "
        "page that works offline, with the scenes ranked by mean FLIP (worst first), an A/B "
        "wipe between the engines, difference and FLIP maps, per-pass metrics and render "
        "times (docs/report.md). Ctrl-C keeps the scenes done.")
    report_cmd.add_argument("scenes", nargs="+", metavar="SCENE",
                            help=".blend file, bo2 compare folder, or a folder of either")
    report_cmd.add_argument("-o", "--output", required=True, metavar="DIR",
                            help="report folder (created if missing)")
    report_cmd.add_argument("--old-methods", action="store_true",
                            help="also render BO2 Lighting with the talk's old methods (BO1 "
                            "environment BRDF, normalization and prefilter), for the page's "
                            "old/new toggle")
    report_cmd.add_argument("--fail-above", type=_fraction, metavar="FLIP",
                            help="exit 1 when a scene's mean LDR-FLIP is above FLIP (0 to 1); "
                            "the failing scenes come first on the page")
    report_cmd.add_argument("--title", default="Look-dev review", help="the page's title")
    _comparison_options(report_cmd, "each file's", "of every render")
    _scheduler_option(report_cmd, "the scenes' renders (a task per scene)")
    report_cmd.set_defaults(func=report.run)
    version = sub.add_parser("version", help="print the add-on version")
    version.set_defaults(func=cmd_version)
    return parser


def main(argv: list[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    try:
        return args.func(args)
    except CommandError as exc:
        print(f"bo2: error: {exc}", file=sys.stderr)
        return exc.code
    except KeyboardInterrupt:
        from ..blender import interrupt

        interrupt.settle()
        print("bo2: interrupted", file=sys.stderr)
        return 130
    except Exception as exc:  # noqa: BLE001 - one line for the user, never a traceback
        print(f"bo2: error: {type(exc).__name__}: {exc}", file=sys.stderr)
        return 1
