"""Lightmaps: layouts, texels, rays, the gather against brute-force integrals, the clean-up,
files and the renderer's use of them (``core.lighting.lightmap``, ``core.bakes.lightmap_bake``)."""

import numpy as np
import pytest

from bo2_lighting.addon.core.bakes import bake as core_bake
from bo2_lighting.addon.core.bakes import lightmap_bake
from bo2_lighting.addon.core.files import bake_file, lightmap_file
from bo2_lighting.addon.core.kernels import lightmap as kernels
from bo2_lighting.addon.core.lighting import lightmap
from bo2_lighting.addon.core.render import pipeline
from bo2_lighting.addon.core.render.job import Cancelled, RenderJob
from bo2_lighting.addon.core.scene import Camera, Light, Material, MeshBatch, Scene, World


def quad(centre, u, v):
    """Two triangles of the rectangle centre +- u +- v, facing u x v: positions, normals."""
    c, u, v = (np.asarray(a, np.float32) for a in (centre, u, v))
    a, b, cc, d = c - u - v, c + u - v, c + u + v, c - u + v
    p = np.array([[a, b, cc], [a, cc, d]], np.float32)
    n = np.cross(u, v)
    return p, np.ascontiguousarray(np.broadcast_to(n / np.linalg.norm(n), p.shape), np.float32)


def sphere(radius=1.0, rings=12, segments=24):
    """A UV sphere's triangles (T, 3, 3) and smooth normals."""
    th = np.linspace(0, np.pi, rings + 1)
    ph = np.linspace(0, 2 * np.pi, segments + 1)
    grid = np.stack([np.sin(th)[:, None] * np.cos(ph), np.sin(th)[:, None] * np.sin(ph),
                     np.cos(th)[:, None] * np.ones_like(ph)], -1)
    tris = []
    for i in range(rings):
        for j in range(segments):
            a, b, c, d = grid[i, j], grid[i + 1, j], grid[i + 1, j + 1], grid[i, j + 1]
            if i > 0:
                tris.append([a, b, d])
            if i < rings - 1:
                tris.append([b, c, d])
    p = np.array(tris, np.float32)
    return p * radius, p / np.linalg.norm(p, axis=2, keepdims=True)


def coverage_reference(uv, width, height):
    """Texel centres inside each triangle, counted by brute force (NumPy)."""
    ys, xs = np.mgrid[0:height, 0:width]
    px, py = xs + 0.5, ys + 0.5
    count = np.zeros((height, width), np.int32)
    for t in uv.astype(np.float64):
        x, y = t[:, 0] * width, (1 - t[:, 1]) * height
        d = [(x[(k + 1) % 3] - x[k]) * (py - y[k]) - (y[(k + 1) % 3] - y[k]) * (px - x[k])
             for k in range(3)]
        inside = ((d[0] > 1e-6) & (d[1] > 1e-6) & (d[2] > 1e-6)) | (
            (d[0] < -1e-6) & (d[1] < -1e-6) & (d[2] < -1e-6))
        count += inside
    return count


@pytest.mark.parametrize("mesh", ["cube", "sphere", "plane"])
def test_layouts_do_not_overlap_and_keep_the_density(mesh):
    if mesh == "sphere":
        positions, _ = sphere(1.0)
    elif mesh == "plane":
        positions, _ = quad([0, 0, 0], [3, 0, 0], [0, 1, 0])
    else:
        faces = [quad(c, u, v)[0] for c, u, v in [
            ([0, 0, 1], [1, 0, 0], [0, 1, 0]), ([0, 0, -1], [0, 1, 0], [1, 0, 0]),
            ([1, 0, 0], [0, 1, 0], [0, 0, 1]), ([-1, 0, 0], [0, 0, 1], [0, 1, 0]),
            ([0, 1, 0], [0, 0, 1], [1, 0, 0]), ([0, -1, 0], [1, 0, 0], [0, 0, 1])]]
        positions = np.concatenate(faces)
    uv, width, height, density = lightmap.layout(positions, 16.0, padding=2)
    assert density == 16.0 and uv.shape == positions.shape[:2] + (2,)
    assert (uv >= 0).all() and (uv <= 1).all()
    count = coverage_reference(uv, width, height)
    assert count.max() == 1  # no texel centre in two triangles
    kernel = np.zeros(width * height, np.int32)
    kernels.coverage(np.ascontiguousarray(uv), width, height, kernel)
    assert lightmap.overlaps(uv, width, height) == 0
    # the kernel counts what the brute force counts, but for centres on a shared edge (within
    # rounding: either side may count them)
    assert kernel.max() == 1 and 0.97 * count.sum() <= kernel.sum() <= count.sum()
    # texels per metre: the UV area in texels over the surface area
    area3 = 0.5 * np.linalg.norm(np.cross(positions[:, 1] - positions[:, 0],
                                          positions[:, 2] - positions[:, 0]), axis=1).sum()
    e1, e2 = uv[:, 1] - uv[:, 0], uv[:, 2] - uv[:, 0]
    area2 = 0.5 * np.abs(e1[:, 0] * e2[:, 1] - e1[:, 1] * e2[:, 0]).sum() * width * height
    assert area2 / area3 == pytest.approx(16.0 ** 2, rel=1e-3)
    # the resolution cap lowers the density
    uv2, w2, h2, d2 = lightmap.layout(positions, 16.0, padding=2, max_resolution=32)
    assert max(w2, h2) <= 32 and d2 < 16.0


