"""The engine's warnings reach the command line: once each on stderr, and in --summary."""

import json
import subprocess
import sys

from test_cli import TINY, bo2, error_lines

SCENE = """
import bpy
bpy.ops.wm.read_factory_settings(use_empty=True)
bpy.ops.mesh.primitive_plane_add(size=4)
plane = bpy.context.object
mat = bpy.data.materials.new("Odd")
if mat.node_tree is None:
    mat.use_nodes = True
nodes, links = mat.node_tree.nodes, mat.node_tree.links
bsdf = nodes["Principled BSDF"]
image = bpy.data.images.new("Missing", 4, 4)
image.source, image.filepath = "FILE", "//no_such_texture.png"
tex = nodes.new("ShaderNodeTexImage")
tex.image = image
links.new(tex.outputs["Color"], bsdf.inputs["Base Color"])
magic = nodes.new("ShaderNodeTexMagic")
links.new(magic.outputs["Fac"], bsdf.inputs["Roughness"])
plane.data.materials.append(mat)
cam = bpy.data.objects.new("Camera", bpy.data.cameras.new("Camera"))
cam.location = (0, 0, 5)
bpy.context.scene.collection.objects.link(cam)
bpy.context.scene.camera = cam
bpy.ops.wm.save_as_mainfile(filepath={path!r})
"""


def test_warnings_are_printed_once_and_summarised(tmp_path):
    blend = tmp_path / "odd.blend"
    subprocess.run([sys.executable, "-c", SCENE.format(path=str(blend))], check=True,
                   capture_output=True)
    summary = tmp_path / "summary.json"
    proc = bo2("render", blend, "--frames", "1-2", "-o", tmp_path / "odd_#.png",
               "--summary", summary, *TINY)
    assert proc.returncode == 0, proc.stderr
    assert not error_lines(proc)
    warnings = [s for s in proc.stderr.splitlines() if s.startswith("bo2: warning: ")]
    assert len(warnings) == len(set(warnings)) >= 2, proc.stderr  # each once, over two frames
    assert any("no_such_texture.png" in w for w in warnings), warnings
    assert any("Magic" in w for w in warnings), warnings
    report = json.loads(summary.read_text())
    assert len(report["warnings"]) == len(warnings)
    assert all(f"bo2: warning: odd.blend: {w}" in warnings for w in report["warnings"])
    assert [len(i["warnings"]) for i in report["images"]] == [len(warnings)] * 2
