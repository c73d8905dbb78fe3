"""Light groups (View Layer > Passes > Light Groups; a light's, an object's and the world's
Light Group) against Cycles' light group passes.

The scene of ``test_light_linking_cycles`` without its links: the key point light in group "key",
the fill sun in "fill", an emissive card in "key", the world (a dim blue) in "env". Cycles
renders direct light only (no bounce); BO2 without probes and without its bounce without
probes, so that its indirect light is the world's alone (the probes' light, bounces
included, is counted in the world's group).
"""

import bpy
import numpy as np
import pytest
from test_light_linking_cycles import build
from util import principled, render_passes

from bo2_lighting.addon.blender import engine


def grouped_scene():
    scene = build()
    layer = bpy.context.view_layer
    for name in ("key", "fill", "env"):
        layer.lightgroups.add(name=name)
    scene.objects["Key"].lightgroup = "key"
    scene.objects["Fill"].lightgroup = "fill"
    scene.world.lightgroup = "env"
    scene.world.node_tree.nodes["Background"].inputs["Color"].default_value = (0.02, 0.03,
                                                                                0.06, 1.0)
    bpy.ops.mesh.primitive_plane_add(size=0.6, location=(0.0, -1.2, 0.02))
    card = bpy.context.object
    card.name = "Card"
    glow = principled("Glow", (0.1, 0.1, 0.1), 1.0)
    bsdf = glow.node_tree.nodes["Principled BSDF"]
    bsdf.inputs["Emission Color" if "Emission Color" in bsdf.inputs else "Emission"] \
        .default_value = (1.0, 0.4, 0.1, 1.0)
    bsdf.inputs["Emission Strength"].default_value = 2.0
    card.data.materials.append(glow)
    card.lightgroup = "key"
    scene.bo2.indirect.use_implicit_bounce = False
    return scene


def test_light_group_passes_match_cycles_and_add_up(addon):
    """Each group's pass within 5% of Cycles' (the world's within 10% over the frame), over
    the frame and over the pixels each lights most; the three add up to Combined."""
    scene = grouped_scene()
    names = [f"Combined_{g}" for g in ("key", "fill", "env")]
    ours = render_passes(scene, "BO2_LIGHTING", names + ["Combined"], samples=16)
    cycles = render_passes(scene, "CYCLES", names + ["Combined"], samples=64)
    total = sum(ours[n] for n in names)
    np.testing.assert_allclose(total, ours["Combined"][..., :3], rtol=1e-4, atol=1e-5)
    for n in names:
        a, b = ours[n], cycles[n]
        lit = b.sum(-1) > np.quantile(b.sum(-1), 0.7)
        print(f"{n}: BO2 {a.mean():.4f}, Cycles {b.mean():.4f}; where it lights most "
              f"{a[lit].mean():.4f} / {b[lit].mean():.4f}")
        # the world's light on surfaces is its SH under the dome's occlusion (6% here)
        assert a.mean() == pytest.approx(b.mean(), rel=0.1 if n.endswith("env") else 0.05), n
        assert a[lit].mean() == pytest.approx(b[lit].mean(), rel=0.05), n


def test_the_gpu_draws_light_groups_as_the_cpu(addon):
    """With the GPU chosen, the light group passes add up to Combined there too, and equal
    the CPU's (or, without a GPU context, the frame renders on the CPU and says why)."""
    scene = grouped_scene()
    names = [f"Combined_{g}" for g in ("key", "fill", "env")]
    scene.bo2.device = "CPU"
    cpu = render_passes(scene, "BO2_LIGHTING", names + ["Combined"], samples=8)
    scene.bo2.device = "GPU"
    with engine.listening() as said:
        gpu = render_passes(scene, "BO2_LIGHTING", names + ["Combined"], samples=8)
    if any("no GPU context" in t for t in said.texts()):
        return
    assert any("Rendered on the GPU" in t for t in said.texts()), said.texts()
    total = sum(gpu[n] for n in names)
    np.testing.assert_allclose(total, gpu["Combined"][..., :3], rtol=1e-3, atol=1e-4)
    for n in names:
        assert np.abs(gpu[n] - cpu[n]).mean() < 2e-3 * max(cpu[n].mean(), 1e-3) + 1e-4, n