def test_overlapping_uvs_are_found():
    positions, _ = quad([0, 0, 0], [1, 0, 0], [0, 1, 0])
    uv = np.array([[[0, 0], [1, 0], [1, 1]], [[0, 0], [1, 1], [0.8, 0.2]]], np.float32)
    assert lightmap.overlaps(uv, 32, 32) > 50
    assert lightmap.overlaps(uv[:1], 32, 32) == 0


def test_rays_hit_what_brute_force_hits():
    positions, _ = sphere(1.0, 8, 16)
    tris = np.ascontiguousarray(positions)
    n = len(tris)
    order, bounds = np.empty(n, np.int32), np.empty((2 * n, 6), np.float32)
    links = np.empty((2 * n, 4), np.int32)
    kernels.build_bvh(tris, order, bounds, links)
    rng = np.random.default_rng(3)
    origins = (rng.random((500, 3)) * 4 - 2).astype(np.float32)
    dirs = rng.normal(size=(500, 3))
    dirs = (dirs / np.linalg.norm(dirs, axis=1, keepdims=True)).astype(np.float32)
    tri = np.empty(500, np.int32)
    hit = np.empty((500, 3), np.float32)
    kernels.trace(tris, order, bounds, links, origins, dirs, np.full(500, 100, np.float32), tri,
                  hit)
    # brute force: every triangle, Moeller-Trumbore in NumPy
    a, e1, e2 = tris[:, 0], tris[:, 1] - tris[:, 0], tris[:, 2] - tris[:, 0]
    for i in range(500):
        p = np.cross(dirs[i], e2)
        det = (e1 * p).sum(1)
        s = origins[i] - a
        u = (s * p).sum(1) / det
        q = np.cross(s, e1)
        v = (dirs[i] * q).sum(1) / det
        t = (e2 * q).sum(1) / det
        ok = (np.abs(det) > 1e-12) & (u >= 0) & (v >= 0) & (u + v <= 1) & (t > 0)
        if ok.any():
            assert tri[i] >= 0 and hit[i, 0] == pytest.approx(t[ok].min(), rel=1e-4)
        else:
            assert tri[i] == -1


def open_floor(wall_albedo=0.0, sky=1.0):
    """A 4 x 4 m floor and a 2 m high wall along its +x edge under a uniform sky."""
    floor, fn = quad([0, 0, 0], [2, 0, 0], [0, 2, 0])
    wall, wn = quad([2, 0, 1], [0, 0, 1], [0, 2, 0])  # faces -x, towards the floor
    cam = Camera.look_at([0, -0.01, 6], [0, 0, 0], 1.2, 48, 48)
    mats = [Material.talk("Floor", albedo=(0.5, 0.5, 0.5), rf0=(0, 0, 0)),
            Material.talk("Wall", albedo=(wall_albedo,) * 3, rf0=(0, 0, 0))]
    return Scene(cam, [MeshBatch(floor, fn, np.zeros(2, np.int32), name="floor"),
                       MeshBatch(wall, wn, np.ones(2, np.int32), name="wall")],
                 mats, [], World(color=np.full(3, sky, np.float32)))


