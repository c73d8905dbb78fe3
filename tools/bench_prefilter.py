"""Benchmark of ``bo2 prefilter``'s filtering beside cmft's, when cmft is installed.

Usage: python tools/bench_prefilter.py [--hdr PATH] [--sizes 128 256] [--repeat 2]

For each face size: the lat-long map's conversion to a cube (``environment_files.to_cube``)
and the chain's filtering (``prefilter.prefilter_powers``) with the talk's filter (bo2) and
cmft's blinnbrdf (gloss scale 10, bias 1), best of ``--repeat``, in this process (Python's
start excluded). If a ``cmft`` executable is on the PATH, the same radiance filter by cmft
(its command line, two CPU threads, no OpenCL) is timed in the same run; otherwise the script
says so. Prints figures only.
"""

from __future__ import annotations

import argparse
import shutil
import subprocess
import tempfile
import time
from pathlib import Path

from bo2_lighting.addon.core.files import environment_files
from bo2_lighting.addon.core.formulas import prefilter

ROOT = Path(__file__).resolve().parents[1]


def best(fn, repeat: int) -> tuple[float, object]:
    times, result = [], None
    for _ in range(repeat):
        start = time.perf_counter()
        result = fn()
        times.append(time.perf_counter() - start)
    return min(times), result


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--hdr", type=Path, default=ROOT.parent / "shared" / "reference" /
                        "envmaps" / "venice_sunset_1k.hdr")
    parser.add_argument("--sizes", type=int, nargs="+", default=[128, 256])
    parser.add_argument("--repeat", type=int, default=2)
    args = parser.parse_args()
    image = environment_files.read_image(args.hdr)
    cmft = shutil.which("cmft")
    print(f"{args.hdr.name}: {image.shape[1]} x {image.shape[0]}")
    print(f"{'face':>5} {'mips':>5} {'to cube s':>10} {'bo2 s':>8} {'blinnbrdf s':>12} "
          f"{'cmft blinnbrdf s':>17}")
    for size in args.sizes:
        mips = size.bit_length()
        t_cube, cube = best(lambda s=size: environment_files.to_cube([image], s), args.repeat)
        t_bo2, _ = best(lambda c=cube, m=mips: prefilter.prefilter_powers(
            c, prefilter.cmft_powers(m, 13.0, 0.0, "blinn")), args.repeat)
        t_cmft_ours, _ = best(lambda c=cube, m=mips: prefilter.prefilter_powers(
            c, prefilter.cmft_powers(m, 10.0, 1.0, "blinnbrdf")), args.repeat)
        if cmft is None:
            theirs = "not installed"
        else:
            with tempfile.TemporaryDirectory() as tmp:
                cmd = [cmft, "--input", str(args.hdr), "--filter", "radiance", "--srcFaceSize",
                       "0", "--dstFaceSize", str(size), "--excludeBase", "false", "--mipCount",
                       str(mips), "--glossScale", "10", "--glossBias", "1", "--lightingModel",
                       "blinnbrdf", "--edgeFixup", "none", "--numCpuProcessingThreads", "2",
                       "--useOpenCL", "false", "--outputNum", "1", "--output0",
                       str(Path(tmp) / "out"), "--output0params", "dds,rgba16f,cubemap"]
                t, _ = best(lambda c=cmd: subprocess.run(c, check=True, capture_output=True),
                            args.repeat)
                theirs = f"{t:.2f}"
        print(f"{size:5d} {mips:5d} {t_cube:10.2f} {t_bo2:8.2f} {t_cmft_ours:12.2f} "
              f"{theirs:>17}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
