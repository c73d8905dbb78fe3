"""BO2 Material and BO2 Gloss to Roughness: the groups built from their specs, and Cycles renders.

Independent values: the closed form r = (2 / (8192^g + 2))^(1/4) evaluated in NumPy at each
pixel's UV centre; a Lambert plane under a sun, a S / pi; emission colour times strength; the
world colour seen through Alpha 0; and the core's reference direct BRDF
(``brdf.direct_brdf(..., model="reference")``) for a glossy plane under a sun. Cycles renders
one sample per pixel with a 0.01-pixel filter, so a pixel is the shading at its centre.
"""

import math

import bpy
import numpy as np
import pytest
from util import bare_material

from bo2_lighting.addon.blender import images, node_groups, operators
from bo2_lighting.addon.core.formulas import brdf

MATERIAL_INPUTS = [
    ("Albedo", "NodeSocketColor", (0.8, 0.8, 0.8, 1.0)),
    ("Specular Color", "NodeSocketColor", (0.04, 0.04, 0.04, 1.0)),
    ("Gloss", "NodeSocketFloat", 0.5),
    ("Normal", "NodeSocketVector", (0.0, 0.0, 0.0)),
    ("Emission", "NodeSocketColor", (0.0, 0.0, 0.0, 1.0)),
    ("Emission Strength", "NodeSocketFloat", 1.0),
    ("Alpha", "NodeSocketFloat", 1.0),
]


@pytest.fixture
def fresh(empty_scene):
    """Factory settings, empty scene (conftest's ``empty_scene``)."""
    return empty_scene


@pytest.fixture
def node_operators(empty_scene):
    """The two node group operators registered, without the rest of the add-on."""
    classes = [operators.NODE_OT_bo2_add_material, operators.MATERIAL_OT_bo2_new]
    for cls in classes:
        bpy.utils.register_class(cls)
    yield empty_scene
    for cls in reversed(classes):
        bpy.utils.unregister_class(cls)


def sockets(tree, in_out):
    return [s for s in tree.interface.items_tree
            if s.item_type == "SOCKET" and s.in_out == in_out]


def test_groups_have_the_specified_sockets(fresh):
    material = node_groups.ensure_group("BO2 Material")
    gloss = bpy.data.node_groups["BO2 Gloss to Roughness"]
    assert node_groups.GROUP_NAMES[:2] == ("BO2 Gloss to Roughness", "BO2 Material")
    assert material.bl_idname == "ShaderNodeTree" and material.name == "BO2 Material"

    inputs = sockets(material, "INPUT")
    assert [s.name for s in inputs] == [name for name, _, _ in MATERIAL_INPUTS]
    for sock, (name, kind, default) in zip(inputs, MATERIAL_INPUTS, strict=True):
        assert sock.socket_type == kind, name
        value = sock.default_value
        assert np.allclose(tuple(value) if np.ndim(default) else value, default), name
        assert sock.hide_value == (name == "Normal"), name
    by_name = {s.name: s for s in inputs}
    for name in ("Gloss", "Alpha"):
        assert (by_name[name].min_value, by_name[name].max_value) == (0.0, 1.0)
    outputs = sockets(material, "OUTPUT")
    assert [(s.name, s.socket_type) for s in outputs] == [("BSDF", "NodeSocketShader")]

    assert [(s.name, s.socket_type) for s in sockets(gloss, "INPUT")] == [
        ("Gloss", "NodeSocketFloat")
    ]
    assert sockets(gloss, "INPUT")[0].default_value == pytest.approx(0.5)
    assert [(s.name, s.socket_type) for s in sockets(gloss, "OUTPUT")] == [
        ("Roughness", "NodeSocketFloat")
    ]
    # The material group computes its roughness with the gloss group.
    inner = [n for n in material.nodes if n.bl_idname == "ShaderNodeGroup"]
    assert [n.node_tree for n in inner] == [gloss]
    specular = next(n for n in material.nodes if n.bl_idname == "ShaderNodeBsdfMetallic")
    assert (specular.fresnel_type, specular.distribution) == ("F82", "BECKMANN")
    assert tuple(specular.inputs["Edge Tint"].default_value) == (1.0, 1.0, 1.0, 1.0)
    diffuse = next(n for n in material.nodes if n.bl_idname == "ShaderNodeBsdfDiffuse")
    for bsdf in (diffuse, specular):
        links = bsdf.inputs["Normal"].links
        assert [(ln.from_node.bl_idname, ln.from_socket.name) for ln in links] == [
            ("NodeGroupInput", "Normal")
        ]


