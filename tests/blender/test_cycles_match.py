"""BO2 Lighting against Cycles on the same scene, both rendered here.

- Glossy spheres (the BO2 Material node group, so both engines read the same material; Cycles
  renders it as Beckmann with Schlick Fresnel) under one point light: the highlight's peak
  position and its energy.
- A Principled BSDF's diffuse under its specular layer (Albedo against DiffCol).
- The Ignis evaluation box scene: renders without error; the difference against a Cycles
  direct-light-only render is printed and bounded loosely.
"""

import math
from pathlib import Path

import bpy
import numpy as np
import pytest
from util import add_ortho_camera, principled, render_passes, render_pixels, set_world_color

ROOT = Path(__file__).resolve().parents[2]
IGNIS_BOX = ROOT.parent / "shared" / "reference" / "scenes" / "ignis" / "box.blend"
RES = 96


def glossy_sphere_scene(gloss: float):
    from bo2_lighting.addon.blender import node_groups

    scene = bpy.context.scene
    scene.render.resolution_x = scene.render.resolution_y = RES
    scene.render.resolution_percentage = 100
    scene.view_settings.view_transform = "Standard"
    scene.cycles.max_bounces = 0
    bpy.ops.mesh.primitive_uv_sphere_add(segments=128, ring_count=64, radius=1.0)
    bpy.ops.object.shade_smooth()
    mat = node_groups.new_material("Glossy")
    group = next(n for n in mat.node_tree.nodes if node_groups.is_bo2_material_node(n))
    group.inputs["Albedo"].default_value = (0, 0, 0, 1)
    group.inputs["Specular Color"].default_value = (1, 1, 1, 1)
    group.inputs["Gloss"].default_value = gloss
    bpy.context.object.data.materials.append(mat)
    cam = bpy.data.objects.new("Camera", bpy.data.cameras.new("Camera"))
    cam.data.lens = 50
    cam.location = (0.0, -5.0, 0.0)
    cam.rotation_euler = (math.pi / 2, 0.0, 0.0)
    scene.collection.objects.link(cam)
    scene.camera = cam
    light = bpy.data.objects.new("Light", bpy.data.lights.new("Light", "POINT"))
    light.data.energy = 1000.0
    light.data.shadow_soft_size = 0.0
    light.location = (2.0, -4.0, 1.5)
    scene.collection.objects.link(light)
    set_world_color(scene)
    return scene


# Highlight energy bound per gloss. At gloss 0.2 the lobe is wide and Cycles' Beckmann NDF with
# Smith shadowing differs from the talk's Blinn-Phong NDF with Schlick-Smith visibility by more
# than 15% (measured: BO2/Cycles = 0.83; the engine itself matches the talk's BRDF to 0.1% at
# the peak pixel, see the closed-form test below), so that case is held to 20%.
# tools/fit_gloss_roughness.py reproduces the ratios analytically (0.834, 0.982, 1.049) and
# splits them: at 0.2, visibility 0.857 times NDF 0.972; at 0.8, the 5% excess is anti-aliasing
# (BO2 shades the pixel centre), the lobes agree to 0.4%. No Beckmann roughness brings 0.2 above
# 0.838, and GGX (at its best-fitting roughness) gives 0.92, 1.20 and 1.19.
ENERGY_BOUND = {0.2: 0.20, 0.5: 0.15, 0.8: 0.15}


@pytest.mark.parametrize("gloss", sorted(ENERGY_BOUND))
def test_glossy_highlight_matches_cycles(addon, gloss):
    scene = glossy_sphere_scene(gloss)
    ours = render_pixels(scene, "BO2_LIGHTING", samples=16)[..., :3].mean(-1)
    cycles = render_pixels(scene, "CYCLES", samples=256)[..., :3].mean(-1)
    peak_ours = np.array(np.unravel_index(np.argmax(ours), ours.shape))
    peak_cycles = np.array(np.unravel_index(np.argmax(cycles), cycles.shape))
    # Energy of the highlight: the sum over the pixels above 5% of Cycles' peak.
    region = cycles > 0.05 * cycles.max()
    ratio = ours[region].sum() / cycles[region].sum()
    offset = np.abs(peak_ours - peak_cycles).max()
    print(f"gloss {gloss}: peak offset {offset} px, highlight energy BO2/Cycles {ratio:.3f}")
    assert offset <= 2
    assert abs(ratio - 1.0) <= ENERGY_BOUND[gloss]


@pytest.mark.parametrize("gloss", [0.2, 0.8])
def test_glossy_sphere_pixels_match_the_talks_brdf(addon, gloss):
    """Pixels of the sphere against the closed form: ray-sphere intersection through each
    pixel centre, then (1/pi) D_pl F V (n.l) E with E = P / (4 pi d^2), computed here."""
    from bo2_lighting.addon.core.formulas import brdf

    scene = glossy_sphere_scene(gloss)
    scene.render.filter_size = 0.0  # one sample at each pixel centre
    ours = render_pixels(scene, "BO2_LIGHTING", samples=1)[..., 0]
    rows, cols = np.mgrid[0:RES, 0:RES]
    half = 0.5 * 36.0 / 50.0  # sensor 36 mm, lens 50 mm
    d = np.stack([((cols + 0.5) / RES - 0.5) * 2 * half, np.ones((RES, RES)),
                  ((rows + 0.5) / RES - 0.5) * 2 * half], -1)  # row 0 at the bottom
    d /= np.linalg.norm(d, axis=-1, keepdims=True)
    eye = np.array([0.0, -5.0, 0.0])
    b = d @ eye
    disc = b * b - (eye @ eye - 1.0)
    hit = disc > 0.05  # away from the silhouette
    t = -b - np.sqrt(np.maximum(disc, 0.0))
    p = eye + t[..., None] * d
    n = p / np.linalg.norm(p, axis=-1, keepdims=True)
    to_light = np.array([2.0, -4.0, 1.5]) - p
    dist2 = np.sum(to_light**2, -1)
    l_dir = to_light / np.sqrt(dist2)[..., None]
    _, spec = brdf.direct_brdf(n, -d, l_dir, np.zeros(3), np.ones(3), gloss)
    expected = spec[..., 0] * 1000.0 / (4 * np.pi * dist2)
    bright = hit & (expected > 0.05 * expected.max())
    np.testing.assert_allclose(ours[bright], expected[bright], rtol=0.02)


