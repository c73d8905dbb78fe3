"""Shadow maps drawn on the GPU (``gpu_backend.shadow_depths``) against the CPU's of the same
light and casters (``core.render.shadows``): every face's depths, the reduction pyramid, the
least depth the filter reads, and the filter's visibility through them."""

import numpy as np
import pytest
import scenes
from test_stages import SHADOW_LIGHTS, _casters, gpu_visibility, shadow_points

from bo2_lighting.addon.core.render import shadow_filter, shadows
from bo2_lighting.addon.core.scene import Camera
from bo2_lighting.addon.gpu_backend import lights, pointwise, shadow_depths, textures

CAMERA = Camera(scenes.look_at(np.array([6.0, -6.0, 4.0]), [0, 0, 0.5]),
                scenes.perspective(1.5, 16 / 9), 320, 180)


def _maps(light, resolution, casters=None):
    """The CPU's map and the same map left to the GPU, and that one drawn."""
    tris = _casters() if casters is None else casters
    cpu = shadows.build_shadow_map(light, tris, CAMERA, resolution=resolution)
    jobs, finish = shadows.shadow_map_jobs(light, tris, CAMERA, resolution=resolution,
                                           on_gpu=True)
    assert not jobs
    planned = finish([])
    assert planned.on_gpu and planned.nbytes == 0
    drawn = lights.shadow_set([planned], casters=shadow_depths.Casters(tris))
    return cpu, planned, drawn


def _layer(texture, layer: int, res: int) -> np.ndarray:
    import gpu

    framebuffer = gpu.types.GPUFrameBuffer(color_slots={"texture": texture, "layer": layer})
    with framebuffer.bind():
        data = framebuffer.read_color(0, 0, res, res, 4, 0, "FLOAT")
    return np.asarray(data, np.float32).reshape(res, res, 4)[..., 0]


@pytest.mark.parametrize("name,resolution", [
    ("point", 512), ("spot", 512), ("sun", 512), ("area", 256), ("sun", 200)])
def test_maps_match_the_cpu(name, resolution):
    """The same texels covered (but for texels exactly on an edge: the GPU's rule takes one
    side), the same depths to float32 interpolation (relative 1e-5; a cascade's depth along
    the sun crosses zero: 1e-5 of its depth range), the same pyramid (its empty blocks alike)
    and the same least depth; an odd side (200) cuts the blocks at the map's edge."""
    cpu, planned, drawn = _maps(SHADOW_LIGHTS[name], resolution)
    res, faces = cpu.resolution, len(cpu.depth)
    assert (planned.resolution, len(planned.depth)) == (res, faces)
    gpu_depth = np.stack([_layer(drawn.depth, f, drawn.depth.width)[:res, :res]
                          for f in range(faces)])
    covered, drawn_here = np.isfinite(cpu.depth), np.isfinite(gpu_depth)
    assert covered.sum() > 0.05 * covered.size
    assert (covered != drawn_here).sum() <= 1e-3 * covered.sum()
    both = covered & drawn_here
    scale = (np.abs(cpu.depth[both]) if cpu.kind != "ORTHO"
             else np.ptp(cpu.depth[both]) * np.ones(both.sum()))
    assert (np.abs(gpu_depth[both] - cpu.depth[both]) <= 1e-5 * scale).all()
    pyramid = textures.read_rows(drawn.mips, len(cpu.mips), 3)
    assert np.array_equal(np.isfinite(pyramid), np.isfinite(cpu.mips))
    finite = np.isfinite(cpu.mips)
    top = np.abs(cpu.mips[finite]).max()
    assert np.abs(pyramid[finite] - cpu.mips[finite]).max() <= 1e-5 * top
    least = pointwise.run(("shadow_filter",), "d = vec4(min_depth(0));",
                          {"p": np.zeros((1, 3), np.float32)}, ("d",),
                          defines=lights.filter_defines(), structs=(lights.SHADOW,),
                          prelude=lights.filter_prelude(),
                          blocks=(("ShadowData", "shadows[1]", drawn.block),),
                          samplers=drawn.samplers())["d"][0, 0]
    assert abs(least - cpu.min_depth) <= 1e-5 * max(1.0, abs(cpu.min_depth))


@pytest.mark.parametrize("name", list(SHADOW_LIGHTS))
def test_filter_through_gpu_maps_matches_the_cpu(name):
    """PCF and PCSS on the GPU, over maps drawn there, against the kernel over the CPU's maps
    at the same points and seeds: the same shadows but at points whose taps meet an edge
    texel the two rasterizers decide differently."""
    cpu, _, drawn = _maps(SHADOW_LIGHTS[name], 512)
    pts, normals, seeds = shadow_points()
    reference = shadow_filter.shadow_visibility(cpu, pts, normals, seeds=seeds)
    assert 0.05 < (reference < 1).mean() < 0.95
    out = gpu_visibility(drawn, pts, normals, seeds)
    diff = np.abs(out - reference)
    print(f"{name}: mean difference {diff.mean():.2e}, points off by > 1/16: "
          f"{(diff > 1 / 16).sum()} of {len(pts)}")
    assert diff.mean() < 1e-3 and (diff > 1 / 16).mean() < 2e-3


def test_casters_behind_a_spot_leave_its_map_empty():
    """Every texel +inf when the only caster is behind the light."""
    behind = np.array([[[-5, -5, 50], [5, -5, 50], [5, 5, 50]]], np.float32)
    _, _, drawn = _maps(SHADOW_LIGHTS["spot"], 64, casters=behind)
    assert np.isposinf(_layer(drawn.depth, 0, 64)).all()


def test_the_cpu_filter_refuses_a_map_left_to_the_gpu():
    _, planned, _ = _maps(SHADOW_LIGHTS["spot"], 64)
    with pytest.raises(ValueError, match="drawn on a GPU"):
        shadow_filter.shadow_visibility(planned, np.zeros((1, 3), np.float32),
                                        np.float32([[0, 0, 1]]))
