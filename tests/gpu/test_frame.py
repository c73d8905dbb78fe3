"""Whole frames on the GPU against the CPU's ``pipeline.render_frame`` of the same scene:
PSNR per pass, and the Combined pass after the view transform pixel by pixel outside edges
(the counts are printed: ``pytest -s``)."""

import dataclasses

import compare
import numpy as np
import pytest
import scenes

from bo2_lighting.addon.core.render import pipeline
from bo2_lighting.addon.core.render.job import RenderJob
from bo2_lighting.addon.core.render.passes import EMPTY_DEPTH
from bo2_lighting.addon.core.render.visibility import sample_offsets
from bo2_lighting.addon.core.scene import Light, Material, program
from bo2_lighting.addon.gpu_backend import frame as gpu_frame
from bo2_lighting.addon.gpu_backend import materials

CASES = {
    "point": dict(lights=["POINT"]),
    "spot": dict(lights=["SPOT"]),
    "sun": dict(lights=["SUN"]),
    "area": dict(lights=["AREA"]),
    "all_lights_emission": dict(lights=list(scenes.LIGHTS), emission=True),
    "orthographic_portrait": dict(lights=list(scenes.LIGHTS), ortho=True, width=150,
                                  height=260),
    "bo2_specular_8_samples": dict(lights=["SPOT", "SUN"], model="bo2", samples=8),
}


def _render_both(scene, on_gpu=True):
    """The CPU's frame, and the GPU's: its shadow maps drawn there (``on_gpu``) as F12 and
    the viewport draw them, else the CPU's maps uploaded (frames with transparent casters)."""
    cpu = pipeline.render_frame(RenderJob(scene))
    frame = pipeline.prepare(RenderJob(scene), on_gpu=on_gpu)
    gpu = gpu_frame.render(frame, sample_offsets(scene.settings.samples,
                                                 scene.settings.filter_width))
    return cpu, gpu


def _check(cpu, gpu, name):
    """Every pass at 40 dB or more; Depth within 1e-4 of the CPU's where both see a surface
    and IndexMA equal there; the Lightmap Texels checker inside its cells (a pixel on a cell's
    border is on one side or the other, as one on an edge); Combined after the view
    transform off by more than 4/255 on at most 0.05% of the pixels outside edges."""
    report = {}
    edge = compare.edges(cpu["Depth"][..., 0], cpu["Normal"])
    for pass_name, image in gpu.items():
        reference = cpu[pass_name][..., :image.shape[-1]]
        if pass_name in ("Depth", "IndexMA"):
            seen = (reference[..., 0] < EMPTY_DEPTH) & (image[..., 0] < EMPTY_DEPTH) & ~edge
            if pass_name == "Depth":
                error = np.abs(image - reference)[seen] / reference[seen]
                assert error.max(initial=0.0) < 1e-4, f"{name}: Depth {error.max()}"
            else:
                assert np.array_equal(image[seen], reference[seen]), f"{name}: IndexMA"
            continue
        if pass_name == "Lightmap Texels":
            inside = compare.cell_interiors(reference)
            image, reference = image[inside], reference[inside]
        value = compare.psnr(image, reference)
        report[pass_name] = round(float(value), 1)
        assert value >= 40.0, f"{name}: {pass_name} {value:.1f} dB"
    off, edges = compare.off_pixels(gpu, cpu)
    print(f"{name}: PSNR {report}; Combined off by > 4/255: {off} pixels "
          f"(edge pixels left out: {edges})")
    assert off <= 0.0005 * gpu["Combined"][..., 0].size


@pytest.mark.parametrize("name", list(CASES))
def test_frame_matches_the_cpu(name):
    case = dict(CASES[name])
    lights = [scenes.LIGHTS[k] for k in case.pop("lights")]
    scene = scenes.objects_scene(lights, **case)
    _check(*_render_both(scene), name)


def _principled(base, roughness) -> Material:
    b = program.ProgramBuilder()
    c = b.const
    surface = b.add("principled", c(*base), c(0.0), c(roughness), c(1.5), c(0.5),
                    c(1.0, 1.0, 1.0), c(0.0), c(0.0, 0.0, 0.0), c(0.0), c(1.0), None)
    return Material("paint", b.build(surface))


def test_layered_diffuse_frame_matches_the_cpu():
    """Principled BSDFs with Layered Diffuse: their albedo weighted toward the eye alike."""
    scene = scenes.objects_scene([scenes.LIGHTS["SPOT"], scenes.LIGHTS["SUN"]])
    scene.materials[:2] = [_principled((0.6, 0.6, 0.6), 0.3), _principled((0.7, 0.2, 0.1), 0.6)]
    scene.settings = dataclasses.replace(scene.settings, layered_diffuse=True)
    cpu, gpu = _render_both(scene)
    plain = pipeline.render_frame(RenderJob(dataclasses.replace(
        scene, settings=dataclasses.replace(scene.settings, layered_diffuse=False))))
    assert (cpu["Albedo"] < plain["Albedo"] - 1e-3).any()  # the layer took its share
    _check(cpu, gpu, "layered_diffuse")