def test_ensure_group_is_idempotent_and_keeps_user_edits(fresh):
    first = node_groups.ensure_group("BO2 Material")
    count = len(bpy.data.node_groups)
    assert count == 2
    assert node_groups.ensure_group("BO2 Material") == first
    assert node_groups.ensure_group("BO2 Gloss to Roughness").name == "BO2 Gloss to Roughness"
    assert len(bpy.data.node_groups) == count

    # A user edit: a changed default and an extra node. Both survive.
    albedo = next(s for s in sockets(first, "INPUT") if s.name == "Albedo")
    albedo.default_value = (0.1, 0.2, 0.3, 1.0)
    first.nodes.new("ShaderNodeValue").name = "User Value"
    again = node_groups.ensure_group("BO2 Material")
    assert again == first and len(bpy.data.node_groups) == count
    assert "User Value" in again.nodes
    assert tuple(albedo.default_value) == pytest.approx((0.1, 0.2, 0.3, 1.0))

    with pytest.raises(KeyError):
        node_groups.ensure_group("Not A BO2 Group")


def test_ensure_group_when_another_tree_holds_the_name(fresh):
    bpy.data.node_groups.new("BO2 Material", "GeometryNodeTree")
    tree = node_groups.ensure_group("BO2 Material")
    assert tree.bl_idname == "ShaderNodeTree" and tree.name == "BO2 Material.001"
    assert node_groups.ensure_group("BO2 Material") == tree
    assert len(bpy.data.node_groups) == 3


def test_is_bo2_material_node(fresh):
    mat = node_groups.new_material()
    tree = mat.node_tree
    node = next(n for n in tree.nodes if n.bl_idname == "ShaderNodeGroup")
    assert node_groups.is_bo2_material_node(node)
    node.node_tree = node.node_tree.copy()  # "BO2 Material.001"
    assert node.node_tree.name == "BO2 Material.001"
    assert node_groups.is_bo2_material_node(node)
    node.node_tree = node_groups.ensure_group("BO2 Gloss to Roughness")
    assert not node_groups.is_bo2_material_node(node)
    assert not node_groups.is_bo2_material_node(tree.nodes["Material Output"])


# --- Cycles renders ---------------------------------------------------------------------------


def setup_render(scene, res_x, res_y, world=(0.0, 0.0, 0.0)):
    """Cycles, 1 sample at pixel centres, an orthographic camera 2 m wide looking down -Z."""
    scene.render.engine = "CYCLES"
    scene.cycles.device = "CPU"
    scene.cycles.samples = 1
    scene.cycles.use_adaptive_sampling = False
    scene.cycles.use_denoising = False
    scene.cycles.filter_width = 0.01
    scene.render.resolution_x, scene.render.resolution_y = res_x, res_y
    scene.render.resolution_percentage = 100
    scene.render.film_transparent = False
    scene.view_settings.view_transform = "Standard"
    scene.view_settings.look = "None"
    scene.view_settings.exposure = 0.0
    scene.view_settings.gamma = 1.0
    cam_data = bpy.data.cameras.new("Camera")
    cam_data.type = "ORTHO"
    cam_data.ortho_scale = 2.0
    cam = bpy.data.objects.new("Camera", cam_data)
    cam.location = (0.0, 0.0, 1.0)
    scene.collection.objects.link(cam)
    scene.camera = cam
    wld = bpy.data.worlds.new("World")
    if wld.node_tree is None:  # 4.5
        wld.use_nodes = True
    wld.node_tree.nodes["Background"].inputs["Color"].default_value = (*world, 1.0)
    wld.node_tree.nodes["Background"].inputs["Strength"].default_value = 1.0
    scene.world = wld


def add_plane(mat):
    """A 2 m plane at z = 0 (UV 0..1 across it) filling the camera's width."""
    bpy.ops.mesh.primitive_plane_add(size=2.0)
    obj = bpy.context.object
    obj.data.materials.append(mat)
    return obj


def add_sun(scene, strength, tilt_deg=0.0):
    """A sun of ``strength`` W/m^2, tilted about X; returns the unit direction to it."""
    data = bpy.data.lights.new("Sun", "SUN")
    data.energy = strength
    data.angle = 0.0
    sun = bpy.data.objects.new("Sun", data)
    sun.rotation_euler = (math.radians(tilt_deg), 0.0, 0.0)
    scene.collection.objects.link(sun)
    t = math.radians(tilt_deg)
    return np.array([0.0, -math.sin(t), math.cos(t)])


