"""Real assets: the glTF importer's material set-ups and the glTF-Blender-IO test scenes.

Every scene of ``reference/scenes/gltf-blender-io`` and every ``.glb`` of ``reference/gltf``
(imported with Blender's own glTF importer) is rendered by both engines under the same sun,
with direct light only, and compared pixel by pixel. The engine must read every node these
files use (no "not supported" warning for a node of the supported list) and stay within the
stated bound of Cycles; the bound is loose where the talk's specular model (normalized
Blinn-Phong, Schlick-Smith) differs from Cycles' multiscatter GGX on rough metals.

The 2.7x-era scenes link a "glTF Metallic Roughness" group from a library the repository does
not hold; ``rebuild_legacy_gltf`` replaces it, as the importer of today would, by a Principled
BSDF fed through the same node chains (base colour times factor and vertex colour, packed
metallic-roughness channels, normal map, emission, alpha modes).
"""

import sys
from pathlib import Path

import bpy
import numpy as np
import pytest
from util import render_passes

ROOT = Path(__file__).resolve().parents[2]
REFERENCE = ROOT.parent / "shared" / "reference"
SCENES = sorted((REFERENCE / "scenes" / "gltf-blender-io").glob("*.blend"))
GLB = sorted((REFERENCE / "gltf").glob("*.glb"))
pytestmark = pytest.mark.skipif(not SCENES, reason="the reference scenes are not here")

W, H = 96, 72


def _link(tree, out, into):
    tree.links.new(out, into)


def _multiply(tree, a, b, kind="RGBA"):
    """a x b as a Mix node (colours) or a Math node (floats)."""
    if kind == "RGBA":
        node = tree.nodes.new("ShaderNodeMix")
        node.data_type, node.blend_type = "RGBA", "MULTIPLY"
        ins = {s.identifier: s for s in node.inputs}
        ins["Factor_Float"].default_value = 1.0
        targets, out = (ins["A_Color"], ins["B_Color"]), next(
            s for s in node.outputs if s.identifier == "Result_Color")
    else:
        node = tree.nodes.new("ShaderNodeMath")
        node.operation = "MULTIPLY"
        targets, out = (node.inputs[0], node.inputs[1]), node.outputs[0]
    for target, value in zip(targets, (a, b), strict=True):
        if isinstance(value, bpy.types.NodeSocket):
            _link(tree, value, target)
        else:
            target.default_value = value
    return out


def _source(sock):
    """What feeds ``sock``: its linked output socket, else its value."""
    if sock.is_linked:
        return sock.links[0].from_socket
    value = sock.default_value
    return tuple(value) if hasattr(value, "__len__") else value


def rebuild_legacy_gltf(material) -> bool:
    """Replace a missing "glTF Metallic Roughness" group by a Principled BSDF fed the same way.
    Returns whether the material changed."""
    tree = material.node_tree
    if tree is None:
        return False
    group = next((n for n in tree.nodes if n.bl_idname == "ShaderNodeGroup"
                  and n.node_tree is not None and n.node_tree.name == "glTF Metallic Roughness"
                  and not len(n.node_tree.nodes)), None)
    if group is None:
        return False
    ins = {s.name: s for s in group.inputs}
    p = tree.nodes.new("ShaderNodeBsdfPrincipled")
    base = _multiply(tree, _source(ins["BaseColor"]), _source(ins["BaseColorFactor"]))
    if ins["Use COLOR_0"].default_value > 0.5:
        vcol = tree.nodes.new("ShaderNodeVertexColor")
        base = _multiply(tree, base, vcol.outputs["Color"])
    _link(tree, base, p.inputs["Base Color"])
    mr = _source(ins["MetallicRoughness"])
    if isinstance(mr, bpy.types.NodeSocket):
        sep = tree.nodes.new("ShaderNodeSeparateColor")
        _link(tree, mr, sep.inputs[0])
        metallic, rough = sep.outputs["Blue"], sep.outputs["Green"]
    else:
        metallic, rough = mr[2], mr[1]
    _link(tree, _multiply(tree, metallic, ins["MetallicFactor"].default_value, "VALUE"),
          p.inputs["Metallic"])
    _link(tree, _multiply(tree, rough, ins["RoughnessFactor"].default_value, "VALUE"),
          p.inputs["Roughness"])
    if ins["Normal"].is_linked:
        nmap = tree.nodes.new("ShaderNodeNormalMap")
        nmap.inputs["Strength"].default_value = ins["NormalScale"].default_value
        _link(tree, ins["Normal"].links[0].from_socket, nmap.inputs["Color"])
        _link(tree, nmap.outputs[0], p.inputs["Normal"])
    emissive = _multiply(tree, _source(ins["Emissive"]), _source(ins["EmissiveFactor"]))
    _link(tree, emissive, p.inputs["Emission Color"])
    p.inputs["Emission Strength"].default_value = 1.0
    mode = int(round(ins["AlphaMode"].default_value))  # 0 opaque, 1 mask, 2 blend
    if mode:
        alpha = _multiply(tree, _source(ins["Alpha"]),
                          float(ins["BaseColorFactor"].default_value[3]), "VALUE")
        if mode == 1:  # mask: alpha >= cutoff
            less = tree.nodes.new("ShaderNodeMath")
            less.operation = "LESS_THAN"
            _link(tree, alpha, less.inputs[0])
            less.inputs[1].default_value = ins["AlphaCutoff"].default_value
            inv = tree.nodes.new("ShaderNodeMath")
            inv.operation = "SUBTRACT"
            inv.inputs[0].default_value = 1.0
            _link(tree, less.outputs[0], inv.inputs[1])
            alpha = inv.outputs[0]
        _link(tree, alpha, p.inputs["Alpha"])
    for link in list(group.outputs[0].links):
        _link(tree, p.outputs[0], link.to_socket)
    tree.nodes.remove(group)
    return True