def test_frame_with_the_cpus_shadow_maps_matches_the_cpu():
    """The maps built on the CPU and uploaded (what a frame with transparent casters uses)."""
    scene = scenes.objects_scene(list(scenes.LIGHTS.values()))
    _check(*_render_both(scene, on_gpu=False), "cpu_maps")


INDIRECT_CASES = {
    # (volume, contact occlusion, dome directions, width, height, normalization, env BRDF)
    "probes": (True, False, 0, 320, 180, "bo2", "bo2"),
    "probes_occlusion_bo1": (True, True, 0, 320, 180, "bo1", "table"),
    "world_dome_upsampled": (False, True, 32, 480, 270, "bo2", "fit"),
}


@pytest.mark.parametrize("name", list(INDIRECT_CASES))
def test_indirect_frame_matches_the_cpu(name):
    """The probes' light, the contact occlusion and the world's occlusion through the dome
    (at 270 rows the dome is looked up every 2 pixels and blended: ``sky.upsampled``)."""
    volume, ao, dome, width, height, normalization, env = INDIRECT_CASES[name]
    scene = scenes.with_probes(scenes.objects_scene(
        [scenes.LIGHTS["SUN"], scenes.LIGHTS["POINT"]], width=width, height=height),
        volume=volume)
    scene.settings = dataclasses.replace(scene.settings, ambient_occlusion=ao,
                                         sky_directions=dome, normalization=normalization,
                                         env_brdf=env)
    frame = pipeline.prepare(RenderJob(scene))
    assert (frame.sky is not None) == bool(dome)
    _check(*_render_both(scene), name)


def test_image_world_frame_matches_the_cpu():
    """An equirect image world (rotated, with strength, a blurred background at a level of
    detail and half its opacity) seen past the objects, and its prefiltered light."""
    from bo2_lighting.addon.core.formulas import texture as core_texture
    from bo2_lighting.addon.core.scene import World

    rng = np.random.default_rng(8)
    h, w = 64, 128
    yy, xx = np.mgrid[0:h, 0:w]
    image = np.stack([0.3 + 0.7 * yy / h, 0.4 + 0.3 * np.sin(xx / 9.0),
                      0.5 + 0.2 * rng.uniform(0, 1, (h, w))], -1).astype(np.float32)
    tex = core_texture.make_texture(image, srgb=False)
    angle = 0.7
    rotation = np.array([[np.cos(angle), -np.sin(angle), 0], [np.sin(angle), np.cos(angle), 0],
                         [0, 0, 1.0]])
    scene = scenes.with_probes(scenes.objects_scene([scenes.LIGHTS["SUN"]], width=320,
                                                    height=180), volume=False)
    scene = dataclasses.replace(scene, world=World(texture=tex, strength=1.5, rotation=rotation,
                                                   background_lod=1.5, background_alpha=0.5))
    scene.settings = dataclasses.replace(scene.settings, sky_directions=0)
    _check(*_render_both(scene), "image world")


@pytest.mark.parametrize("directional", [False, True])
def test_lightmapped_frame_matches_the_cpu(directional):
    """The ground and the box take their diffuse indirect light from baked lightmaps (an
    irradiance one, or a directional one's L1 SH), the sphere from the probes."""
    from bo2_lighting.addon.core.lighting.lightmap import Lightmap

    rng = np.random.default_rng(9)
    scene = scenes.with_probes(scenes.objects_scene([scenes.LIGHTS["SPOT"]]), volume=False)
    scene.settings = dataclasses.replace(scene.settings, sky_directions=32)
    for k in (0, 1):
        mesh = scene.meshes[k]
        corners = mesh.positions.reshape(-1, 3)
        uvs = ((corners[:, :2] - corners[:, :2].min(0)) / np.ptp(corners[:, :2], 0).clip(1e-6)
               ).reshape(-1, 3, 2).astype(np.float32)
        h, w = 24, 32
        yy, xx = np.mgrid[0:h, 0:w]
        base = 0.5 + 0.4 * np.sin(xx / 5.0 + k)[..., None] * np.cos(yy / 4.0)[..., None]
        image = np.repeat(base, 12 if directional else 3, -1) * rng.uniform(0.8, 1.2, 12 if
                                                                            directional else 3)
        scene.meshes[k] = dataclasses.replace(mesh, lightmap=Lightmap(
            image.astype(np.float32), uvs))
    frame = pipeline.prepare(RenderJob(scene))
    assert frame.lightmaps is not None and len(frame.lightmaps) == 2
    _check(*_render_both(scene), f"lightmaps (directional: {directional})")


