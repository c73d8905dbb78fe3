"""Small scenes built from the core's dataclasses for the GPU tests: a ground, a box and a
sphere under lights of every kind, seen by a perspective or an orthographic camera."""

import numpy as np

from bo2_lighting.addon.core.scene import (
    Camera,
    Light,
    Material,
    MeshBatch,
    RenderSettings,
    Scene,
    World,
    program,
)


def box(lo, hi) -> np.ndarray:
    lo, hi = np.array(lo, float), np.array(hi, float)
    c = np.array([[(lo, hi)[(k >> a) & 1][a] for a in range(3)] for k in range(8)])
    quads = [(0, 1, 3, 2), (4, 6, 7, 5), (0, 4, 5, 1), (2, 3, 7, 6), (0, 2, 6, 4), (1, 5, 7, 3)]
    return np.array([[c[q[0]], c[q[i]], c[q[i + 1]]] for q in quads for i in (1, 2)],
                    np.float32)


def flat_normals(tris: np.ndarray) -> np.ndarray:
    n = np.cross(tris[:, 1] - tris[:, 0], tris[:, 2] - tris[:, 0])
    n /= np.linalg.norm(n, axis=1, keepdims=True)
    return np.repeat(n[:, None], 3, 1).astype(np.float32)


def sphere(centre, radius: float, rings: int = 24):
    """Triangles (T, 3, 3) and smooth corner normals of a UV sphere."""
    th = np.linspace(0, np.pi, rings + 1)
    ph = np.linspace(0, 2 * np.pi, 2 * rings + 1)

    def at(i, j):
        return np.array([np.sin(th[i]) * np.cos(ph[j]), np.sin(th[i]) * np.sin(ph[j]),
                         np.cos(th[i])])

    tris, normals = [], []
    for i in range(rings):
        for j in range(2 * rings):
            a, b, c, d = at(i, j), at(i + 1, j), at(i + 1, j + 1), at(i, j + 1)
            for q in ((a, b, c), (a, c, d)):
                if np.linalg.norm(np.cross(q[1] - q[0], q[2] - q[0])) > 1e-9:
                    tris.append([np.asarray(centre) + radius * x for x in q])
                    normals.append(list(q))
    return np.array(tris, np.float32), np.array(normals, np.float32)


def look_at(eye, target) -> np.ndarray:
    f = np.asarray(target, float) - eye
    f /= np.linalg.norm(f)
    r = np.cross(f, [0, 0, 1])
    r /= np.linalg.norm(r)
    m = np.eye(4)
    m[:3, :3] = np.stack([r, np.cross(r, f), -f])
    m[:3, 3] = -m[:3, :3] @ eye
    return m


def perspective(focal: float, aspect: float, near=0.1, far=100.0) -> np.ndarray:
    return np.array([[focal, 0, 0, 0], [0, focal * aspect, 0, 0],
                     [0, 0, -(far + near) / (far - near), -2 * far * near / (far - near)],
                     [0, 0, -1, 0]])


def orthographic(half_width: float, aspect: float, near=0.1, far=100.0) -> np.ndarray:
    return np.array([[1 / half_width, 0, 0, 0], [0, aspect / half_width, 0, 0],
                     [0, 0, -2 / (far - near), -(far + near) / (far - near)], [0, 0, 0, 1]])


def _unit(v) -> np.ndarray:
    v = np.asarray(v, float)
    return v / np.linalg.norm(v)


LIGHTS = {
    "POINT": Light("POINT", np.array([80.0, 70, 60]), position=np.array([1.0, -2.0, 3.0]),
                   radius=0.2),
    "SPOT": Light("SPOT", np.array([200.0, 200, 220]), position=np.array([-3.0, 2.0, 4.0]),
                  direction=_unit([0.5, -0.3, -0.8]), spot_size=0.9, radius=0.05),
    "SUN": Light("SUN", np.array([1.5, 1.4, 1.2]), direction=_unit([-0.4, 0.6, -0.7]),
                 radius=np.radians(2.0)),
    "AREA": Light("AREA", np.array([60.0, 60, 80]), position=np.array([2.5, 1.5, 2.0]),
                  direction=_unit([-0.5, -0.3, -0.8]), size=np.array([0.6, 0.4])),
}


