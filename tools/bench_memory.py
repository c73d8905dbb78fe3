"""Peak memory of big textures and big frames: BO2 Lighting against Cycles, in the same run.

Usage: python tools/bench_memory.py [--sizes 4096,16384] [--skip-cycles] [--skip-8k]

Each case is one ``bo2 render`` process; the table gives its peak resident memory (the
kernel's ``ru_maxrss``) and, for the textures, what the texture adds to the same render of
the same plane without it. Texture cases: a plane filling a 160x90 frame, its Base Color an
8-bit RGB PNG of N x N texels read from disk (a smooth pattern, so that the file stays
small), 1 sample. Frame case: 7680x4320, the demo scene ``first_light.blend``, 1 sample,
with the file's passes and with every pass (``--all-passes``). Prints figures only.
"""

from __future__ import annotations

import argparse
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

from bo2_lighting.addon.core.review import imaging

sys.path.insert(0, str(Path(__file__).resolve().parent))
from bench_render import BO2, run  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]

BUILD = r'''
import sys
import bpy
bpy.ops.wm.read_factory_settings(use_empty=True)
scene = bpy.context.scene
scene.render.resolution_x, scene.render.resolution_y = 160, 90
bpy.ops.mesh.primitive_plane_add(size=2.0)
plane = bpy.context.object
plane.scale = (16 / 9, 1.0, 1.0)
m = bpy.data.materials.new("Plane")
if bpy.app.version < (5, 0, 0):
    m.use_nodes = True
plane.data.materials.append(m)
if sys.argv[2] != "-":
    node = m.node_tree.nodes.new("ShaderNodeTexImage")
    node.image = bpy.data.images.load(sys.argv[2])
    m.node_tree.links.new(node.outputs["Color"],
                          m.node_tree.nodes["Principled BSDF"].inputs["Base Color"])
bpy.ops.object.camera_add(location=(0.0, 0.0, 2.0))
scene.camera = bpy.context.object
scene.camera.data.type = "ORTHO"
scene.camera.data.ortho_scale = 2.0 * 16 / 9
bpy.ops.object.light_add(type="SUN")
bpy.ops.wm.save_as_mainfile(filepath=sys.argv[1])
'''


def write_texture(path: Path, size: int) -> None:
    """An 8-bit RGB PNG of size x size texels: smooth ramps with a checker of 64 texels."""
    x = (np.arange(size) * 255 // max(1, size - 1)).astype(np.uint8)
    image = np.empty((size, size, 3), np.uint8)
    image[..., 0] = x[None, :]
    image[..., 1] = x[:, None]
    cells = np.arange(size) // 64
    image[..., 2] = np.where((cells[None, :] + cells[:, None]) % 2 == 0, 200, 40)
    imaging.write_png(path, image)


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sizes", default="4096,16384",
                        help="texture sides to measure, comma-separated")
    parser.add_argument("--skip-cycles", action="store_true")
    parser.add_argument("--skip-8k", action="store_true", help="leave out the 8K frames")
    args = parser.parse_args()
    engines = ["bo2"] + ([] if args.skip_cycles else ["cycles"])
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        out = str(tmp / "frame.png")
        bare = tmp / "bare.blend"
        subprocess.run([sys.executable, "-c", BUILD, str(bare), "-"], check=True,
                       capture_output=True)
        base = {}
        for engine in engines:
            base[engine] = run([str(BO2), "render", str(bare), "-o", out, "--engine", engine,
                                "--samples", "1"])[1]
            rows.append((f"160x90, no texture, {engine}", base[engine], None))
        for size in (int(s) for s in args.sizes.split(",") if s):
            print(f"writing a {size}x{size} PNG ...", flush=True)
            png = tmp / f"texture_{size}.png"
            write_texture(png, size)
            blend = tmp / f"texture_{size}.blend"
            subprocess.run([sys.executable, "-c", BUILD, str(blend), str(png)], check=True,
                           capture_output=True)
            for engine in engines:
                print(f"rendering {size}x{size} with {engine} ...", flush=True)
                peak = run([str(BO2), "render", str(blend), "-o", out, "--engine", engine,
                            "--samples", "1"])[1]
                rows.append((f"160x90, {size}x{size} 8-bit texture, {engine}", peak,
                             peak - base[engine]))
        if not args.skip_8k:
            scene = ROOT / "demo_blends" / "first_light.blend"
            for engine in engines:
                for extra in ([], ["--all-passes"]):
                    print(f"rendering 7680x4320 {' '.join(extra)} with {engine} ...", flush=True)
                    peak = run([str(BO2), "render", str(scene), "-o", str(tmp / "frame.exr"),
                                "--engine", engine, "--samples", "1",
                                "--resolution", "7680x4320", *extra])[1]
                    passes = "every pass" if extra else "the file's passes"
                    rows.append((f"7680x4320, {passes}, {engine}", peak, None))
    print(f"\n{'case':<44} {'peak MiB':>9} {'added MiB':>10}")
    for name, peak, added in rows:
        print(f"{name:<44} {peak:9.0f} {'' if added is None else f'{added:10.0f}'}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