def test_holdout_and_backface_culling_match_the_cpu():
    """A holdout sphere cuts a hole (alpha 0) through the ground and hides what is behind it;
    the box's material culls its faces seen from behind (its walls' insides show, and a camera
    inside it sees out)."""
    scene = scenes.with_probes(scenes.objects_scene([scenes.LIGHTS["SUN"],
                                                     scenes.LIGHTS["POINT"]]), volume=False)
    scene.meshes[2] = dataclasses.replace(scene.meshes[2], holdout=True)
    scene.materials[1] = dataclasses.replace(scene.materials[1], backface_culling=True)
    box = scene.meshes[1]  # 1 cm above the ground: its bottom, seen from inside, is not
    scene.meshes[1] = dataclasses.replace(box, positions=box.positions + np.float32([0, 0, 0.01]))
    frame = pipeline.prepare(RenderJob(scene))
    assert frame.holdout.any() and frame.cull is not None
    cpu, gpu = _render_both(scene)
    hole = cpu["Combined"][..., 3] == 0.0
    assert hole.sum() > 500 and (gpu["Combined"][..., 3][hole] < 0.26).all()
    _check(cpu, gpu, "holdout and culling")
    inside = dataclasses.replace(scene, camera=dataclasses.replace(
        scene.camera, world_to_camera=scenes.look_at(np.array([-1.0, 0.0, 0.5]),
                                                     [3.0, -2.0, 0.3])))
    _check(*_render_both(inside), "culled faces seen from inside")


def test_every_sample_shaded_and_transparent_film():
    scene = scenes.objects_scene(list(scenes.LIGHTS.values()))
    scene.settings = dataclasses.replace(scene.settings, shade_every_sample=True,
                                         film_transparent=True)
    cpu, gpu = _render_both(scene)
    assert gpu["Combined"][0, 0, 3] == 0.0  # the sky's corner: no background
    _check(cpu, gpu, "every sample, transparent film")


def test_more_lights_than_one_batch():
    """Lights beyond ``BATCH_LIGHTS`` are shaded in further draws and add up."""
    rng = np.random.default_rng(3)
    lights = [Light("POINT", rng.uniform(2, 6, 3), position=np.array(
        [*rng.uniform(-3, 3, 2), rng.uniform(1.5, 3)]), radius=0.1,
        shadow=bool(k % 3)) for k in range(gpu_frame.BATCH_LIGHTS + 9)]
    scene = scenes.objects_scene(lights, samples=2)
    _check(*_render_both(scene), "41 lights")


def _textured(scene):
    """``scene`` with node-graph materials: an 8-bit image through Generated coordinates and a
    Mapping on the ground, a float image's height as a Bump on the box, a ramp of Object
    coordinates mixed by a Layer Weight on the sphere."""
    from bo2_lighting.addon.core.formulas import texture as core_texture

    rng = np.random.default_rng(5)
    noise = rng.uniform(0, 1, (48, 64, 4))
    codes = (255 * (0.5 + 0.5 * np.sin(np.linspace(0, 9, 64))[None, :, None] * noise)).astype(
        np.uint8)
    checker = core_texture.make_texture(codes, srgb=True)
    heights = core_texture.make_texture(rng.uniform(0, 1, (32, 32, 3)).astype(np.float32),
                                        srgb=False, interpolation="Cubic")
    b = program.ProgramBuilder()
    gen = b.add("texcoord", param=("Generated",))
    mapped = b.add("mapping", gen, b.const(0.0, 0.0, 0.0), b.const(0.0, 0.0, 0.4),
                   b.const(6.0, 6.0, 1.0), param=("POINT",))
    color = b.add("image", mapped, param=(checker, 0))
    rough = b.add("math", b.add("swizzle", color, param=(3, 4)), b.const(0.8), b.const(0.0),
                  param=("MULTIPLY", False))
    ground = b.build(b.add("principled", b.add("swizzle", color, param=(0, 3)), b.const(0.0),
                           rough, b.const(1.5), b.const(0.5), b.const(1.0, 1.0, 1.0),
                           b.const(0.0), b.const(0.0, 0.0, 0.0), b.const(0.0), b.const(1.0),
                           None))
    b = program.ProgramBuilder()
    h = b.add("to_float", b.add("image", param=(heights, 0)), param=("color",))
    bump = b.add("bump", b.const(0.8), b.const(0.3), h, None, b.const(0.1), param=(False,))
    box = b.build(b.add("bo2", b.const(0.7, 0.3, 0.1), b.const(0.04, 0.04, 0.04),
                        b.const(0.7), bump, b.const(0.0, 0.0, 0.0), b.const(1.0),
                        b.const(1.0)))
    b = program.ProgramBuilder()
    obj = b.add("texcoord", param=("Object",))
    z = b.add("swizzle", obj, param=(2, 3))
    ramp = b.add("ramp", b.add("math", z, b.const(0.7), b.const(0.0), param=("DIVIDE", False)),
                 param=(np.float32([[0.9, 0.1, 0.1, 1], [0.1, 0.8, 0.2, 1], [0.2, 0.2, 0.9, 1]]),
                        True))
    weight = b.add("swizzle", b.add("layer_weight", b.const(0.3), None), param=(1, 2))
    sphere = b.build(b.add("mix_shader", weight,
                           b.add("diffuse", b.add("swizzle", ramp, param=(0, 3)), None),
                           b.add("glossy", b.const(0.9, 0.8, 0.6), b.const(0.3), None)))
    mats = [Material("ground", ground), Material("box", box, pass_index=3),
            Material("sphere", sphere)]
    return dataclasses.replace(scene, materials=mats)