def bo2_material(**values):
    """A material whose surface is BO2 Material with the given input values."""
    mat = node_groups.new_material("Test")
    node = next(n for n in mat.node_tree.nodes if node_groups.is_bo2_material_node(n))
    for name, value in values.items():
        node.inputs[name].default_value = value
    return mat


def render(scene):
    """Render, save the Render Result as 32-bit float EXR and load it: (H, W, 4), row 0 bottom."""
    assert bpy.ops.render.render() == {"FINISHED"}
    return images.render_result_pixels(scene)[::-1].astype(np.float64)


def test_gloss_to_roughness_in_cycles_matches_the_closed_form(fresh):
    scene = fresh
    res_x, res_y = 64, 4
    setup_render(scene, res_x, res_y)
    mat, tree = bare_material("Gloss ramp")
    output = tree.nodes["Material Output"]
    coords = tree.nodes.new("ShaderNodeTexCoord")
    split = tree.nodes.new("ShaderNodeSeparateXYZ")
    group = tree.nodes.new("ShaderNodeGroup")
    group.node_tree = node_groups.ensure_group("BO2 Gloss to Roughness")
    pack = tree.nodes.new("ShaderNodeCombineXYZ")
    emit = tree.nodes.new("ShaderNodeEmission")
    tree.links.new(coords.outputs["UV"], split.inputs["Vector"])
    tree.links.new(split.outputs["X"], group.inputs["Gloss"])
    # R = the gloss Cycles used, G = its roughness.
    tree.links.new(split.outputs["X"], pack.inputs["X"])
    tree.links.new(group.outputs["Roughness"], pack.inputs["Y"])
    tree.links.new(pack.outputs["Vector"], emit.inputs["Color"])
    tree.links.new(emit.outputs["Emission"], output.inputs["Surface"])
    add_plane(mat)

    px = render(scene)
    gloss_centre = (np.arange(res_x) + 0.5) / res_x
    expected = (2.0 / (8192.0 ** gloss_centre + 2.0)) ** 0.25
    assert np.allclose(expected, brdf.gloss_to_roughness(gloss_centre), atol=1e-6)
    assert np.abs(px[..., 0] - gloss_centre).max() < 1e-4
    err = np.abs(px[..., 1] - expected).max()
    print(f"gloss ramp: max |r - closed form at UV centre| {err:.3g}, "
          f"max |u - UV centre| {np.abs(px[..., 0] - gloss_centre).max():.3g}")
    assert err < 1e-4, err
    # Against the gloss Cycles actually shaded, the group is exact to float32 precision.
    exact = (2.0 / (8192.0 ** px[..., 0] + 2.0)) ** 0.25
    assert np.abs(px[..., 1] - exact).max() < 2e-6


def beckmann_head_on(tilt_deg, rf0, gloss):
    """Cycles' Metallic BSDF (Beckmann, Smith, F82 Tint = Schlick) times n.l, view along n.

    Independent closed form: Beckmann D(h) = exp(-tan^2 / m^2) / (pi m^2 cos^4) with
    m = r^2 and r = (2 / (8192^g + 2))^(1/4); height-correlated Smith
    G = 1 / (1 + Lambda(l) + Lambda(v)) (Heitz 2014) with Walter et al. 2007's rational
    Beckmann Lambda; Schlick F on l.h; f (n.l) = D G F / (4 n.v), n.v = 1.
    """
    t = math.radians(tilt_deg)
    m = math.sqrt(2.0 / (8192.0**gloss + 2.0))
    th = t / 2.0  # the half vector halves the angle between l and v = n
    d = math.exp(-math.tan(th) ** 2 / m**2) / (math.pi * m**2 * math.cos(th) ** 4)
    lam = 0.0
    if t > 0.0:
        a = 1.0 / (m * math.tan(t))
        if a < 1.6:
            lam = (1.0 - 1.259 * a + 0.396 * a * a) / (3.535 * a + 2.181 * a * a)
    f = np.asarray(rf0) + (1.0 - np.asarray(rf0)) * (1.0 - math.cos(th)) ** 5
    return d / (1.0 + lam) * f / 4.0