def floor_irradiance_by_brute_force(x, samples=400000):
    """Irradiance at floor point (x, 0, 0) under a unit sky, a black 2 m wall at x = 2 (y in
    -2..2) blocking it: pi times the cosine-weighted fraction of the sky seen."""
    rng = np.random.default_rng(1)
    u1, u2 = rng.random(samples), rng.random(samples)
    r = np.sqrt(u1)
    d = np.stack([r * np.cos(2 * np.pi * u2), r * np.sin(2 * np.pi * u2), np.sqrt(1 - u1)], 1)
    t = (2 - x) / np.where(d[:, 0] > 0, d[:, 0], 1e-30)
    blocked = (d[:, 0] > 0) & (np.abs(t * d[:, 1]) <= 2) & (t * d[:, 2] <= 2)
    return np.pi * (1 - blocked.mean())


def test_gather_matches_a_brute_force_integral():
    scene = open_floor()
    uv, w, h, _ = lightmap.layout(scene.meshes[0].positions, 10.0)
    settings = lightmap.Settings(rays=256, bounces=1, denoise=False)
    (result,) = lightmap_bake.bake(RenderJob(scene), [lightmap.Target("floor", 0, uv, w, h)],
                                   settings)
    p = scene.meshes[0].positions.astype(np.float64)
    for x in (1.9, 1.5, 0.5, -1.5):
        point = np.array([x, 0.3, 0.0])
        for t in range(2):  # the triangle holding the point, and its weights
            m = np.column_stack([p[t, 1] - p[t, 0], p[t, 2] - p[t, 0]])[:2]
            b1, b2 = np.linalg.solve(m, point[:2] - p[t, 0, :2])
            if min(b1, b2, 1 - b1 - b2) >= 0:
                break
        q = (1 - b1 - b2) * uv[t, 0] + b1 * uv[t, 1] + b2 * uv[t, 2]
        got = lightmap.sample(result.image, q[None])[0, 0]
        assert got == pytest.approx(floor_irradiance_by_brute_force(x), rel=0.03), x


def test_a_closed_box_converges_to_its_series():
    """A closed cube of albedo a lit only by emission e of every wall: the radiance is
    e / (1 - a) everywhere, so the irradiance the lightmap holds (without the walls' own
    emission, which is not indirect light) is pi (e / (1 - a))."""
    a, e = 0.6, 0.2
    faces = [quad(c, u, v) for c, u, v in [
        ([0, 0, 1], [0, 1, 0], [1, 0, 0]), ([0, 0, -1], [1, 0, 0], [0, 1, 0]),
        ([1, 0, 0], [0, 0, 1], [0, 1, 0]), ([-1, 0, 0], [0, 1, 0], [0, 0, 1]),
        ([0, 1, 0], [1, 0, 0], [0, 0, 1]), ([0, -1, 0], [0, 0, 1], [1, 0, 0])]]  # inwards
    p = np.concatenate([f[0] for f in faces])
    n = np.concatenate([f[1] for f in faces])
    mat = Material.talk("Wall", albedo=(a, a, a), rf0=(0, 0, 0), emission=(e, e, e))
    scene = Scene(Camera.look_at([0, 0, 0], [1, 0, 0], 1.0, 8, 8),
                  [MeshBatch(p, n, np.zeros(len(p), np.int32), name="box")], [mat], [],
                  World(color=np.zeros(3, np.float32)))
    uv, w, h, _ = lightmap.layout(p, 8.0)
    out = {}
    for bounces in (1, 4, 6):
        (r,) = lightmap_bake.bake(RenderJob(scene), [lightmap.Target("box", 0, uv, w, h)],
                                  lightmap.Settings(rays=128, bounces=bounces))
        out[bounces] = float(np.median(r.image[r.image[..., 0] > 0][:, 0]))
    assert out[1] == pytest.approx(np.pi * e, rel=0.02)  # one gather: the walls' emission
    truth = np.pi * e / (1 - a)
    assert out[4] == pytest.approx(truth, rel=0.04)  # three gathers and the series' tail
    assert out[6] == pytest.approx(truth, rel=0.04)