@pytest.mark.parametrize("indirect", [False, True])
def test_node_graph_materials_match_the_cpu(indirect):
    """Materials that vary over their surface drawn by their GLSL (``gpu_backend.materials``):
    images at their footprint's level, a bump, procedural colour and mixes."""
    scene = _textured(scenes.objects_scene(list(scenes.LIGHTS.values()), samples=2))
    if indirect:
        scene = scenes.with_probes(scene)
    frame = pipeline.prepare(RenderJob(scene))
    assert gpu_frame.unsupported(frame) is None
    _check(*_render_both(scene), f"node graphs {'with probes' if indirect else ''}")


def test_what_the_gpu_does_not_draw_is_named():
    """A material reading more corner attributes than the GPU's vertex inputs hold."""
    scene = scenes.objects_scene([scenes.LIGHTS["SUN"]])
    cube = scene.meshes[1]
    names = [f"paint{k}" for k in range(materials.MAX_STREAMS + 1)]
    scene.meshes[1] = dataclasses.replace(cube, attributes={
        ("attribute", n): np.full((len(cube.positions), 3, 4), 0.1 * k, np.float32)
        for k, n in enumerate(names)})
    b = program.ProgramBuilder()
    total = b.const(0.0, 0.0, 0.0)
    for n in names:
        paint = b.add("swizzle", b.add("attribute", param=(n,)), param=(0, 3))
        total = b.add("vector_math", total, paint, total, b.const(1.0), param=("ADD",))
    scene.materials[1] = Material("Painted", b.build(b.add(
        "bo2", total, b.const(0.04, 0.04, 0.04), b.const(0.5), None, b.const(0.0, 0.0, 0.0),
        b.const(1.0), b.const(1.0))))
    frame = pipeline.prepare(RenderJob(scene))
    assert "attributes" in gpu_frame.unsupported(frame)
    with pytest.raises(gpu_frame.Unsupported, match="attributes"):
        gpu_frame.GPUFrame(frame)


def _holed(seed: int, low: float, high: float):
    """The talk's material whose colour and alpha come from a 16 x 16 image of random texels
    in [low, high) (Closest), through Object coordinates."""
    from bo2_lighting.addon.core.formulas import texture as core_texture

    texels = np.random.default_rng(seed).uniform(low, high, (16, 16, 4)).astype(np.float32)
    holes = core_texture.make_texture(texels, srgb=False, interpolation="Closest")
    b = program.ProgramBuilder()
    look = b.add("image", b.add("texcoord", param=("Object",)), param=(holes, 0))
    return b.build(b.add("bo2", b.add("swizzle", look, param=(0, 3)), b.const(0.04, 0.04, 0.04),
                         b.const(0.6), None, b.const(0.0, 0.0, 0.0), b.const(1.0),
                         b.add("swizzle", look, param=(3, 4))))


def test_dithered_transparency_matches_the_cpu():
    """Stochastic transparency: a constant alpha on the box, an alpha from an image on the
    sphere (and its shadow cut out), in front of each other; the layers peeled per sample as
    the CPU peels them, with the same thresholds."""
    scene = scenes.objects_scene(list(scenes.LIGHTS.values()), samples=8)
    sphere = _holed(3, 0.0, 1.0)
    b = program.ProgramBuilder()
    box = b.build(b.add("principled", b.const(0.2, 0.5, 0.9), b.const(0.0), b.const(0.4),
                        b.const(1.5), b.const(0.5), b.const(1.0, 1.0, 1.0), b.const(0.0),
                        b.const(0.0, 0.0, 0.0), b.const(0.0), b.const(0.35), None))
    scene.materials[1] = Material("box", box, pass_index=3)
    scene.materials[2] = Material("sphere", sphere)
    lifted = scene.meshes[1].positions + np.float32([0.0, 0.0, 0.02])  # its bottom and the
    scene.meshes[1] = dataclasses.replace(scene.meshes[1], positions=lifted)  # ground: no tie
    frame = pipeline.prepare(RenderJob(scene))
    assert frame.fades.any() and gpu_frame.unsupported(frame) is None
    _check(*_render_both(scene), "dithered transparency")


