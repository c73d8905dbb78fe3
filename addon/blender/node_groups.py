"""Shader node groups of BO2 Lighting, built from the data specs in ``node_groups/``.

**BO2 Material** is the closest Cycles/EEVEE match of the talk's model (Lazarov 2013, slide
"Black Ops: shading model"): a Lambert diffuse (Diffuse BSDF, roughness 0) *added* to the
microfacet specular, as the talk does not energy-balance the two, plus emission, with Alpha
mixing in a Transparent BSDF. The specular is a Metallic BSDF:

- Fresnel type F82 Tint with Base Color = rf0 and tint white. Cycles' F82-Tint is
  ``F = Schlick(rf0, l.h) - b (l.h)(1 - l.h)^6`` with ``b`` proportional to ``1 - tint``
  (``fresnel_f82tint_B`` in Cycles' ``bsdf_util.h``), so a white tint makes ``b = 0`` and ``F``
  exactly the talk's Schlick Fresnel (slide "Black Ops: reflectance function"). The Glossy
  BSDF has no Fresnel, and the Principled BSDF's dielectric Fresnel is not Schlick's.
- Beckmann distribution: the talk's Blinn-Phong NDF is a "cheaper replacement for Beckmann NDF
  (with parameter conversion)" (slide "Black Ops: normal distribution function"). Cycles'
  Beckmann width is ``r^2`` for roughness ``r``, and **BO2 Gloss to Roughness** gives
  ``r = (2 / (8192^g + 2))^(1/4)`` (``brdf.gloss_to_roughness``), so ``r^2`` is the Beckmann
  ``m = sqrt(2 / (alpha + 2))`` of the power ``alpha = 8192^g`` (Walter et al. 2007). Both
  NDFs then peak at ``(alpha + 2) / (2 pi)`` and both visibilities are 1 at normal incidence,
  so with view and light along the normal Cycles renders the model exactly; away from it the
  Beckmann tail and Smith masking (against Blinn-Phong and Schlick-Smith) make Cycles brighter,
  by 13% for a light 30 degrees off the normal and 53% at 60 degrees (gloss 0.2, normal view;
  see tests/blender/test_node_groups.py). EEVEE uses GGX whatever the distribution.

``ensure_group`` builds a group from its spec only when the file has none: a group of the same
name that the user edited (or an older build) is reused as it is, never overwritten. To get
the current spec back, delete or rename the group and call ``ensure_group`` again.
"""

import json
from pathlib import Path

import bpy

SPEC_DIR = Path(__file__).resolve().parents[2] / "node_groups"
"""Folder of the group specs; the extension ships ``node_groups/`` next to ``addon/``."""

GLOSS_GROUP = "BO2 Gloss to Roughness"
MATERIAL_GROUP = "BO2 Material"
PRINCIPLED_GROUP = "BO2 Principled to Talk"
ENV_BRDF_GROUPS = {"bo2": "BO2 Environment BRDF", "bo1": "BO2 Environment BRDF (BO1)",
                   "fit": "BO2 Environment BRDF (Fit)"}
"""Environment BRDF group of each analytic model of ``core.formulas.env_brdf`` (specs written by
``tools/make_env_brdf_groups.py``)."""
GROUP_NAMES = (GLOSS_GROUP, MATERIAL_GROUP, *ENV_BRDF_GROUPS.values(), PRINCIPLED_GROUP)
"""Names of the groups, dependencies first."""

_SPEC_FILES = {
    GLOSS_GROUP: "bo2_gloss_to_roughness.json",
    MATERIAL_GROUP: "bo2_material.json",
    ENV_BRDF_GROUPS["bo2"]: "bo2_env_brdf.json",
    ENV_BRDF_GROUPS["bo1"]: "bo2_env_brdf_bo1.json",
    ENV_BRDF_GROUPS["fit"]: "bo2_env_brdf_fit.json",
    PRINCIPLED_GROUP: "bo2_principled_to_talk.json",
}
_TAG = "bo2_node_group"  # ID property that marks a tree built here; its value is the group name
SHADER_TREE = "ShaderNodeTree"
MATERIAL_OBJECT_TYPES = {"MESH", "CURVE", "SURFACE", "META", "FONT"}


def load_spec(name: str) -> dict:
    """The spec of group ``name`` as stored in ``node_groups/`` (a dict loaded from JSON)."""
    if name not in _SPEC_FILES:
        raise KeyError(f"unknown node group {name!r}; expected one of: {', '.join(GROUP_NAMES)}")
    with open(SPEC_DIR / _SPEC_FILES[name], encoding="utf-8") as fh:
        return json.load(fh)


def _find_existing(name: str):
    tree = bpy.data.node_groups.get(name)
    if tree is not None and tree.bl_idname == SHADER_TREE:
        return tree
    # One built here under a suffixed name ("BO2 Material.001") while another tree held the name.
    for tree in bpy.data.node_groups:
        if (tree.bl_idname == SHADER_TREE and tree.get(_TAG) == name
                and tree.name.startswith(name + ".")):
            return tree
    return None


def ensure_group(name: str) -> bpy.types.ShaderNodeTree:
    """The shader node group ``name`` (one of ``GROUP_NAMES``), built from its spec if missing.

    An existing shader tree of that name is returned as it is, edits included; so is one built
    here earlier under a suffixed name. Dependencies (groups used inside) are ensured first.
    """
    if name not in _SPEC_FILES:
        raise KeyError(f"unknown node group {name!r}; expected one of: {', '.join(GROUP_NAMES)}")
    tree = _find_existing(name)
    if tree is not None:
        return tree
    return _build(load_spec(name))