def test_direct_light_bounces_into_the_lightmap_and_shadows_count():
    scene = open_floor(wall_albedo=0.8, sky=0.0)
    sun = Light("SUN", np.full(3, 3.0, np.float32), direction=np.array([0.6, 0.0, -0.8]))
    scene.lights = [sun]
    uv, w, h, _ = lightmap.layout(scene.meshes[0].positions, 10.0)
    (floor,) = lightmap_bake.bake(RenderJob(scene), [lightmap.Target("floor", 0, uv, w, h)],
                                  lightmap.Settings(rays=128, bounces=1))
    # the wall, lit by the sun (cos 0.6 of 3 W/m^2), throws light back on the floor: more the
    # nearer the wall
    near = lightmap.sample(floor.image, np.array([[0.95, 0.5]]))[0, 0]
    far = lightmap.sample(floor.image, np.array([[0.1, 0.5]]))[0, 0]
    assert near > 2 * far > 0.0


def denoise_reference(image, chart, position, normal, variance, texel: float, levels: int = 3,
                      sigma_normal: float = 0.1, sigma_luminance: float = 4.0) -> np.ndarray:
    """``lightmap.denoise`` in NumPy, tap by tap over whole images: the reference its
    kernel (``kernels.lightmap.atrous``) is held to."""
    h, w, c = image.shape
    valid = chart >= 0
    luma = np.array([0.2126, 0.7152, 0.0722])[:c] if c == 3 else None
    out = image.astype(np.float64)
    var = np.asarray(variance, np.float64)
    kernel = np.array([1.0, 4.0, 6.0, 4.0, 1.0]) / 16.0
    for level in range(levels):
        step = 1 << level
        pad = 2 * step
        img = np.pad(out, ((pad, pad), (pad, pad), (0, 0)))
        ch = np.pad(chart, pad, constant_values=-1)
        pos = np.pad(position.astype(np.float64), ((pad, pad), (pad, pad), (0, 0)))
        nor = np.pad(normal.astype(np.float64), ((pad, pad), (pad, pad), (0, 0)))
        lum = (out[..., :3] @ luma if luma is not None else out[..., 0])
        lum_p = np.pad(lum, pad)
        scale = sigma_luminance * np.sqrt(var) + 1e-6 * (np.abs(lum) + 1e-6)
        acc = np.zeros_like(out)
        total = np.zeros((h, w))
        for a in range(5):
            for b in range(5):
                dy, dx = (a - 2) * step, (b - 2) * step
                win = (slice(pad + dy, pad + dy + h), slice(pad + dx, pad + dx + w))
                same = (ch[win] == chart) & valid
                plane = np.abs(((pos[win] - position) * normal).sum(-1)) / max(texel, 1e-6)
                bend = (1.0 - (nor[win] * normal).sum(-1)) / sigma_normal
                shade = np.abs(lum_p[win] - lum) / scale
                wgt = same * kernel[a] * kernel[b] * np.exp(-plane - bend - shade)
                acc += wgt[..., None] * img[win]
                total += wgt
        out = np.where(valid[..., None], acc / np.maximum(total, 1e-30)[..., None], out)
        var = var / 4.0
    return out.astype(np.float32)


def test_the_denoise_kernel_matches_its_reference():
    """Two charts, a curved one, noise, varying variance, 1 and 3 channels and 12, and a band
    size that splits the rows: the kernel's levels equal the NumPy reference's."""
    rng = np.random.default_rng(5)
    h, w = 40, 56
    chart = np.full((h, w), -1)
    chart[3:37, 2:30] = 0
    chart[5:30, 33:54] = 1
    ys, xs = np.mgrid[0:h, 0:w]
    pos = np.stack([xs * 0.05, ys * 0.05, 0.02 * np.sin(xs * 0.3)], -1).astype(np.float32)
    nor = np.stack([-0.006 * np.cos(xs * 0.3), np.zeros_like(pos[..., 0]),
                    np.ones_like(pos[..., 0])], -1)
    nor = (nor / np.linalg.norm(nor, axis=-1, keepdims=True)).astype(np.float32)
    var = rng.uniform(0.001, 0.05, (h, w)).astype(np.float32)
    band = lightmap.BAND
    lightmap.BAND = 7 * w  # several bands
    try:
        for c in (3, 1, 12):
            noisy = rng.uniform(0.2, 2.0, (h, w, c)).astype(np.float32)
            got = lightmap.denoise(noisy, chart, pos, nor, var, texel=0.05)
            want = denoise_reference(noisy, chart, pos, nor, var, texel=0.05)
            np.testing.assert_allclose(got, want, rtol=2e-5, atol=2e-6)
    finally:
        lightmap.BAND = band
    steps = list(lightmap.denoise_steps(noisy, chart, pos, nor, var, texel=0.05))
    assert steps == sorted(steps) and steps[-1] == 1.0