def test_every_look_dev_view_matches_the_cpu():
    """The viewport's look-dev views drawn on the GPU (``gpu_backend.viewport``) against
    ``viewport.view_pixels`` of the CPU's passes, the probes' influence views among them:
    at least 40 dB outside edge pixels (where the CPU colours the averaged position)."""
    from bo2_lighting.addon.core.render import viewport as cpu_viewport
    from bo2_lighting.addon.gpu_backend import textures
    from bo2_lighting.addon.gpu_backend import viewport as gpu_viewport

    scene = scenes.with_probes(scenes.objects_scene(list(scenes.LIGHTS.values()), width=240,
                                                    height=136, samples=2))
    samples = scene.settings.samples
    cpu = pipeline.render_frame(RenderJob(scene))
    frame = pipeline.prepare(RenderJob(scene))
    edge = compare.edges(cpu["Depth"][..., 0], cpu["Normal"])
    drawing = gpu_viewport.ViewportDrawing()
    assert set(gpu_viewport.VIEWS) == set(cpu_viewport.VIEWS)
    report = {}
    for view in gpu_viewport.VIEWS:
        for _ in range(samples):
            texture = drawing.draw(frame, scene.camera, view, samples)
        gpu = textures.read(texture)[::-1]
        want = cpu_viewport.view_pixels(cpu, view, scene)
        value = compare.psnr(gpu[~edge][..., :3], want[~edge][..., :3])
        report[view] = round(float(value), 1)
    print(f"look-dev views, GPU vs CPU: {report}")
    assert min(report.values()) >= 40.0, report


def test_a_material_tweak_keeps_the_drawn_shadow_maps():
    """A frame made again for new materials (``with_materials``: the same geometry and maps)
    reuses the shadow maps the GPU drew for the frame before; new maps are drawn anew."""
    from bo2_lighting.addon.core.render.buffers import with_materials

    scene = scenes.objects_scene([scenes.LIGHTS["POINT"], scenes.LIGHTS["SUN"]])
    frame = pipeline.prepare(RenderJob(scene), on_gpu=True)
    first = gpu_frame.GPUFrame(frame)
    tweaked = with_materials(frame, frame.scene)
    assert tweaked is not None and tweaked is not frame
    again = gpu_frame.GPUFrame(tweaked)
    assert len(again.batches) == len(first.batches)
    assert all(a.shadows is b.shadows for a, b in zip(again.batches, first.batches, strict=True))
    fresh = gpu_frame.GPUFrame(pipeline.prepare(RenderJob(scene), on_gpu=True))
    assert all(a.shadows is not b.shadows
               for a, b in zip(fresh.batches, first.batches, strict=True))


def test_linked_lights_match_the_cpu():
    """Light and shadow linking: the point light lights the ground and the sphere alone (its
    receiver set), the sun is shadowed by the box alone (its blocker set), the spot unlinked;
    the GPU's frame against the CPU's, and against the unlinked frame where linking must
    change it. A set beyond the GPU's 31 renders on the CPU, and says why."""
    lights = [dataclasses.replace(scenes.LIGHTS["POINT"], receivers=1),
              dataclasses.replace(scenes.LIGHTS["SUN"], blockers=2), scenes.LIGHTS["SPOT"]]
    scene = scenes.objects_scene(lights)
    ground, box, ball = scene.meshes
    ground.light_sets, box.light_sets, ball.light_sets = 0b011, 0b101, 0b011
    ground.shadow_sets, box.shadow_sets, ball.shadow_sets = 0b011, 0b101, 0b011
    cpu, gpu = _render_both(scene)
    _check(cpu, gpu, "linked")
    plain = _render_both(scenes.objects_scene([scenes.LIGHTS[k] for k in
                                                ("POINT", "SUN", "SPOT")]))[1]
    changed = np.abs(gpu["Combined"] - plain["Combined"]).max(-1) > 0.01
    print("linked: pixels changed by linking", changed.mean())
    assert 0.01 < changed.mean() < 0.9, changed.mean()
    far = dataclasses.replace(scenes.LIGHTS["POINT"], receivers=gpu_frame.GPU_LINK_SETS)
    frame = pipeline.prepare(RenderJob(scenes.objects_scene([far])))
    assert gpu_frame.unsupported(frame) == "more than 31 light linking collections"