@pytest.mark.parametrize("tilt", [0.0, 60.0])
def test_lambert_diffuse_with_zero_specular(fresh, tilt):
    """Specular Color 0, gloss 0: a sun of strength S at angle t renders a S cos(t) / pi.

    Schlick's F is 0 at l.h = 1 (head-on). At t = 60 degrees F = (1 - cos 30 degrees)^5 =
    4.3e-5 leaves a specular residual: 5.1e-6 S in Cycles' Beckmann (2.7e-6 S in the model).
    """
    scene = fresh
    setup_render(scene, 4, 4)
    albedo = np.array([0.2, 0.5, 0.8])
    strength = 3.0
    add_plane(bo2_material(**{"Albedo": (*albedo, 1.0), "Specular Color": (0, 0, 0, 1),
                              "Gloss": 0.0}))
    to_sun = add_sun(scene, strength, tilt)
    px = render(scene)[..., :3]
    lambert = albedo * strength * math.cos(math.radians(tilt)) / math.pi
    residual = px - lambert
    print(f"diffuse tilt {tilt}: Cycles {px[0, 0]}, a S cos / pi {lambert}, "
          f"residual {np.abs(residual).max():.3g}")
    assert np.allclose(residual, beckmann_head_on(tilt, np.zeros(3), 0.0) * strength,
                       rtol=0, atol=2e-7)
    n = v = np.array([0.0, 0.0, 1.0])
    _, spec = brdf.direct_brdf(n, v, to_sun, albedo, np.zeros(3), 0.0, model="reference")
    assert np.abs(residual).max() < 2e-5 and np.all(spec * strength < 1e-5)
    if tilt == 0.0:
        assert np.abs(residual).max() < 1e-6


def test_emission(fresh):
    scene = fresh
    setup_render(scene, 4, 4)
    add_plane(bo2_material(**{"Albedo": (0, 0, 0, 1), "Specular Color": (0, 0, 0, 1),
                              "Emission": (0.2, 0.4, 0.6, 1.0), "Emission Strength": 2.0}))
    px = render(scene)[..., :3]
    assert np.allclose(px, [0.4, 0.8, 1.2], atol=1e-5)


def test_alpha_zero_shows_the_world(fresh):
    scene = fresh
    world = (0.3, 0.6, 0.1)
    setup_render(scene, 4, 4, world=world)
    add_plane(bo2_material(**{"Alpha": 0.0, "Emission": (1, 1, 1, 1)}))
    add_sun(scene, 5.0)
    px = render(scene)
    assert np.allclose(px[..., :3], world, atol=1e-5)
    assert np.allclose(px[..., 3], 1.0)


# Cycles (Beckmann NDF, Smith masking) against the model (Blinn-Phong, Schlick-Smith) for
# gloss 0.2, rf0 = 1, view along the normal, sun tilted by t. Measured relative differences,
# the same in 4.5 and 5.0: t = 0: 1.4e-7 (both NDFs peak at (alpha + 2) / (8 pi), both
# visibilities are 1); t = 30 degrees: 0.126; t = 60 degrees: 0.534 (Cycles brighter: its
# Beckmann D is 1.11 and its Smith G / (n.l) 1.38 times the model's terms there).
GLOSSY_BOUNDS = {0.0: 1e-5, 30.0: 0.15, 60.0: 0.6}


def test_connected_normal_is_used(fresh):
    """Normal tilted by 60 degrees, head-on sun and view: a S cos(60) / pi (F = 0 at l.h = 1)."""
    scene = fresh
    setup_render(scene, 4, 4)
    albedo = np.array([0.2, 0.5, 0.8])
    mat = bo2_material(**{"Albedo": (*albedo, 1.0), "Specular Color": (0, 0, 0, 1)})
    tree = mat.node_tree
    normal = tree.nodes.new("ShaderNodeCombineXYZ")
    t = math.radians(60.0)
    normal.inputs["Y"].default_value = math.sin(t)
    normal.inputs["Z"].default_value = math.cos(t)
    group = next(n for n in tree.nodes if node_groups.is_bo2_material_node(n))
    tree.links.new(normal.outputs["Vector"], group.inputs["Normal"])
    add_plane(mat)
    add_sun(scene, 3.0)
    px = render(scene)[..., :3]
    assert np.allclose(px, albedo * 3.0 * 0.5 / math.pi, rtol=1e-5, atol=0)


@pytest.mark.parametrize("tilt", sorted(GLOSSY_BOUNDS))
def test_glossy_specular_against_the_reference_model(fresh, tilt):
    scene = fresh
    setup_render(scene, 4, 4)
    strength = 2.0
    add_plane(bo2_material(**{"Albedo": (0, 0, 0, 1), "Specular Color": (1, 1, 1, 1),
                              "Gloss": 0.2}))
    to_sun = add_sun(scene, strength, tilt)
    px = render(scene)[..., :3]
    # The group is Beckmann with m = r^2 and Schlick Fresnel, to float32 precision ...
    cycles = beckmann_head_on(tilt, np.ones(3), 0.2) * strength
    print(f"glossy tilt {tilt}: Cycles / Beckmann closed form - 1: {(px / cycles - 1).max():.3g}")
    assert np.abs(px / cycles - 1.0).max() < 1e-5
    # ... and the talk's reference model differs from it by its NDF and visibility.
    n = v = np.array([0.0, 0.0, 1.0])
    _, spec = brdf.direct_brdf(n, v, to_sun, np.zeros(3), np.ones(3), 0.2, model="reference")
    expected = spec * strength
    rel = np.abs(px / expected - 1.0).max()
    print(f"glossy tilt {tilt}: Cycles {px[0, 0]}, model {expected}, rel. diff. {rel:.3g}")
    assert rel < GLOSSY_BOUNDS[tilt], rel