def dilate_reference(image: np.ndarray, valid: np.ndarray, passes: int = 16) -> np.ndarray:
    """``lightmap.dilate`` in NumPy, a pass over whole shifted images: its kernel's
    reference."""
    out = np.where(valid[..., None], image, 0.0).astype(np.float32)
    have = valid.copy()
    h, w = have.shape
    for _ in range(passes):
        if have.all():
            break
        total = np.zeros_like(out)
        count = np.zeros((h, w), np.float32)
        padded = np.pad(out, ((1, 1), (1, 1), (0, 0)))
        mask = np.pad(have, 1).astype(np.float32)
        for dy in (-1, 0, 1):
            for dx in (-1, 0, 1):
                if dx == dy == 0:
                    continue
                m = mask[1 + dy:1 + dy + h, 1 + dx:1 + dx + w]
                total += padded[1 + dy:1 + dy + h, 1 + dx:1 + dx + w] * m[..., None]
                count += m
        grow = ~have & (count > 0)
        if not grow.any():
            break
        out[grow] = total[grow] / count[grow, None]
        have = have | grow
    return out


def test_the_dilate_kernel_matches_its_reference():
    rng = np.random.default_rng(9)
    image = rng.uniform(0.0, 4.0, (37, 53, 3)).astype(np.float32)
    valid = np.zeros((37, 53), bool)
    valid[5:20, 4:17] = True
    valid[25:30, 30:50] = True
    valid[33, 2] = True
    for passes in (1, 3, 16, 60):
        np.testing.assert_allclose(lightmap.dilate(image, valid, passes),
                                   dilate_reference(image, valid, passes), rtol=1e-6)


def test_clean_up():
    rng = np.random.default_rng(0)
    h, w = 32, 32
    chart = np.full((h, w), -1)
    chart[4:28, 4:15] = 0
    chart[4:28, 17:28] = 1
    truth = np.where(chart[..., None] == 0, 1.0, 3.0).astype(np.float32) * np.ones((1, 1, 3))
    noisy = (truth * (1 + 0.2 * rng.normal(size=truth.shape))).astype(np.float32)
    ys, xs = np.mgrid[0:h, 0:w]
    pos = np.stack([xs * 0.05, ys * 0.05, np.zeros_like(xs)], -1).astype(np.float32)
    nor = np.broadcast_to(np.array([0, 0, 1], np.float32), (h, w, 3)).copy()
    var = np.full((h, w), (0.2 * 2.0) ** 2 / 3, np.float32)
    clean = lightmap.denoise(noisy, chart, pos, nor, var, texel=0.05)
    inside = chart >= 0
    err = lambda a: np.abs(a - truth)[inside].mean()  # noqa: E731
    assert err(clean) < 0.4 * err(noisy)
    # nothing leaks from one chart into the next
    assert np.abs(clean[chart == 0] - 1.0).mean() < 0.05
    assert np.abs(clean[chart == 1] - 3.0).mean() < 0.15
    # dilation fills the padding from the charts only
    full = lightmap.dilate(clean, inside, passes=8)
    assert np.isfinite(full).all() and (full > 0).all()
    assert np.allclose(full[inside], clean[inside])