def test_cryptomatte_matches_the_cpu():
    """The Cryptomatte passes of the GPU's samples against the CPU's: the same names ranked
    first, and the same coverage, but at edges, where the GPU's rasterization rule gives a
    sample on an edge to one triangle and the CPU's may give it to the other."""
    scene = scenes.objects_scene([scenes.LIGHTS["SUN"]], samples=8)
    for k, m in enumerate(scene.meshes):
        m.name, m.asset = f"mesh{k}", "group" if k else ""
    scene.settings = dataclasses.replace(scene.settings, samples=8,
                                         cryptomatte=("Object", "Material", "Asset"),
                                         cryptomatte_levels=4)
    cpu, gpu = _render_both(scene)
    names = [f"Crypto{kind}{n:02d}" for kind in ("Object", "Material", "Asset") for n in (0, 1)]
    assert set(names) <= set(gpu)
    for name in names:
        same_id = gpu[name][..., 0].view(np.uint32) == cpu[name][..., 0].view(np.uint32)
        close = np.abs(gpu[name][..., 1] - cpu[name][..., 1]) <= 1.0 / 8 + 1e-6
        print(f"{name}: rank 0 the same at {same_id.mean():.4f} of the pixels, coverage "
              f"within one sample at {close.mean():.4f}")
        assert same_id.mean() > 0.995 and close.mean() > 0.995, name
    covered = sum(gpu[f"CryptoObject{n:02d}"][..., c] for n in (0, 1) for c in (1, 3))
    assert covered.max() <= 1.0 + 1e-6 and (covered == 1.0).mean() > 0.5  # the sky: none


def test_depth_of_field_matches_the_cpu():
    """A thin lens focused on the box (blades, a ratio): the GPU's samples see from the CPU's
    lens points; the frame against the CPU's, and blurred where the pinhole's is sharp."""
    from bo2_lighting.addon.core.scene import Aperture

    scene = scenes.objects_scene([scenes.LIGHTS["SUN"], scenes.LIGHTS["POINT"]], samples=16)
    pinhole = _render_both(scene)[1]["Combined"]
    eye = scene.camera.position
    scene.camera.aperture = Aperture(radius=1.2, focus=float(np.linalg.norm(eye - [-1, 0, 0.5])),
                                     blades=6, rotation=0.2, ratio=1.3)
    cpu, gpu = _render_both(scene)
    _check(cpu, gpu, "depth of field")
    blurred = np.abs(gpu["Combined"] - pinhole).max(-1) > 0.05
    assert 0.02 < blurred.mean() < 0.6, blurred.mean()


def test_light_groups_match_the_cpu():
    """Light groups on the GPU (a frame per group: its lights, its meshes' emission, the
    world's light and probes for the world's): each pass against the CPU's, and together
    Combined."""
    lights = [dataclasses.replace(scenes.LIGHTS["SUN"], group="sun"),
              dataclasses.replace(scenes.LIGHTS["POINT"], group="lamps"),
              dataclasses.replace(scenes.LIGHTS["SPOT"], group="lamps")]
    scene = scenes.with_probes(scenes.objects_scene(lights, emission=True))
    scene.meshes[3].group = "lamps"  # the glowing cube
    scene.world.group = "world"
    scene.settings = dataclasses.replace(scene.settings, light_groups=("sun", "lamps", "world"))
    cpu, gpu = _render_both(scene)
    names = ["Combined_sun", "Combined_lamps", "Combined_world"]
    for name in names:
        value = compare.psnr(gpu[name], cpu[name])
        print(f"{name}: {value:.1f} dB")
        assert value >= 40.0, name
    np.testing.assert_allclose(sum(gpu[n] for n in names), gpu["Combined"][..., :3],
                               rtol=1e-3, atol=1e-4)


@pytest.mark.parametrize(("camera_moves", "probes"), [(False, False), (True, False),
                                                      (False, True)])
def test_motion_blur_matches_the_cpu(camera_moves, probes):
    """A box moving over the shutter (and the camera moving too; and a scene with probes, the
    world's dome and its contact occlusion): the GPU draws each sample at the CPU's time,
    shaded at the middle of its share of the shutter with that share's shadow maps (the
    box's shadow streaks); the frame against the CPU's, streaked where the still one is
    sharp. 40 samples: two or three per share, so a still triangle's shading is reused within
    a share and a moving one's never."""
    scene = scenes.objects_scene([scenes.LIGHTS["SUN"], scenes.LIGHTS["POINT"]], samples=40)
    if probes:
        scene = scenes.with_probes(scene)
    still = _render_both(scene)[1]["Combined"]
    box = scene.meshes[1]
    box.motion = np.stack([box.positions + np.float32([dx, 0.3 * dx, 0.0])
                           for dx in (-0.4, 0.0, 0.4)])
    if camera_moves:
        views = []
        for dx in (0.15, 0.0, -0.15):
            view = np.array(scene.camera.world_to_camera, np.float64)
            view[1, 3] += dx
            views.append(view)
        scene.camera = dataclasses.replace(scene.camera, motion=np.stack(views))
    frame = pipeline.prepare(RenderJob(scene))
    assert frame.at_times is not None and frame.shadows_move
    assert gpu_frame.unsupported(frame) is None
    cpu, gpu = _render_both(scene)
    _check(cpu, gpu, "motion blur")
    streaked = np.abs(gpu["Combined"] - still).max(-1) > 0.05
    assert 0.01 < streaked.mean() < 0.8, streaked.mean()