def _socket(sockets, key: str, where: str):
    """A node socket by identifier, else by name."""
    for sock in sockets:
        if sock.identifier == key:
            return sock
    for sock in sockets:
        if sock.name == key:
            return sock
    raise ValueError(f"{where}: no socket {key!r} (have {[s.identifier for s in sockets]})")


def _set_value(sock, value, where: str):
    if not hasattr(sock, "default_value"):
        raise ValueError(f"{where}: socket {sock.identifier!r} has no value")
    sock.default_value = value


def _add_interface(tree, item: dict) -> None:
    sock = tree.interface.new_socket(
        item["name"], in_out=item["in_out"], socket_type=item["socket_type"]
    )
    if "subtype" in item:
        sock.subtype = item["subtype"]
    if "description" in item:
        sock.description = item["description"]
    if "min" in item:
        sock.min_value = item["min"]
    if "max" in item:
        sock.max_value = item["max"]
    if "default" in item:
        sock.default_value = item["default"]
    sock.hide_value = bool(item.get("hide_value", False))


def _add_node(tree, spec: dict):
    node = tree.nodes.new(spec["bl_idname"])
    node.name = spec["name"]
    where = f"{tree.name}: node {spec['name']!r}"
    if "node_tree" in spec:
        node.node_tree = ensure_group(spec["node_tree"])
    if "label" in spec:
        node.label = spec["label"]
    for key, value in spec.get("properties", {}).items():
        setattr(node, key, value)
    for key, value in spec.get("inputs", {}).items():
        _set_value(_socket(node.inputs, key, where), value, where)
    node.location = spec.get("location", (0.0, 0.0))
    return node


def _build(spec: dict) -> bpy.types.ShaderNodeTree:
    """A new shader node group from ``spec`` (interface, nodes, links)."""
    for node in spec["nodes"]:
        if "node_tree" in node:
            ensure_group(node["node_tree"])
    tree = bpy.data.node_groups.new(spec["name"], SHADER_TREE)
    try:
        tree[_TAG] = spec["name"]
        tree.description = spec.get("description", "")
        for item in spec["interface"]:
            _add_interface(tree, item)
        nodes = {n["name"]: _add_node(tree, n) for n in spec["nodes"]}
        for link in spec["links"]:
            (src, out_key), (dst, in_key) = link["from"], link["to"]
            where = f"{tree.name}: link {src}.{out_key} -> {dst}.{in_key}"
            if src not in nodes or dst not in nodes:
                raise ValueError(f"{where}: unknown node")
            tree.links.new(
                _socket(nodes[src].outputs, out_key, where),
                _socket(nodes[dst].inputs, in_key, where),
            )
    except Exception:
        bpy.data.node_groups.remove(tree)
        raise
    return tree


def is_bo2_material_node(node) -> bool:
    """True for a group node of BO2 Material ("BO2 Material" or a duplicate "BO2 Material.001")."""
    if getattr(node, "bl_idname", None) != "ShaderNodeGroup":
        return False
    tree = node.node_tree
    if tree is None:
        return False
    return tree.name == MATERIAL_GROUP or tree.name.startswith(MATERIAL_GROUP + ".")


def add_material_node(tree, location=(0.0, 0.0), name: str = MATERIAL_GROUP):
    """Add a group node of ``name`` (BO2 Material by default) to shader tree ``tree``; returns
    the node, selected and active.

    Raises ValueError when ``tree`` is that group itself or used inside it (a recursive group).
    """
    group = ensure_group(name)
    if tree == group or group.contains_tree(tree):
        raise ValueError(f"cannot add '{group.name}' inside '{tree.name}': it would contain itself")
    for n in tree.nodes:
        n.select = False
    node = tree.nodes.new("ShaderNodeGroup")
    node.node_tree = group
    node.width = 200.0
    node.location = location
    node.select = True
    tree.nodes.active = node
    return node


def new_material(name: str = MATERIAL_GROUP) -> bpy.types.Material:
    """A new material whose surface is a BO2 Material group node linked to the Material Output."""
    mat = bpy.data.materials.new(name)
    if mat.node_tree is None:  # Blender 4.5; 5.0 materials always have a node tree
        mat.use_nodes = True
    tree = mat.node_tree
    for node in list(tree.nodes):
        if node.bl_idname != "ShaderNodeOutputMaterial":
            tree.nodes.remove(node)
    output = next(iter(tree.nodes), None) or tree.nodes.new("ShaderNodeOutputMaterial")
    output.location = (300.0, 0.0)
    node = add_material_node(tree, (0.0, 0.0))
    tree.links.new(node.outputs["BSDF"], output.inputs["Surface"])
    return mat


ADD_OPERATOR = "node.bo2_add_material"  # operators.NODE_OT_bo2_add_material


def draw_add_menu(self, context):
    """Entry of the Shader Editor's Add menu (appended to ``NODE_MT_add``)."""
    space = context.space_data
    if space is None or space.tree_type != SHADER_TREE:
        return
    layout = self.layout
    layout.separator()
    props = layout.operator(ADD_OPERATOR, text="BO2 Material",
                            icon="NODE_MATERIAL")
    props.use_transform = True
    for name in (*ENV_BRDF_GROUPS.values(), GLOSS_GROUP):
        props = layout.operator(ADD_OPERATOR, text=name, icon="NODETREE")
        props.group, props.use_transform = name, True


_ADD_MENU = "NODE_MT_add"


def append_menus() -> None:
    """Append ``draw_add_menu`` to the Add menu, when this Blender has one by that name."""
    menu = getattr(bpy.types, _ADD_MENU, None)
    if menu is not None:
        menu.append(draw_add_menu)


def remove_menus() -> None:
    """Undo ``append_menus()``."""
    menu = getattr(bpy.types, _ADD_MENU, None)
    if menu is not None:
        menu.remove(draw_add_menu)