def test_seams_are_stitched():
    """A cube's layout puts neighbouring faces in different charts: after stitching, the values
    on both sides of every seam agree far better than the texels beside them differ."""
    faces = [quad(c, u, v)[0] for c, u, v in [
        ([0, 0, 1], [1, 0, 0], [0, 1, 0]), ([0, 0, -1], [0, 1, 0], [1, 0, 0]),
        ([1, 0, 0], [0, 1, 0], [0, 0, 1]), ([-1, 0, 0], [0, 0, 1], [0, 1, 0]),
        ([0, 1, 0], [0, 0, 1], [1, 0, 0]), ([0, -1, 0], [1, 0, 0], [0, 0, 1])]]
    p = np.concatenate(faces)
    uv, w, h, _ = lightmap.layout(p, 8.0)
    seam = lightmap.seams(p, uv)
    assert len(seam) >= 12  # the cube's 12 edges, at least, cut
    # smooth light over each chart, but each chart off by its own amount: jumps at every seam
    island = lightmap.uv_islands(uv)
    from bo2_lighting.addon.core.kernels import lightmap as k

    tri = np.full(w * h, -1, np.int32)
    bary = np.zeros((w * h, 3), np.float32)
    k.texels(np.ascontiguousarray(uv), w, h, k.SUBSAMPLES, tri, bary)
    point = np.einsum("nk,nkc->nc", bary, p[np.maximum(tri, 0)])
    offset = np.random.default_rng(1).random(island.max() + 1)
    value = 1.0 + 0.2 * point[:, 0] + np.where(tri >= 0, offset[island[np.maximum(tri, 0)]], 0)
    image = lightmap.dilate(np.repeat(value[:, None], 3, 1).reshape(h, w, 3).astype(np.float32),
                            (tri >= 0).reshape(h, w))
    before, _ = lightmap.seam_jumps(image, seam)
    stitched = lightmap.stitch(image, seam)
    after, beside = lightmap.seam_jumps(stitched, seam)
    assert before.mean() > 0.1
    assert after.max() < beside.max() and after.mean() < 0.1 * before.mean()