@pytest.mark.parametrize("blended", [False, True])
def test_shader_aovs_match_the_cpu(blended):
    """The ball writes its position (a colour AOV) and its facing (a value AOV), the box a
    constant colour AOV: each pass against the CPU's; an AOV no material writes is 0. The box
    ``blended`` (alpha 0.5): its AOV and the ball's behind it by their shares."""
    scene = scenes.objects_scene([scenes.LIGHTS["SUN"]], samples=8)
    b = program.ProgramBuilder()
    metal = b.add("bo2", b.const(0.0, 0.0, 0.0), b.const(0.9, 0.7, 0.4), b.const(0.8), None,
                  b.const(0.0, 0.0, 0.0), b.const(1.0), b.const(1.0))
    position = b.add("geometry", param=("Position",))
    facing = b.add("swizzle", b.add("layer_weight", b.const(0.5), None), param=(1, 2))
    scene.materials[2] = Material("metal", b.build(metal, aovs=(
        ("where", position, b.const(0.0)), ("facing", b.const(0.0, 0.0, 0.0), facing))))
    b = program.ProgramBuilder()
    box = b.add("bo2", b.const(0.7, 0.2, 0.1), b.const(0.04, 0.04, 0.04), b.const(0.6), None,
                b.const(0.0, 0.0, 0.0), b.const(1.0), b.const(0.5 if blended else 1.0))
    scene.materials[1] = Material("box", b.build(box, aovs=(
        ("where", b.const(0.25, 0.5, 0.75), b.const(0.0)),)), blended=blended)
    lifted = scene.meshes[1].positions + np.float32([0.0, 0.0, 0.02])  # no tie with the ground
    scene.meshes[1] = dataclasses.replace(scene.meshes[1], positions=lifted)
    scene.settings = dataclasses.replace(scene.settings, aovs=(
        ("where", "COLOR"), ("facing", "VALUE"), ("nobody", "VALUE")))
    cpu, gpu = _render_both(scene)
    for name in ("where", "facing", "nobody"):
        assert gpu[name].shape == cpu[name].shape, name
        value = compare.psnr(gpu[name], cpu[name])
        print(f"{name}: {value:.1f} dB")
        assert value >= 40.0, (name, value)
    assert not gpu["nobody"].any() and gpu["where"][..., 3].max() == pytest.approx(1.0)


@pytest.mark.parametrize("transparent,caught", [(False, False), (True, False), (False, True),
                                                (True, True)])
def test_shadow_catchers_match_the_cpu(transparent, caught):
    """The ground a shadow catcher under a sun and a point light: the world times the share
    of light the shadows let through (or black of their opacity with a transparent film), the
    frame against the CPU's; with the Shadow Catcher pass (``caught``), that share in the pass
    and the catcher left out of Combined."""
    scene = scenes.objects_scene([scenes.LIGHTS["SUN"], scenes.LIGHTS["POINT"]], samples=8)
    scene.meshes[0].shadow_catcher = True
    scene.world.color = np.array([0.3, 0.4, 0.5], np.float32)
    scene.settings = dataclasses.replace(scene.settings, film_transparent=transparent,
                                         shadow_catcher_pass=caught)
    frame = pipeline.prepare(RenderJob(scene))
    assert gpu_frame.unsupported(frame) is None
    cpu, gpu = _render_both(scene)
    _check(cpu, gpu, "shadow catcher")
    alpha = gpu["Combined"][..., 3]
    if caught:  # the ground left out of Combined; its shadows in the pass alone
        share = gpu["Shadow Catcher"][..., 0]
        assert (alpha < 1e-6).mean() > 0.2 and 0.005 < (share < 0.9).mean() < 0.5
    elif transparent:  # the shadows' opacity, nothing else of the ground
        assert 0.005 < ((alpha > 0.05) & (alpha < 0.999)).mean() < 0.5


def _see_through(color, alpha: float):
    """The talk's material of coverage ``alpha``."""
    b = program.ProgramBuilder()
    return b.build(b.add("bo2", b.const(*color), b.const(0.04, 0.04, 0.04), b.const(0.6),
                         None, b.const(0.0, 0.0, 0.0), b.const(1.0), b.const(alpha)))


