"""The environment BRDF node groups, rendered by Cycles, against ``core.formulas.env_brdf``.

An emission plane fills an orthographic view; its colour is a group's output, with gloss
running across the image and n.v up it (one value per pixel, from the UV map), and rf0 = 0,
0.04 and 1 in the red, green and blue channels. Every pixel must equal the engine's value
within 1e-3. A second scene checks the "from the geometry" n.v on a sphere.
"""

import math

import bpy
import numpy as np
import pytest
from util import add_ortho_camera, bare_material, render_pixels, set_world_color

from bo2_lighting.addon.blender import node_groups
from bo2_lighting.addon.core.formulas import env_brdf

W, H = 40, 30
RF0 = (0.0, 0.04, 1.0)


def emission_material(name: str):
    mat, tree = bare_material(name)
    emission = tree.nodes.new("ShaderNodeEmission")
    tree.links.new(emission.outputs[0], tree.nodes["Material Output"].inputs["Surface"])
    group = tree.nodes.new("ShaderNodeGroup")
    group.node_tree = node_groups.ensure_group(name)
    group.inputs["Specular Color"].default_value = (*RF0, 1.0)
    tree.links.new(group.outputs["Color"], emission.inputs["Color"])
    return mat, group


def exact_scene(res=(W, H)):
    scene = bpy.context.scene
    scene.render.resolution_x, scene.render.resolution_y = res
    scene.render.resolution_percentage = 100
    scene.render.filter_size = 0.01  # each pixel sees its centre only
    scene.view_settings.view_transform = "Standard"
    set_world_color(scene)
    return scene


def grid_material(name: str):
    """Gloss = column / (W - 1), n.v = row / (H - 1) (clamped by the group), from the UVs."""
    mat, group = emission_material(name)
    tree = mat.node_tree
    coords = tree.nodes.new("ShaderNodeTexCoord")
    split = tree.nodes.new("ShaderNodeSeparateXYZ")
    tree.links.new(coords.outputs["UV"], split.inputs["Vector"])
    for axis, count, socket in (("X", W, "Gloss"), ("Y", H, "NoV")):
        cell = tree.nodes.new("ShaderNodeMath")
        cell.operation = "MULTIPLY"
        cell.inputs[1].default_value = float(count)
        tree.links.new(split.outputs[axis], cell.inputs[0])
        index = tree.nodes.new("ShaderNodeMath")
        index.operation = "FLOOR"
        tree.links.new(cell.outputs[0], index.inputs[0])
        value = tree.nodes.new("ShaderNodeMath")
        value.operation = "DIVIDE"
        value.inputs[1].default_value = float(count - 1)
        tree.links.new(index.outputs[0], value.inputs[0])
        tree.links.new(value.outputs[0], group.inputs[socket])
    return mat


@pytest.mark.parametrize("model", sorted(node_groups.ENV_BRDF_GROUPS))
def test_group_matches_the_engine_per_pixel(addon, model):
    scene = exact_scene()
    add_ortho_camera(scene, scale=2.0)
    bpy.ops.mesh.primitive_plane_add(size=1.0)
    plane = bpy.context.object
    plane.scale = (2.0, 1.5, 1.0)  # the camera's 4:3 view exactly
    plane.data.materials.append(grid_material(node_groups.ENV_BRDF_GROUPS[model]))
    px = render_pixels(scene, "CYCLES", samples=1)[..., :3]  # row 0 at the bottom
    gloss = np.arange(W) / (W - 1)
    n_dot_v = np.arange(H) / (H - 1)
    g, nv = np.meshgrid(gloss, n_dot_v)  # (H, W), row 0 = n.v 0 = the bottom row
    expected = env_brdf.environment_brdf(g[..., None], nv[..., None], np.array(RF0), model)
    err = np.abs(px - expected)
    print(f"{model}: max |Cycles - engine| = {err.max():.2e}")
    assert err.max() < 1e-3


def test_group_takes_n_dot_v_from_the_geometry(addon):
    """NoV left negative: n.v of the shading normal and the view, on an orthographic sphere
    whose n.v at a pixel is sqrt(1 - r^2) (r: distance from the centre in radii)."""
    scene = exact_scene(res=(48, 48))
    add_ortho_camera(scene, scale=2.2, height=3.0)
    bpy.ops.mesh.primitive_uv_sphere_add(segments=256, ring_count=128, radius=1.0)
    bpy.ops.object.shade_smooth()
    mat, group = emission_material(node_groups.ENV_BRDF_GROUPS["bo2"])
    group.inputs["Gloss"].default_value = 0.7
    bpy.context.object.data.materials.append(mat)
    px = render_pixels(scene, "CYCLES", samples=1)[..., :3]
    centres = (np.arange(48) + 0.5) / 48 * 2.2 - 1.1
    x, y = np.meshgrid(centres, centres)
    r2 = x * x + y * y
    inside = r2 < 0.8**2  # away from the silhouette, where the facets' normals are exact
    expected = env_brdf.environment_brdf(0.7, np.sqrt(1.0 - r2[inside])[:, None],
                                         np.array(RF0), "bo2")
    err = np.abs(px[inside] - expected)
    print(f"geometry n.v: max |Cycles - engine| = {err.max():.2e} over {inside.sum()} px")
    assert err.max() < 2e-3
    assert math.isclose(float(px[24, 24, 2]), 0.25 * 0.7 + 0.75, abs_tol=1e-3)  # rf0 = 1: a1
