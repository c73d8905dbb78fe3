"""Cryptomatte passes against published values and a brute-force count.

Independent values: MurmurHash3_x86_32 of "hello" (SMHasher's reference implementation); the
ids and metadata keys Cycles wrote for the same names (Blender 5.0, a multilayer EXR of a
scene with objects "Floor", "A", "B" and a parent "Rig"); per pixel the names its samples see,
counted one by one.
"""

import collections
import json

import numpy as np
import pytest
from test_pipeline import H, W, floor, lambert_scene

from bo2_lighting.addon.core.render import cryptomatte, pipeline
from bo2_lighting.addon.core.render.job import RenderJob
from bo2_lighting.addon.core.scene import Light, Material, RenderSettings


def test_hashes_are_murmur3_as_cycles_writes_them():
    assert cryptomatte.murmur3_32(b"") == 0
    assert cryptomatte.murmur3_32(b"hello") == 0x248BFA47
    cycles = {"Floor": "6a2fb16e", "A": "54dcf7ce", "B": "cca66a8a", "Rig": "b76dec1e",
              "World": "89408cc1", "default_surface": "78d05529"}
    assert {n: f"{cryptomatte.name_hash(n):08x}" for n in cycles} == cycles
    for layer, key in (("ViewLayer.CryptoObject", "542cafa"),
                       ("ViewLayer.CryptoMaterial", "c7dbf5e"),
                       ("ViewLayer.CryptoAsset", "aa21542")):
        assert cryptomatte.identifier(layer) == key
    meta = cryptomatte.metadata("ViewLayer", "Object", {"A": 0x54DCF7CE})
    assert meta == {"cryptomatte/542cafa/name": "ViewLayer.CryptoObject",
                    "cryptomatte/542cafa/hash": "MurmurHash3_32",
                    "cryptomatte/542cafa/conversion": "uint32_to_float32",
                    "cryptomatte/542cafa/manifest": '{"A":"54dcf7ce"}'}
    assert json.loads(meta["cryptomatte/542cafa/manifest"]) == {"A": "54dcf7ce"}


def test_ids_never_make_denormals_infinities_or_nans():
    ids = np.array([0x00000001, 0x7F800001, 0xFF800000, 0x54DCF7CE], np.uint32)
    f = cryptomatte.id_floats(ids)
    assert np.isfinite(f).all() and (np.abs(f[:3]) >= np.finfo(np.float32).tiny).all()
    assert f[3].view(np.uint32) == 0x54DCF7CE  # a normal exponent is kept as it is
    assert f[0].view(np.uint32) == 0x00800001  # the exponent's lowest bit flipped


@pytest.mark.parametrize("levels", [1, 2, 5, 6])
def test_ranks_count_what_each_pixel_sees(levels):
    rng = np.random.default_rng(levels)
    samples, pixels = 16, 300
    names = np.array([11, 22, 33, 44, 0x7F800001], np.uint64)
    ids = names[rng.integers(0, len(names), (samples, pixels))]
    ids[rng.random((samples, pixels)) < 0.2] = cryptomatte.NONE
    out = cryptomatte.ranks(ids, levels)
    kept = 2 * -(-levels // 2)  # whole passes of two ranks
    assert out.shape == (pixels, 2 * kept)
    for p in range(pixels):
        counts = collections.Counter(int(i) for i in ids[:, p] if i != cryptomatte.NONE)
        expected = sorted(counts.items(), key=lambda kv: (-kv[1], kv[0]))[:kept]
        got = out[p].reshape(-1, 2)
        for rank, (name, hits) in enumerate(expected):
            assert got[rank, 0] == cryptomatte.id_floats(np.array([name], np.uint32))[0]
            assert got[rank, 1] == pytest.approx(hits / samples)
        assert not got[len(expected):].any()


def test_a_frame_writes_the_ids_of_what_it_sees():
    """A card on a floor, seen from above: inside the card its id with coverage 1, on the
    floor the floor's, at the card's edges both, their coverages summing to 1; the material
    pass names the materials; Levels 3 makes two passes per kind."""
    card = floor(size=1.0)
    card.positions = card.positions + np.float32([0.0, 0.0, 0.5])
    card.name, card.asset = "Card", "Rig"
    card.material = np.array([2, 2], np.int32)
    scene = lambert_scene(Light("SUN", color=np.ones(3), direction=np.array([0, 0, -1.0])))
    scene.meshes.append(card)
    scene.materials.append(Material.talk(name="Red", albedo=np.array([0.8, 0.1, 0.1],
                                                                      np.float32)))
    scene.settings = RenderSettings(samples=16, cryptomatte=("Object", "Material", "Asset"),
                                    cryptomatte_levels=3)
    image = pipeline.render_frame(RenderJob(scene))
    assert {n for n in image if n.startswith("Crypto")} == {
        f"Crypto{k}{n:02d}" for k in ("Object", "Material", "Asset") for n in (0, 1)}
    obj = image["CryptoObject00"]
    as_id = {n: cryptomatte.id_floats(np.array([cryptomatte.name_hash(n)], np.uint32))[0]
             for n in ("Card", "floor", "Rig", "Red", "lambert")}
    middle, corner = obj[H // 2, W // 2], obj[1, 1]
    assert middle[0] == as_id["Card"] and middle[1] == 1.0 and middle[3] == 0.0
    assert corner[0] == as_id["floor"] and corner[1] == 1.0
    assert image["CryptoAsset00"][H // 2, W // 2, 0] == as_id["Rig"]
    assert image["CryptoAsset00"][1, 1, 0] == as_id["floor"]  # no parent: its own name
    assert image["CryptoMaterial00"][H // 2, W // 2, 0] == as_id["Red"]
    covered = obj[..., 1] + obj[..., 3] + image["CryptoObject01"][..., 1]
    np.testing.assert_allclose(covered, 1.0, atol=1e-6)
    edge = (obj[..., 1] < 1.0)
    assert edge.sum() > 0 and (obj[..., 1] >= obj[..., 3]).all()
    assert set(np.unique(obj[edge][:, [0, 2]].view(np.uint32))) == {
        as_id[n].view(np.uint32) for n in ("Card", "floor")}
    assert cryptomatte.manifest(scene, "Object") == {"floor": cryptomatte.name_hash("floor"),
                                                     "Card": cryptomatte.name_hash("Card")}
    assert set(cryptomatte.manifest(scene, "Material")) == {"lambert", "Red"}  # those used


def test_names_whose_ids_clash_are_found():
    """Two object names with the same MurmurHash3 (found by a search over 83,098 names):
    their mattes cannot be told apart, and ``clashes`` names them."""
    a, b = "Cube.027977", "Cube.083097"
    assert cryptomatte.name_hash(a) == cryptomatte.name_hash(b) == 0xF4AAE443
    names = {n: cryptomatte.name_hash(n) for n in ("Floor", a, "A", b)}
    assert cryptomatte.clashes(names) == [(a, b)]
    assert cryptomatte.clashes({"Floor": 1, "A": 2}) == []
