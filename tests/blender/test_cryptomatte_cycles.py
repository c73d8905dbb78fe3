"""Cryptomatte passes picked by Blender's own Cryptomatte node, against Cycles' mattes.

The scene of ``test_light_linking_cycles`` (two spheres on a floor), sphere B parented to an empty
"Rig". The compositor's Cryptomatte node (source Render) reads the render's passes and
metadata; its Matte output of a name, composited, is compared with the same matte of a Cycles
render.
"""

import bpy
import numpy as np
import pytest
from test_light_linking_cycles import build
from util import render_pixels

from bo2_lighting.addon.blender import engine

LEVELS = 4


def scene_with_rig():
    scene = build()
    rig = bpy.data.objects.new("Rig", None)
    scene.collection.objects.link(rig)
    scene.objects["B"].parent = rig
    layer = bpy.context.view_layer
    layer.use_pass_cryptomatte_object = layer.use_pass_cryptomatte_material = True
    layer.use_pass_cryptomatte_asset = True
    layer.pass_cryptomatte_depth = LEVELS
    scene.render.film_transparent = False
    return scene


def matte_tree(scene, kind: str, names: str):
    """The compositor: Render Layers' Cryptomatte node picking ``names`` of pass ``kind``,
    its Matte as the composited image."""
    if bpy.app.version >= (5, 0, 0):
        tree = bpy.data.node_groups.new("Compositing", "CompositorNodeTree")
        tree.interface.new_socket("Image", in_out="OUTPUT", socket_type="NodeSocketColor")
        scene.compositing_node_group = tree
        out = tree.nodes.new("NodeGroupOutput")
    else:
        scene.use_nodes = True
        tree = scene.node_tree
        for node in list(tree.nodes):
            tree.nodes.remove(node)
        out = tree.nodes.new("CompositorNodeComposite")
    node = tree.nodes.new("CompositorNodeCryptomatteV2")
    node.source = "RENDER"
    node.scene = scene
    node.layer_name = f"{bpy.context.view_layer.name}.Crypto{kind}"
    node.matte_id = names
    tree.links.new(node.outputs["Matte"], out.inputs[0])
    scene.render.use_compositing = True
    return node


def matte(scene, engine_id: str, samples: int) -> np.ndarray:
    return render_pixels(scene, engine_id, samples=samples)[..., 0]


@pytest.mark.parametrize(("kind", "names"), [("Object", "A"), ("Material", "B"),
                                              ("Asset", "Rig"), ("Object", "Floor,B")])
def test_the_cryptomatte_node_picks_the_mattes_cycles_gives(addon, kind, names):
    """The matte of a name from BO2's passes against Cycles': the same pixels inside (IoU of
    the half-covered masks above 0.97), edges within 0.25 (16 and 64 samples' coverage), mean
    difference under 0.01; and BO2's render says the names it wrote."""
    scene = scene_with_rig()
    matte_tree(scene, kind, names)
    with engine.listening() as said:
        ours = matte(scene, "BO2_LIGHTING", 16)
    assert not [t for t in said.texts() if "Crypto" in t], said.texts()
    cycles = matte(scene, "CYCLES", 64)
    inside, theirs = ours > 0.5, cycles > 0.5
    iou = (inside & theirs).sum() / max((inside | theirs).sum(), 1)
    print(f"{kind} {names}: IoU {iou:.4f}, mean |difference| "
          f"{np.abs(ours - cycles).mean():.4f}, max {np.abs(ours - cycles).max():.3f}, "
          f"{theirs.mean():.3f} of the frame")
    assert theirs.mean() > 0.02  # the name is in the frame
    assert iou > 0.97
    assert np.abs(ours - cycles).mean() < 0.01
    assert np.quantile(np.abs(ours - cycles), 0.999) < 0.25


def test_levels_make_the_passes_and_their_metadata(addon, tmp_path):
    """Levels 4 registers two passes per kind (the compositor's Render Layers node shows
    them); a multilayer EXR of BO2's render holds them and the metadata Cycles writes for the
    names BO2 saw."""
    from bo2_lighting.addon.blender import images
    from bo2_lighting.addon.core.files import exr

    scene = scene_with_rig()
    render_pixels(scene, "BO2_LIGHTING", samples=4)
    path = tmp_path / "crypto.exr"
    images.save_render_result(scene, path, "OPEN_EXR_MULTILAYER", "32", "RGBA",
                              follow_scene=True)
    parts = exr.read(path, separate=True)  # one part per pass (5.x) or one in all (4.5)
    written = {c.rsplit(".", 1)[0] for p in parts for c in p.channels}
    layer = bpy.context.view_layer.name
    for kind in ("Object", "Material", "Asset"):
        for n in ("00", "01"):
            assert {f"{layer}.Crypto{kind}{n}.{c}" for c in "rgba"} <= {
                c for p in parts for c in p.channels}
        assert f"{layer}.Crypto{kind}02" not in written
    header = parts[0].header
    manifests = {header[k]: header[k.replace("/name", "/manifest")]
                 for k in header if k.startswith("cryptomatte/") and k.endswith("/name")}
    assert manifests[f"{layer}.CryptoObject"] == \
        '{"Floor":"6a2fb16e","A":"54dcf7ce","B":"cca66a8a"}'
    assert '"Rig":"b76dec1e"' in manifests[f"{layer}.CryptoAsset"]


def test_names_whose_ids_clash_are_said(addon):
    """Two objects whose names hash alike render, and the render says one matte picks both."""
    scene = scene_with_rig()
    scene.objects["A"].name, scene.objects["B"].name = "Cube.027977", "Cube.083097"
    with engine.listening() as said:
        render_pixels(scene, "BO2_LIGHTING", samples=1)
    assert ("Cryptomatte Object: 'Cube.027977' and 'Cube.083097' have the same id, so one "
            "matte picks both; rename one") in said.texts(), said.texts()
