"""Depth of field: the thin lens's blur against its closed form.

Independent values: an emitting half-plane's edge at depth z seen through a lens of radius a
focused at s is the pinhole image convolved with a disc of radius R = a |1/s - 1/z| (tangent
units, times the projection's scale to pixels); across a straight edge the disc's share on one
side of a line at signed distance t is (acos(t/R) - (t/R) sqrt(1 - (t/R)^2)) / pi.
"""

import numpy as np
import pytest

from bo2_lighting.addon.core.render import depth_of_field, pipeline
from bo2_lighting.addon.core.render.job import RenderJob
from bo2_lighting.addon.core.scene import (
    Aperture,
    Camera,
    Material,
    MeshBatch,
    RenderSettings,
    Scene,
    World,
)

W, H = 96, 16


def edge_scene(depth: float, aperture: Aperture | None, samples: int = 256):
    """An emitting half-plane x < 0 at distance ``depth`` ahead of a camera at the origin
    looking down -Y (Z up), black beyond; pixel filter off (every sample at the centre)."""
    cam = Camera.look_at([0, 0, 0], [0, 1, 0], np.radians(20.0), W, H, near=0.05, far=100.0)
    cam.aperture = aperture
    big = 50.0
    quad = np.array([[-big, depth, -big], [0, depth, -big], [0, depth, big], [-big, depth, big]],
                    np.float32)
    tris = quad[[[0, 2, 1], [0, 3, 2]]]
    normals = np.broadcast_to(np.float32([0, -1, 0]), tris.shape).copy()
    glow = Material.talk(name="glow", albedo=np.zeros(3, np.float32),
                         rf0=np.zeros(3, np.float32), gloss=0.0,
                         emission=np.ones(3, np.float32))
    return Scene(cam, [MeshBatch(tris, normals, np.array([1, 1], np.int32))],
                 [Material(), glow], [], World(color=np.zeros(3, np.float32)),
                 RenderSettings(samples=samples, filter_width=0.0))


def disc_share(t: np.ndarray) -> np.ndarray:
    """The share of a unit disc on the far side of a line at signed distance ``t``."""
    t = np.clip(t, -1.0, 1.0)
    return (np.arccos(t) - t * np.sqrt(1.0 - t * t)) / np.pi


@pytest.mark.parametrize("depth", [1.0, 2.0, 6.0])
def test_an_edge_blurs_by_the_circle_of_confusion(depth):
    """Focused at 2 m, aperture radius 40 cm: the edge at 1 m and 6 m spreads over the disc's
    profile (within 0.03 of the closed form over the row), the edge at 2 m stays as sharp as
    a pinhole's."""
    aperture = Aperture(radius=0.4, focus=2.0)
    image = pipeline.render_frame(RenderJob(edge_scene(depth, aperture)))["Combined"]
    row = image[H // 2, :, 0]
    cam = edge_scene(depth, aperture).camera
    scale = cam.projection[0, 0] * W / 2.0  # pixels per tangent unit
    radius = aperture.radius * abs(1.0 / aperture.focus - 1.0 / depth) * scale
    x = np.arange(W) + 0.5 - W / 2.0  # the pixel centres' distance from the edge, pixels
    if radius < 0.5:
        pinhole = pipeline.render_frame(RenderJob(edge_scene(depth, None)))["Combined"]
        np.testing.assert_allclose(row, pinhole[H // 2, :, 0], atol=1e-6)
        return
    expected = disc_share(x / radius)
    print(f"depth {depth}: blur radius {radius:.2f} px; largest error "
          f"{np.abs(row - expected).max():.4f}")
    assert radius > 3.0
    np.testing.assert_allclose(row, expected, atol=0.03)


def test_apertures_are_discs_and_polygons_of_their_area():
    """Lens points fill the disc or polygon uniformly (their mean at the centre, their mean
    squared distance that of the shape), inside it, the width divided by the ratio."""
    n = np.arange(4096)
    disc = depth_of_field.lens_points(Aperture(0.02, 1.0), n) / 0.02
    assert np.abs(disc.mean(0)).max() < 0.01
    assert (disc ** 2).sum(1).mean() == pytest.approx(0.5, abs=0.01)  # r^2 / 2
    hexagon = depth_of_field.lens_points(Aperture(1.0, 1.0, blades=6, rotation=0.3), n)
    angles = 0.3 + np.arange(6) * np.pi / 3
    # inside: on the centre's side of every edge (the apothem cos(pi/6) from it)
    normals = np.stack([np.cos(angles + np.pi / 6), np.sin(angles + np.pi / 6)], -1)
    assert (hexagon @ normals.T <= np.cos(np.pi / 6) + 1e-9).all()
    # a regular n-gon of circumradius 1: E|p|^2 = (1 + 2 cos^2(pi/n)) / 6
    assert (hexagon ** 2).sum(1).mean() == pytest.approx((1 + 2 * np.cos(np.pi / 6) ** 2) / 6,
                                                          abs=0.01)
    wide = depth_of_field.lens_points(Aperture(1.0, 1.0, ratio=2.0), n)
    assert np.abs(wide[:, 0]).max() <= 0.5 + 1e-9 and np.abs(wide[:, 1]).max() > 0.95
