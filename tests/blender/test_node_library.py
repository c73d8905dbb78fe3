"""The node group asset library and the Principled <-> BO2 Material conversion.

Independent values: the group specs in ``node_groups/`` (sockets), the core's
``principled_to_talk`` in NumPy against Cycles evaluating BO2 Principled to Talk (emission
shows a value exactly: 0.01 px filter, one sample, Standard view), a Lambert plane under a sun
(albedo / pi times the irradiance) for a material built from the library.
"""

import bpy
import numpy as np
import pytest
from test_node_groups import add_plane, add_sun, render, setup_render
from util import bare_material, render_pixels

from bo2_lighting.addon.blender import convert, library, node_groups
from bo2_lighting.addon.core.scene.nodes import principled_to_talk


def load_library():
    with bpy.data.libraries.load(str(library.LIBRARY_FILE), assets_only=True) as (src, dst):
        dst.node_groups = list(src.node_groups)
    return {g.name: g for g in dst.node_groups}


def interface(tree):
    """(name, in/out, type) of the sockets, inputs then outputs, each in their order."""
    items = [(s.name, s.in_out, s.socket_type) for s in tree.interface.items_tree
             if s.item_type == "SOCKET"]
    return sorted(items, key=lambda item: item[1] == "OUTPUT")


def test_library_holds_every_group_as_specified(empty_scene):
    groups = load_library()
    assert set(groups) == set(node_groups.GROUP_NAMES)
    for name, tree in groups.items():
        spec = node_groups.load_spec(name)
        specified = [(i["name"], i["in_out"], i["socket_type"]) for i in spec["interface"]]
        assert interface(tree) == sorted(specified, key=lambda item: item[1] == "OUTPUT"), name
        assert sorted(n.name for n in tree.nodes) == sorted(n["name"] for n in spec["nodes"]), \
            f"{name}: the library is older than its spec; run tools/build_node_library.py"
        assert tree.asset_data is not None and tree.asset_data.catalog_id == library.CATALOG_ID
        assert "BO2 Lighting" in [t.name for t in tree.asset_data.tags]
    catalog = library.CATALOG_FILE.read_text()
    assert f"{library.CATALOG_ID}:{library.CATALOG_PATH}:" in catalog


def test_a_material_from_the_library_renders_in_cycles(empty_scene):
    scene = empty_scene
    groups = load_library()
    setup_render(scene, 8, 8)
    mat, tree = bare_material("From library")
    node = tree.nodes.new("ShaderNodeGroup")
    node.node_tree = groups["BO2 Material"]
    node.inputs["Albedo"].default_value = (0.5, 0.25, 0.125, 1.0)
    node.inputs["Specular Color"].default_value = (0.0, 0.0, 0.0, 1.0)
    tree.links.new(node.outputs["BSDF"], tree.nodes["Material Output"].inputs["Surface"])
    add_plane(mat)
    add_sun(scene, 3.0)
    px = render(scene)
    expected = np.array([0.5, 0.25, 0.125]) / np.pi * 3.0
    np.testing.assert_allclose(px[..., :3].reshape(-1, 3).mean(0), expected, rtol=1e-3)


PRINCIPLED = [  # base, metallic, roughness, ior, level, tint, transmission
    ((0.8, 0.3, 0.1), 0.0, 0.5, 1.5, 0.5, (1.0, 1.0, 1.0), 0.0),
    ((0.9, 0.6, 0.2), 1.0, 0.2, 1.45, 0.5, (1.0, 1.0, 1.0), 0.0),
    ((0.4, 0.5, 0.6), 0.35, 0.05, 2.0, 0.8, (0.9, 0.5, 0.2), 0.25),
    ((0.2, 0.2, 0.2), 0.0, 0.95, 1.33, 0.1, (1.0, 1.0, 1.0), 0.0),
    ((1.0, 1.0, 1.0), 0.6, 0.0, 1.0, 1.0, (1.0, 1.0, 1.0), 1.0),
]


@pytest.mark.parametrize("values", PRINCIPLED, ids=[f"case{k}" for k in range(len(PRINCIPLED))])
def test_principled_to_talk_group_matches_the_core_in_cycles(empty_scene, values):
    scene = empty_scene
    setup_render(scene, 4, 4)
    mat, tree = bare_material("P2T")
    group = tree.nodes.new("ShaderNodeGroup")
    group.node_tree = node_groups.ensure_group(node_groups.PRINCIPLED_GROUP)
    base, metallic, rough, ior, level, tint, transmission = values
    for name, value in zip(("Base Color", "Metallic", "Roughness", "IOR", "Specular IOR Level",
                            "Specular Tint", "Transmission Weight"), values, strict=True):
        group.inputs[name].default_value = (*value, 1.0) if isinstance(value, tuple) else value
    emit = tree.nodes.new("ShaderNodeEmission")
    tree.links.new(emit.outputs[0], tree.nodes["Material Output"].inputs["Surface"])
    add_plane(mat)
    albedo, rf0, gloss = principled_to_talk(
        np.array([base]), np.array([[metallic]]), np.array([[rough]]), np.array([[ior]]),
        np.array([[level]]), np.array([tint]), np.array([[transmission]]))
    for output, expected in (("Albedo", albedo[0]), ("Specular Color", rf0[0]),
                             ("Gloss", np.repeat(gloss.reshape(-1), 3))):
        tree.links.new(group.outputs[output], emit.inputs["Color"])
        px = render(scene)[..., :3].reshape(-1, 3).mean(0)
        np.testing.assert_allclose(px, expected, atol=2e-5, err_msg=output)