def objects_scene(lights, width=320, height=180, ortho=False, samples=4, model="reference",
                  emission=False) -> Scene:
    """A ground, a box and a metal sphere (and a glowing cube with ``emission``)."""
    ground = np.array([[[-5, -5, 0], [5, -5, 0], [5, 5, 0]], [[-5, -5, 0], [5, 5, 0],
                                                              [-5, 5, 0]]], np.float32)
    cube = box([-1.5, -0.5, 0], [-0.5, 0.5, 1.0])
    ball, ball_n = sphere([0.8, 0.2, 0.7], 0.7)
    cube_uv = (cube[..., [0, 2]] - cube[..., [0, 2]].min((0, 1))).astype(np.float32)
    meshes = [MeshBatch(ground, flat_normals(ground), np.zeros(2, np.int32)),
              MeshBatch(cube, flat_normals(cube), np.full(len(cube), 1, np.int32),
                        uvs=cube_uv),
              MeshBatch(ball, ball_n, np.full(len(ball), 2, np.int32))]
    mats = [Material("ground", program.talk_program((0.6, 0.6, 0.6), (0.04,) * 3, 0.3)),
            Material("box", program.talk_program((0.7, 0.2, 0.1), (0.04,) * 3, 0.6),
                     pass_index=3),
            Material("metal", program.talk_program((0.0, 0.0, 0.0), (0.9, 0.7, 0.4), 0.8))]
    if emission:
        glow = box([1.8, -1.8, 0.0], [2.2, -1.4, 0.4])
        meshes.append(MeshBatch(glow, flat_normals(glow), np.full(len(glow), 3, np.int32)))
        mats.append(Material("glow", program.talk_program((0.2,) * 3, (0.04,) * 3, 0.5,
                                                          emission=(4.0, 2.0, 0.5))))
    eye = np.array([4.5, -5.5, 3.2])
    proj = (orthographic(3.2, width / height) if ortho else perspective(1.6, width / height))
    cam = Camera(look_at(eye, [0, 0, 0.6]), proj, width, height, orthographic=ortho)
    return Scene(cam, meshes, mats, list(lights),
                 World(color=np.array([0.05, 0.06, 0.08], np.float32)),
                 RenderSettings(samples=samples, specular_model=model))


def _chain(rng, size, tint):
    """A smooth-ish random cube-map chain (6, S, S, 3) per level, S, S/2, ..., 1."""
    out = []
    while size >= 1:
        base = rng.uniform(0.6, 1.4, (6, 1, 1, 3)) * tint
        noise = rng.uniform(0.8, 1.2, (6, size, size, 3))
        out.append((base * noise).astype(np.float32))
        size //= 2
    return out


def with_probes(scene: Scene, volume: bool = True, seed: int = 2) -> Scene:
    """``scene`` lit by a sky-blue world (its SH and chain), a reflection probe with a box
    proxy over the objects and, with ``volume``, an irradiance volume around them."""
    import dataclasses

    from bo2_lighting.addon.core.lighting import probes as cp

    rng = np.random.default_rng(seed)
    dc = np.eye(9, 3)[:, :1] * np.ones(3)
    world_sh = (rng.normal(size=(9, 3)) * 0.05 + dc * [0.5, 0.6, 0.8]).astype(np.float32)
    sky = np.array([0.5, 0.6, 0.8])
    probes = cp.Probes(
        world_sh=world_sh, world_mips={"bo2": _chain(rng, 32, sky), "bo1": _chain(rng, 32, sky)},
        reflection=[cp.ReflectionProbe(
            "R", np.array([0.5, 0.0, 1.0]), 3.0, 0.3,
            {"bo2": _chain(rng, 32, [0.8, 0.7, 0.6]), "bo1": _chain(rng, 32, [0.8, 0.7, 0.6])},
            (dc * 1.2).astype(np.float32), proxy="box",
            proxy_to_world=np.diag([3.0, 3.0, 2.0, 1.0]))])
    if volume:
        to_world = np.diag([2.0, 2.0, 1.5, 1.0])
        to_world[:3, 3] = [0.0, 0.0, 1.5]
        probes.volumes.append(cp.IrradianceVolume(
            "V", to_world, (4, 4, 3),
            (rng.normal(size=(4, 4, 3, 9, 3)) * 0.1 + dc * 0.8).astype(np.float32),
            influence=0.5, facing_bias=0.2))
    return dataclasses.replace(scene, probes=probes)
