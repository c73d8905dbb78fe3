"""Hair tubes and point spheres against the round surfaces Cycles renders: the tube's mean
projected width 2 r and the sphere's area 4 pi r^2 (closed forms), outward faces, frames
carried along a helix without flips."""

import numpy as np
import pytest

from bo2_lighting.addon.core.scene import strands


def face_normals(tris):
    return np.cross(tris[:, 1] - tris[:, 0], tris[:, 2] - tris[:, 0])


def test_a_tube_is_as_wide_as_a_round_one_on_average_and_faces_out():
    r = 0.01
    pts = np.stack([np.zeros(5), np.zeros(5), np.linspace(0, 1, 5)], -1).astype(np.float32)
    tris, normals, curve = strands.tubes(pts, np.full(5, r, np.float32), np.array([0, 5]))
    assert tris.shape == (4 * 2 * strands.TUBE_SIDES, 3, 3) and (curve == 0).all()
    radial = tris.mean(1) * np.float32([1, 1, 0])
    assert (np.einsum("nk,nk->n", face_normals(tris), radial) > 0).all()
    assert (np.einsum("nck,nck->nc", normals, tris * np.float32([1, 1, 0])) > 0).all()
    ring = tris[:, :, :2].reshape(-1, 2)
    widths = []
    for phi in np.linspace(0, np.pi, 721)[:-1]:  # views across the axis
        proj = ring @ np.array([np.cos(phi), np.sin(phi)])
        widths.append(proj.max() - proj.min())
    assert np.mean(widths) == pytest.approx(2 * r, rel=0.002)


def test_frames_follow_a_helix_without_flips():
    t = np.linspace(0, 6 * np.pi, 200)
    pts = np.stack([np.cos(t), np.sin(t), 0.1 * t], -1).astype(np.float32)
    tangent, across = strands.curve_frames(pts, np.array([0, 200]))
    assert np.abs(np.einsum("nk,nk->n", tangent, across)).max() < 1e-6
    assert np.einsum("nk,nk->n", across[1:], across[:-1]).min() > 0.99


def test_spheres_have_the_area_of_the_sphere_and_face_out():
    centres = np.array([[0, 0, 0], [3, 1, 2]], np.float32)
    radii = np.array([0.5, 2.0], np.float32)
    tris, normals = strands.spheres(centres, radii)
    assert tris.shape == (40, 3, 3)
    for k, (c, r) in enumerate(zip(centres, radii, strict=True)):
        part = tris[20 * k:20 * k + 20]
        area = 0.5 * np.linalg.norm(face_normals(part), axis=1).sum()
        assert area == pytest.approx(4 * np.pi * r * r, rel=1e-5)
        assert (np.einsum("nk,nk->n", face_normals(part), part.mean(1) - c) > 0).all()
        np.testing.assert_allclose(np.linalg.norm(normals[20 * k:20 * k + 20], axis=-1), 1.0,
                                   rtol=1e-6)