def _blended_scene(sort="pixel", overlap=True):
    """The objects under every light type, the box and the ball Blended (the ball's alpha from
    an image, its object's layers shown once without ``overlap``) and three crossing cards in
    front of them: two Blended, one Dithered (peeled inside the stacks)."""
    from bo2_lighting.addon.core.scene import MeshBatch

    scene = scenes.objects_scene(list(scenes.LIGHTS.values()), samples=8)
    ball = _holed(5, 0.2, 0.9)
    scene.materials[1] = Material("box", _see_through((0.7, 0.2, 0.1), 0.45), pass_index=3,
                                  blended=True)
    scene.materials[2] = Material("ball", ball, blended=True, transparency_overlap=overlap)
    lifted = scene.meshes[1].positions + np.float32([0.0, 0.0, 0.02])  # its bottom and the
    scene.meshes[1] = dataclasses.replace(scene.meshes[1], positions=lifted)  # ground: no tie
    colors = [(0.9, 0.3, 0.1), (0.1, 0.7, 0.3), (0.2, 0.3, 0.9)]
    for k, (color, alpha) in enumerate(zip(colors, (0.5, 0.35, 0.6), strict=True)):
        scene.materials.append(Material(f"card {k}", _see_through(color, alpha),
                                        blended=k != 1))
        x = -0.8 + 0.7 * k
        card = np.array([[[x, -1.2, 0.2], [x + 1.4, 0.4, 0.2], [x + 1.4, 0.4, 1.8]],
                         [[x, -1.2, 0.2], [x + 1.4, 0.4, 1.8], [x, -1.2, 1.8]]], np.float32)
        card += np.float32([0.3 * k, -0.25 * k, 0.0])
        scene.meshes.append(MeshBatch(card, scenes.flat_normals(card),
                                      np.full(2, len(scene.materials) - 1, np.int32)))
    scene.settings = dataclasses.replace(scene.settings, blend_sort=sort)
    return scene


@pytest.mark.parametrize("sort", ["pixel", "object"])
def test_blended_transparency_matches_the_cpu(sort):
    """Blended stacks peeled and composited "over" per sample as the CPU's
    ``transparency.blend`` (per pixel, or EEVEE's order by object origin with the ball's
    layers shown once), a Dithered card peeled inside them; every pass against the CPU's."""
    scene = _blended_scene(sort, overlap=sort == "pixel")
    frame = pipeline.prepare(RenderJob(scene))
    assert frame.blends.any() and frame.dithers.any() and gpu_frame.unsupported(frame) is None
    _check(*_render_both(scene), f"blended, {sort} order")


def test_a_deep_blended_stack_and_a_holdout_behind_one_match_the_cpu():
    """Ten crossing cards of alpha 0.3, more than ``BLEND_LAYERS``: the surface behind the
    eighth drawn opaque, and the pixel samples cut counted and said as the CPU says them; a
    holdout card behind part of the stack cuts its hole there."""
    from bo2_lighting.addon.core.render.transparency import BLEND_LAYERS
    from bo2_lighting.addon.core.scene import MeshBatch

    scene = scenes.objects_scene([scenes.LIGHTS["SUN"], scenes.LIGHTS["SPOT"]], samples=4)
    for k in range(BLEND_LAYERS + 2):
        scene.materials.append(Material(f"card {k}", _see_through(
            (0.1 + 0.08 * k, 0.9 - 0.08 * k, 0.5), 0.3), blended=True))
        y = -1.2 + 0.18 * k
        card = np.array([[[-1.6, y, 0.1], [1.6, y, 0.1], [1.6, y + 0.1, 1.9]],
                         [[-1.6, y, 0.1], [1.6, y + 0.1, 1.9], [-1.6, y, 1.9]]], np.float32)
        scene.meshes.append(MeshBatch(card, scenes.flat_normals(card),
                                      np.full(2, len(scene.materials) - 1, np.int32)))
    hole = np.array([[[0.2, 1.0, 0.3], [1.4, 1.0, 0.3], [1.4, 1.0, 1.5]],
                     [[0.2, 1.0, 0.3], [1.4, 1.0, 1.5], [0.2, 1.0, 1.5]]], np.float32)
    scene.meshes.append(MeshBatch(hole, scenes.flat_normals(hole), np.zeros(2, np.int32),
                                  holdout=True))
    job = RenderJob(scene)
    cpu = pipeline.render_frame(job)
    said = []
    gpu = gpu_frame.render(pipeline.prepare(RenderJob(scene), on_gpu=True),
                           sample_offsets(scene.settings.samples, scene.settings.filter_width),
                           warn=lambda text, *_: said.append(text))
    _check(cpu, gpu, "deep stack")
    cut = [t for t in job.warnings.texts() if "blended" in t]
    assert len(cut) == 1 and said == cut, (said, cut)
    assert (gpu["Combined"][..., 3] < 0.9).any()  # through the stack onto the holdout