@pytest.mark.skipif(not IGNIS_BOX.exists(), reason="reference scenes are not available")
def test_ignis_box_renders_and_is_close_to_cycles_direct(addon):
    bpy.ops.wm.open_mainfile(filepath=str(IGNIS_BOX))
    scene = bpy.context.scene
    scene.render.resolution_percentage = 50
    scene.cycles.max_bounces = 0  # direct light only, as BO2 Lighting has no indirect yet
    ours = render_pixels(scene, "BO2_LIGHTING", samples=16)[..., :3]
    cycles = render_pixels(scene, "CYCLES", samples=128)[..., :3]
    assert np.isfinite(ours).all()
    lit = cycles.mean(-1) > 0.02
    rel = np.abs(ours - cycles).mean(-1)[lit] / cycles.mean(-1)[lit]
    rmse = float(np.sqrt(np.mean((ours - cycles) ** 2)))
    print(f"ignis box: mean relative error {rel.mean():.3f}, median {np.median(rel):.3f}, "
          f"RMSE {rmse:.4f}, mean BO2 {ours.mean():.4f} vs Cycles {cycles.mean():.4f}")
    assert lit.sum() > 0.2 * lit.size
    assert np.median(rel) < 0.25


@pytest.mark.parametrize("roughness,metallic", [(0.2, 0.0), (0.5, 0.0), (0.5, 0.5)])
def test_principled_diffuse_is_layered_under_its_specular_as_in_cycles(addon, roughness,
                                                                       metallic):
    """With Layered Diffuse, a Principled BSDF's diffuse colour, BO2's Albedo pass against
    Cycles' DiffCol (which carries its weight under the specular layer,
    ``closure_layering_weight``) on a sphere seen by an orthographic camera, where
    n.v = sqrt(1 - r^2): within 2.5% down to n.v = 0.5 and
    7% at n.v 0.25-0.4, where the talk's environment BRDF (Schlick's Fresnel, no multiple
    scattering) takes less than Cycles' GGX layer. Unlayered, the diffuse would be 7% too bright
    at n.v 0.5-0.7 and 20% at the rim; by default (the talk's sum) the Albedo is the base's
    times one less Metallic. Half metallic, the metal lies beside the diffuse, not above it:
    the diffuse's layer is the dielectric's alone."""
    scene = bpy.context.scene
    scene.render.resolution_x = scene.render.resolution_y = RES
    scene.render.resolution_percentage = 100
    scene.view_settings.view_transform = "Standard"
    scene.render.filter_size = scene.cycles.filter_width = 0.01
    scene.cycles.max_bounces = 0
    set_world_color(scene)
    bpy.ops.mesh.primitive_uv_sphere_add(segments=128, ring_count=64, radius=1.0)
    bpy.ops.object.shade_smooth()
    mat = principled("Paint", (0.8, 0.8, 0.8), roughness)
    mat.node_tree.nodes["Principled BSDF"].inputs["Metallic"].default_value = metallic
    bpy.context.object.data.materials.append(mat)
    add_ortho_camera(scene, 2.2, height=5.0)
    talk = render_passes(scene, "BO2_LIGHTING", ["Albedo"])["Albedo"][..., 0]
    scene.bo2.use_layered_diffuse = True
    ours = render_passes(scene, "BO2_LIGHTING", ["Albedo"])["Albedo"][..., 0]
    cycles = render_passes(scene, "CYCLES", ["DiffCol"])["DiffCol"][..., 0]
    rows, cols = np.mgrid[0:RES, 0:RES]
    r = np.hypot((cols + 0.5) / RES - 0.5, (rows + 0.5) / RES - 0.5) * 2.2
    n_dot_v = np.sqrt(np.clip(1.0 - r * r, 0.0, 1.0))
    for lo, hi, bound in ((0.9, 1.0, 0.025), (0.5, 0.7, 0.025), (0.25, 0.4, 0.07)):
        ring = (n_dot_v >= lo) & (n_dot_v < hi)
        ratio = ours[ring].mean() / cycles[ring].mean()
        print(f"roughness {roughness}, metallic {metallic}, n.v {lo}-{hi}: BO2 "
              f"{ours[ring].mean():.4f}, Cycles {cycles[ring].mean():.4f}, unlayered "
              f"{0.8 * (1 - metallic):.2f}")
        assert abs(ratio - 1.0) <= bound, (lo, ratio)
        # by default the talk's model: the diffuse added to the specular, unweighted
        np.testing.assert_allclose(talk[ring], 0.8 * (1.0 - metallic), rtol=1e-3)