def principled_material(name, base, metallic, roughness):
    mat, tree = bare_material(name)
    node = tree.nodes.new("ShaderNodeBsdfPrincipled")
    node.inputs["Base Color"].default_value = (*base, 1.0)
    node.inputs["Metallic"].default_value = metallic
    node.inputs["Roughness"].default_value = roughness
    tree.links.new(node.outputs[0], tree.nodes["Material Output"].inputs["Surface"])
    return mat, node


def test_conversion_keeps_the_render_and_comes_back_exactly(addon):
    scene = bpy.context.scene
    setup_render(scene, 16, 16)
    mat, node = principled_material("Gold", (0.9, 0.6, 0.2), 0.7, 0.3)
    coords = mat.node_tree.nodes.new("ShaderNodeTexCoord")  # a roughness ramp stays linked
    tex = mat.node_tree.nodes.new("ShaderNodeSeparateXYZ")
    mat.node_tree.links.new(coords.outputs["UV"], tex.inputs["Vector"])
    mat.node_tree.links.new(tex.outputs["X"], node.inputs["Roughness"])
    add_plane(mat)
    add_sun(scene, 3.0, tilt_deg=20.0)
    scene.bo2.indirect.use = False
    scene.render.filter_size = 0.01
    before = render_pixels(scene, "BO2_LIGHTING", samples=1)
    convert.to_bo2(mat)
    surface = convert.surface_node(mat)[2]
    assert node_groups.is_bo2_material_node(surface)
    assert surface.inputs["Albedo"].links[0].from_node.node_tree.name == \
        node_groups.PRINCIPLED_GROUP
    after = render_pixels(scene, "BO2_LIGHTING", samples=1)
    np.testing.assert_allclose(after, before, atol=1e-4)
    convert.to_principled(mat)
    back = convert.surface_node(mat)[2]
    assert back.type == "BSDF_PRINCIPLED"
    assert back.inputs["Metallic"].default_value == pytest.approx(0.7)
    assert back.inputs["Roughness"].links[0].from_node == tex
    assert not any(n.type == "GROUP" for n in mat.node_tree.nodes)
    np.testing.assert_allclose(render_pixels(scene, "BO2_LIGHTING", samples=1), before,
                               atol=1e-6)


@pytest.mark.parametrize("values", PRINCIPLED[:4], ids=[f"case{k}" for k in range(4)])
def test_constant_talk_values_invert_to_the_same_talk_values(values):
    base, metallic, rough, ior, level, tint, transmission = values
    if transmission or ior != 1.5 and metallic < 1.0:
        ior, level, tint, transmission = 1.5, 0.5, (1.0, 1.0, 1.0), 0.0
    args = [np.array([base]), np.array([[metallic]]), np.array([[rough]]), np.array([[ior]]),
            np.array([[level]]), np.array([tint]), np.array([[0.0]])]
    albedo, rf0, gloss = principled_to_talk(*args)
    p = convert.invert(albedo[0], rf0[0], float(gloss.reshape(-1)[0]))
    again = principled_to_talk(np.array([p["Base Color"][:3]]), np.array([[p["Metallic"]]]),
                               np.array([[p["Roughness"]]]), np.array([[1.5]]),
                               np.array([[p["Specular IOR Level"]]]),
                               np.array([p["Specular Tint"][:3]]), np.array([[0.0]]))
    for a, b in zip((albedo, rf0, gloss), again, strict=True):
        np.testing.assert_allclose(b, a, atol=2e-3)


def test_every_asset_has_a_preview_rendered_by_bo2(empty_scene):
    """The Asset Browser's thumbnails: a 128 px sphere per group, lit (not Blender's icon)."""
    for name, tree in load_library().items():
        preview = tree.preview
        assert preview is not None and tuple(preview.image_size) == (128, 128), name
        px = np.array(preview.image_pixels_float[:]).reshape(128, 128, 4)
        covered = px[..., 3] > 0.5
        assert 0.3 < covered.mean() < 0.9, name  # the sphere, on a transparent film
        assert px[covered, :3].std() > 0.05, name  # shaded, not flat
