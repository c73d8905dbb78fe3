"""Render the pictures of docs/model.md with the core pipeline alone (no Blender needed).

Usage: python tools/make_docs_images.py [OUT_DIR]   (default docs/images)

``specular_models.png``: one row per direct specular model of ``brdf.MODELS`` (top to bottom),
spheres of gloss 0, 0.25, 0.5, 0.75 and 1 (left to right), dielectric rf0 = 0.04 over a black
albedo, lit by a point light from behind on the right, whose highlights sit at grazing angles
where the visibility terms differ most, and by a weaker light near the camera.
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

from bo2_lighting.addon.core.formulas import brdf, texture
from bo2_lighting.addon.core.render import pipeline
from bo2_lighting.addon.core.render.job import RenderJob
from bo2_lighting.addon.core.review import imaging
from bo2_lighting.addon.core.scene import Camera, Light, Material, MeshBatch, RenderSettings, Scene

ROOT = Path(__file__).resolve().parent.parent

GLOSSES = (0.0, 0.25, 0.5, 0.75, 1.0)


def uv_sphere(center, radius, segments=96, rings=48):
    """(T, 3, 3) positions and exact normals of a UV sphere, counter-clockwise outside."""
    theta = np.linspace(0, np.pi, rings + 1)
    phi = np.linspace(0, 2 * np.pi, segments + 1)
    t, p = np.meshgrid(theta, phi, indexing="ij")
    n = np.stack([np.sin(t) * np.cos(p), np.sin(t) * np.sin(p), np.cos(t)], -1)
    a, b, c, d = n[:-1, :-1], n[1:, :-1], n[1:, 1:], n[:-1, 1:]
    tris = np.concatenate([np.stack([a, b, c], 2).reshape(-1, 3, 3),
                           np.stack([a, c, d], 2).reshape(-1, 3, 3)])
    return (tris * radius + center).astype(np.float32), tris.astype(np.float32)


def model_row(model: str, width=600, height=130) -> np.ndarray:
    meshes, materials = [], [Material()]
    for i, g in enumerate(GLOSSES):
        pos, nrm = uv_sphere(np.array([(i - 2) * 1.15, 0.0, 0.0]), 0.5)
        materials.append(Material.talk(name=f"g{g}", albedo=np.zeros(3, np.float32),
                                  rf0=np.full(3, 0.04, np.float32), gloss=g))
        meshes.append(MeshBatch(pos, nrm, np.full(len(pos), i + 1, np.int32)))
    grazing = Light("POINT", color=np.full(3, 3000.0), position=np.array([6.0, 3.0, 2.0]),
                    shadow=False)  # the spheres would shadow their neighbours
    frontal = Light("POINT", color=np.full(3, 300.0), position=np.array([-2.0, -6.0, 2.0]),
                    shadow=False)
    cam = Camera.look_at([0.0, -9.0, 0.0], [0.0, 0.0, 0.0], np.radians(8.6), width, height)
    scene = Scene(camera=cam, meshes=meshes, materials=materials, lights=[grazing, frontal],
                  settings=RenderSettings(samples=8, specular_model=model))
    scene.world.color = np.full(3, 0.02, np.float32)
    return pipeline.render_frame(RenderJob(scene))["Combined"][..., :3]


def main() -> int:
    out = Path(sys.argv[1]) if len(sys.argv) > 1 else ROOT / "docs" / "images"
    out.mkdir(parents=True, exist_ok=True)
    rows = [model_row(m) for m in brdf.MODELS]
    gap = np.full((4, rows[0].shape[1], 3), 0.2, np.float32)
    image = np.concatenate([x for r in rows for x in (r, gap)][:-1])
    path = out / "specular_models.png"
    imaging.write_png(path, texture.linear_to_srgb(np.clip(image, 0.0, 1.0)))
    print(f"wrote {path} (rows: {', '.join(brdf.MODELS)})")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