# --- Operators ----------------------------------------------------------------------------------


def test_new_material_operator(node_operators):
    bpy.ops.mesh.primitive_plane_add()
    obj = bpy.context.object
    assert bpy.ops.material.bo2_new() == {"FINISHED"}
    mat = obj.active_material
    assert mat is not None and len(obj.material_slots) == 1
    output = next(n for n in mat.node_tree.nodes if n.bl_idname == "ShaderNodeOutputMaterial")
    links = output.inputs["Surface"].links
    assert len(links) == 1 and node_groups.is_bo2_material_node(links[0].from_node)
    assert links[0].from_socket.name == "BSDF"
    # A second call replaces the material of the active slot and reuses the groups.
    assert bpy.ops.material.bo2_new() == {"FINISHED"}
    assert len(obj.material_slots) == 1 and obj.active_material != mat
    assert len(bpy.data.node_groups) == 2


class ReportStub:
    """Stands in for an operator instance: collects ``report()`` calls."""

    def __init__(self):
        self.reports = []

    def report(self, kind, message):
        self.reports.append((kind, message))


def test_new_material_operator_errors(node_operators):
    assert bpy.context.object is None
    stub = ReportStub()
    assert operators.MATERIAL_OT_bo2_new.execute(stub, bpy.context) == {"CANCELLED"}
    assert stub.reports == [({"ERROR"}, "New BO2 Material: no active object")]
    # Through bpy.ops, Blender turns the error report into a RuntimeError.
    with pytest.raises(RuntimeError, match="no active object"):
        bpy.ops.material.bo2_new()

    empty = bpy.data.objects.new("Empty", None)
    bpy.context.scene.collection.objects.link(empty)
    bpy.context.view_layer.objects.active = empty
    stub = ReportStub()
    assert operators.MATERIAL_OT_bo2_new.execute(stub, bpy.context) == {"CANCELLED"}
    assert len(stub.reports) == 1 and "'Empty' (EMPTY)" in stub.reports[0][1]
    with pytest.raises(RuntimeError, match="cannot have materials"):
        bpy.ops.material.bo2_new()
    assert len(bpy.data.materials) == 0


def test_add_material_operator(node_operators):
    bpy.ops.mesh.primitive_plane_add()
    obj = bpy.context.object
    # No material: nothing to add to.
    assert not bpy.ops.node.bo2_add_material.poll()
    mat = bpy.data.materials.new("Plain")
    if mat.node_tree is None:
        mat.use_nodes = True
    obj.data.materials.append(mat)
    before = len(mat.node_tree.nodes)
    assert bpy.ops.node.bo2_add_material() == {"FINISHED"}
    assert len(mat.node_tree.nodes) == before + 1
    node = mat.node_tree.nodes.active
    assert node_groups.is_bo2_material_node(node) and node.select
    assert bpy.ops.node.bo2_add_material() == {"FINISHED"}
    assert len(bpy.data.node_groups) == 2
    # The same operator adds the other groups of the Add menu.
    for name in node_groups.ENV_BRDF_GROUPS.values():
        assert bpy.ops.node.bo2_add_material(group=name) == {"FINISHED"}
        node = mat.node_tree.nodes.active
        assert node.node_tree.name == name and "Color" in node.outputs


def test_add_material_refuses_recursion(fresh):
    group = node_groups.ensure_group("BO2 Material")
    with pytest.raises(ValueError):
        node_groups.add_material_node(group)
    with pytest.raises(ValueError):
        node_groups.add_material_node(node_groups.ensure_group("BO2 Gloss to Roughness"))


def test_add_menu_entry(fresh):
    menu = getattr(bpy.types, "NODE_MT_add", None)
    assert menu is not None
    node_groups.append_menus()
    try:
        assert node_groups.draw_add_menu in menu._dyn_ui_initialize()
    finally:
        node_groups.remove_menus()
    assert node_groups.draw_add_menu not in menu._dyn_ui_initialize()