def stage(scene):
    """``tools/make_asset_images.stage``: one sun, a black world, a framing camera."""
    sys.path.insert(0, str(ROOT / "tools"))
    try:
        import make_asset_images
    finally:
        sys.path.pop(0)
    make_asset_images.stage(scene, W, H)


def unsupported_warnings(scene) -> list[str]:
    """The engine's warnings about nodes it does not read, for nodes of the supported list."""
    from bo2_lighting.addon.blender import extract, material_nodes

    depsgraph = bpy.context.evaluated_depsgraph_get()
    _, warnings = extract.extract_scene(depsgraph)
    named = [w for w in warnings if "is not supported" in w or "could not be read" in w]
    return [w for w in named if any(f"({kind})" in w for kind in material_nodes.SUPPORTED_NODES)
            or "could not be read" in w]


def compare(scene, name):
    """Both renders: (Combined |d| (H, W, 3), Albedo |d| against Cycles' Diffuse Color)."""
    ours = render_passes(scene, "BO2_LIGHTING", ["Combined", "Albedo"], samples=16)
    cycles = render_passes(scene, "CYCLES", ["Combined", "DiffCol"], samples=32)
    image = np.abs(ours["Combined"][..., :3] - cycles["Combined"][..., :3])
    albedo = np.abs(ours["Albedo"][..., :3] - cycles["DiffCol"][..., :3])
    print(f"{name}: Combined mean |d| {image.mean():.4f}, p95 {np.percentile(image, 95):.4f} "
          f"(BO2 mean {ours['Combined'][..., :3].mean():.4f}, Cycles "
          f"{cycles['Combined'][..., :3].mean():.4f}); Albedo mean |d| {albedo.mean():.4f}, "
          f"p99 {np.percentile(albedo, 99):.4f}")
    assert np.isfinite(ours["Combined"]).all()
    lit = (cycles["Combined"][..., :3].max(-1) > 1e-4).mean()
    assert lit > (0.0002 if name == "01_metallic_sphere" else 0.05)  # framed and lit (a mirror
    # sphere under a black sky shows the sun's highlight alone)
    return image, albedo


# Combined: (mean |d|, 95th percentile) per scene where the bound is not the default. Rough
# metals (the legacy glTF group's defaults are metallic 1, roughness 1) reflect less in the
# talk's model than in Cycles' multiscatter GGX: at gloss 0 (alpha = 1) the normalized
# Blinn-Phong lobe with Schlick-Smith visibility keeps some 40-60% of the energy, and a smooth
# metal sphere's sun highlight is a few pixels whose size differs. 01_principled_material's
# four images are not in the repository: both engines render Cycles' magenta, whose emission
# saturates differently.
DEFAULT_BOUND = (0.01, 0.05)
BOUNDS = {
    "01_alpha_blend": (0.04, 0.45), "01_alpha_mask": (0.05, 0.5),
    "01_color_attribute": (0.025, 0.15), "01_metallic_sphere": (0.2, 0.05),
    "01_principled_material": (0.1, 1.0), "05_metallic_sphere_light": (0.35, 0.5),
    "08_combine_orm": (0.25, 0.35), "08_only_rough": (0.02, 0.04),
}
# Albedo against Cycles' Diffuse Color (mean, 99th percentile): Cycles' Principled BSDF dims
# its diffuse layer by the specular layer's albedo (4-10% here) where the talk's albedo is the
# base colour times 1 - metallic; textures are minified by mip maps here and by Cycles' samples
ALBEDO_BOUND = (0.03, 0.2)
def check(name, image, albedo):
    mean, p95 = BOUNDS.get(name, DEFAULT_BOUND)
    assert image.mean() <= mean and np.percentile(image, 95) <= p95
    assert albedo.mean() <= ALBEDO_BOUND[0] and np.percentile(albedo, 99) <= ALBEDO_BOUND[1]


@pytest.mark.parametrize("path", SCENES, ids=[p.stem for p in SCENES])
def test_gltf_blender_io_scenes(addon, path):
    bpy.ops.wm.open_mainfile(filepath=str(path))
    for mat in bpy.data.materials:
        rebuild_legacy_gltf(mat)
    scene = bpy.context.scene
    stage(scene)
    assert unsupported_warnings(scene) == []
    check(path.stem, *compare(scene, path.stem))


@pytest.mark.parametrize("path", GLB, ids=[p.stem for p in GLB])
def test_gltf_imports(addon, path):
    bpy.ops.import_scene.gltf(filepath=str(path))
    scene = bpy.context.scene
    stage(scene)
    assert unsupported_warnings(scene) == []
    check(path.stem, *compare(scene, path.stem))