def test_files_round_trip_and_refuse_damage(tmp_path):
    lm = lightmap.Lightmap(np.random.default_rng(0).random((8, 6, 12)).astype(np.float32),
                           np.random.default_rng(1).random((5, 3, 2)).astype(np.float32))
    path = tmp_path / "A.exr"
    lightmap_file.write_all([(path, {"object": "A"}, lm)])
    meta, back = lightmap_file.read(path)
    assert meta["object"] == "A" and back.directional
    assert np.array_equal(back.image, lm.image) and np.array_equal(back.uvs, lm.uvs)
    path.write_bytes(path.read_bytes()[: path.stat().st_size // 2])  # truncated
    with pytest.raises(bake_file.BakeFileError):
        lightmap_file.read(path)
    with pytest.raises(bake_file.BakeFileError, match="no baked lightmap"):
        lightmap_file.read(tmp_path / "missing.exr")
    # all or nothing: a failure in the second file leaves the first one's old content
    good = tmp_path / "B.exr"
    lightmap_file.write_all([(good, {"object": "B"}, lm)])
    before = good.read_bytes()
    with pytest.raises(OSError):  # the second file's folder cannot be made: B.exr is a file
        lightmap_file.write_all([(good, {"object": "B2"}, lm), (good / "C.exr", {}, lm)])
    assert good.read_bytes() == before and not list(tmp_path.glob(".*.tmp"))


def test_a_stopped_bake_raises_and_the_renderer_reads_lightmaps():
    scene = open_floor()
    uv, w, h, _ = lightmap.layout(scene.meshes[0].positions, 10.0)
    target = lightmap.Target("floor", 0, uv, w, h)
    with pytest.raises(Cancelled):
        lightmap_bake.bake(RenderJob(scene, should_stop=lambda: True), [target],
                           lightmap.Settings(rays=16))
    (lm,) = lightmap_bake.bake(RenderJob(scene), [target], lightmap.Settings(rays=64, bounces=1))
    scene.probes = core_bake.world_probes(scene.world, 16)
    plain = pipeline.render_frame(RenderJob(scene))["DiffInd"]
    scene.meshes[0].lightmap = lm
    lit = pipeline.render_frame(RenderJob(scene))["DiffInd"]
    # the floor by the wall: the world fallback sees the whole sky, the lightmap the wall too
    row = lit.shape[0] // 2  # column c is at x = (c + 0.5) / 48 * 8.2 - 4.1 m
    near = floor_irradiance_by_brute_force(1.62)
    assert lit[row, 33, 0] == pytest.approx(0.5 * near / np.pi, rel=0.05)
    assert plain[row, 33, 0] > 1.2 * lit[row, 33, 0]
    far = floor_irradiance_by_brute_force(-0.94)
    assert lit[row, 18, 0] == pytest.approx(0.5 * far / np.pi, rel=0.03)
    # the Lightmap pass holds the irradiance, Lightmap Texels a checker of the floor's texels
    passes = pipeline.render_frame(RenderJob(scene))
    assert passes["Lightmap"][row, 18, 0] == pytest.approx(far, rel=0.03)
    texels = passes["Lightmap Texels"][row, 14:22, 0]
    assert texels.min() > 0 and len(np.unique(np.round(texels, 2))) >= 2
    assert passes["Lightmap"][row, 40].max() == 0.0  # the wall has no lightmap
    scene.settings.lightmaps = False
    assert np.array_equal(pipeline.render_frame(RenderJob(scene))["DiffInd"], plain)


def test_directional_lightmaps_keep_the_irradiance_at_the_normal():
    scene = open_floor()
    uv, w, h, _ = lightmap.layout(scene.meshes[0].positions, 10.0)
    target = lightmap.Target("floor", 0, uv, w, h)
    settings = lightmap.Settings(rays=128, bounces=1, denoise=False)
    (flat,) = lightmap_bake.bake(RenderJob(scene), [target], settings)
    (sh,) = lightmap_bake.bake(RenderJob(scene), [target], lightmap.Settings(
        rays=128, bounces=1, denoise=False, directional=True))
    assert sh.directional and sh.image.shape == flat.image.shape[:2] + (12,)
    from bo2_lighting.addon.core.formulas import sh as core_sh

    q = np.array([[0.8, 0.5], [0.3, 0.5]])
    coeffs = lightmap.as_sh(lightmap.sample(sh.image, q))
    up = [core_sh.irradiance(c, np.array([[0.0, 0.0, 1.0]]))[0, 0] for c in coeffs]
    assert up == pytest.approx(lightmap.sample(flat.image, q)[:, 0], rel=0.02)
    # by the wall the sky comes from -x: a normal tilted away from the wall gets more
    tilted = core_sh.irradiance(coeffs[0], np.array([[-0.5, 0.0, 0.866]]))
    towards = core_sh.irradiance(coeffs[0], np.array([[0.5, 0.0, 0.866]]))
    assert tilted[0, 0] > 1.1 * towards[0, 0]


def test_keys_tell_what_changed():
    scene = open_floor()
    key = lightmap_bake.light_key(scene)
    geo = lightmap_bake.geometry_key(scene.meshes[0].positions)
    scene.lights.append(Light("POINT", np.full(3, 10.0, np.float32)))
    assert lightmap_bake.light_key(scene) != key
    moved = scene.meshes[0].positions + np.float32(0.01)
    assert lightmap_bake.geometry_key(moved) != geo
    assert lightmap.memory_bytes(256, 128, False) == 256 * 128 * 12
    assert lightmap.memory_bytes(256, 128, True) == 256 * 128 * 48


def test_broken_meshes_bake_finite_lightmaps():
    """A zero-area triangle, a third face on the floor's diagonal (a non-manifold edge) and a
    NaN corner: the layout has no overlap, the lightmap is finite."""
    floor, fn = quad([0, 0, 0], [1, 0, 0], [0, 1, 0])  # its diagonal: (-1, -1) to (1, 1)
    flat = np.array([[[0, 0, 0], [0.5, 0, 0], [1, 0, 0]]], np.float32)
    fan = np.array([[[-1, -1, 0], [1, 1, 0], [0, 0, 1]]], np.float32)
    broken = np.array([[[0, 0, 0], [np.nan, 0, 0], [0, 1, 0]]], np.float32)
    p = np.concatenate([floor, flat, fan, broken])
    n = np.ascontiguousarray(np.concatenate([fn, np.repeat(fn[:1], 3, 0)]), np.float32)
    ok = np.isfinite(p).all(axis=(1, 2))
    uv, w, h, _ = lightmap.layout(np.where(ok[:, None, None], p, 0.0), 8.0)
    assert lightmap.overlaps(uv[ok], w, h) == 0
    mesh = MeshBatch(p, n, np.zeros(len(p), np.int32), name="broken")
    scene = Scene(Camera.look_at([0, -3, 2], [0, 0, 0], 1.0, 8, 8), [mesh], [Material.talk()],
                  [Light("SUN", np.full(3, 2.0, np.float32))],
                  World(color=np.full(3, 0.5, np.float32)))
    (lm,) = lightmap_bake.bake(RenderJob(scene), [lightmap.Target("broken", 0, uv, w, h)],
                               lightmap.Settings(rays=16, bounces=2))
    assert np.isfinite(lm.image).all() and lm.image.max() > 0.0
