"""Cryptomatte passes: per pixel the names seen, ranked by the share of the pixel's samples
that see each (Friedman and Jones, "Fully Automatic ID Mattes with Support for Motion Blur and
Transparency", SIGGRAPH 2015 poster; the Cryptomatte specification 1.2.0), written as Blender
writes them, so that its Cryptomatte node picks mattes from them.

- A name's id is MurmurHash3_x86_32 of its UTF-8 bytes, seed 0 (``murmur3_32``), stored as
  the float32 of those bits, the exponent's lowest bit flipped where it would be all zeros or
  all ones (no denormal, infinity or NaN: ``id_floats``).
- Pass ``Crypto<Kind>NN`` holds ranks 2 NN and 2 NN + 1 as (id, coverage, id, coverage);
  ``levels`` ranks (the view layer's Levels) take ceil(levels / 2) passes.
- Metadata ``cryptomatte/<7 hex of the hash of "<layer>.Crypto<Kind>">/{name, hash,
  conversion, manifest}``; the manifest maps each name to its id in 8 hex digits.
"""

from __future__ import annotations

import json

import numpy as np

KINDS = ("Object", "Material", "Asset")  # the view layer's Cryptomatte passes, in order
_M32 = 0xFFFFFFFF


def _rotl(x: int, r: int) -> int:
    return ((x << r) | (x >> (32 - r))) & _M32


def murmur3_32(data: bytes, seed: int = 0) -> int:
    """MurmurHash3_x86_32 (Appleby, SMHasher) of ``data``: a 32-bit unsigned integer."""
    c1, c2 = 0xCC9E2D51, 0x1B873593
    h = seed & _M32
    body = len(data) // 4 * 4
    for i in range(0, body, 4):
        k = _rotl(int.from_bytes(data[i:i + 4], "little") * c1 & _M32, 15) * c2 & _M32
        h = (_rotl(h ^ k, 13) * 5 + 0xE6546B64) & _M32
    tail = data[body:]
    if tail:
        k = int.from_bytes(tail, "little")
        h ^= _rotl(k * c1 & _M32, 15) * c2 & _M32
    h ^= len(data)
    h = (h ^ (h >> 16)) * 0x85EBCA6B & _M32
    h = (h ^ (h >> 13)) * 0xC2B2AE35 & _M32
    return h ^ (h >> 16)


def name_hash(name: str) -> int:
    """The id of ``name``: ``murmur3_32`` of its UTF-8 bytes."""
    return murmur3_32(name.encode("utf-8"))


def id_floats(ids: np.ndarray) -> np.ndarray:
    """(N,) float32 of (N,) uint32 ids, the spec's conversion: an exponent of all zeros or
    all ones gets its lowest bit flipped."""
    bits = np.asarray(ids, np.uint32).copy()
    exponent = (bits >> np.uint32(23)) & np.uint32(255)
    bits[(exponent == 0) | (exponent == 255)] ^= np.uint32(1 << 23)
    return bits.view(np.float32)


def identifier(layer_pass: str) -> str:
    """The 7 hex digits that name ``layer_pass`` ("ViewLayer.CryptoObject") in metadata keys."""
    return f"{name_hash(layer_pass):08x}"[:7]


def passes(kind: str, levels: int) -> list[str]:
    """The pass names of ``kind`` at ``levels`` ranks: Crypto<Kind>00, 01, ..."""
    return [f"Crypto{kind}{k:02d}" for k in range(-(-min(16, max(1, int(levels))) // 2))]


def metadata(layer: str, kind: str, manifest: dict[str, int]) -> dict[str, str]:
    """The render result's metadata of one kind's passes: {key: value}."""
    name = f"{layer}.Crypto{kind}"
    key = f"cryptomatte/{identifier(name)}/"
    return {key + "name": name, key + "hash": "MurmurHash3_32",
            key + "conversion": "uint32_to_float32",
            key + "manifest": json.dumps({n: f"{h:08x}" for n, h in manifest.items()},
                                         separators=(",", ":"))}


def ranks(ids: np.ndarray, levels: int) -> np.ndarray:
    """Per pixel the ids most samples see, most first, with the share of the samples that
    see each (ties: the smaller id first): ``levels`` rounded up to whole passes.

    ids:     (S, N) uint64: each sample's id at N pixels; ``NONE`` where it sees no surface
    returns: (N, 4 ceil(levels / 2)) float32: (id float, coverage) per rank; 0, 0 beyond
             the names a pixel has
    """
    samples, count = ids.shape
    width = 4 * -(-max(1, int(levels)) // 2)
    out = np.zeros((count, width), np.float32)
    pixel = np.broadcast_to(np.arange(count, dtype=np.uint64), ids.shape).ravel()
    flat = ids.ravel()
    seen = flat != NONE
    keys, hits = np.unique((pixel[seen] << np.uint64(32)) | flat[seen], return_counts=True)
    if not len(keys):
        return out
    at = (keys >> np.uint64(32)).astype(np.int64)
    value = (keys & np.uint64(_M32)).astype(np.uint32)
    order = np.lexsort((value, -hits, at))  # by pixel, most samples first, then by id
    at, value, hits = at[order], value[order], hits[order]
    first = np.searchsorted(at, at, side="left")
    rank = np.arange(len(at)) - first
    keep = rank < width // 2
    at, value, hits, rank = at[keep], value[keep], hits[keep], rank[keep]
    out[at, 2 * rank] = id_floats(value)
    out[at, 2 * rank + 1] = hits.astype(np.float32) / np.float32(samples)
    return out


NONE = np.uint64(1 << 32)  # the id of a sample that sees no surface (outside 32 bits)


def names_of(meshes, materials, kind: str) -> list[str]:
    """The name each mesh batch (``Object``, ``Asset``) or material (``Material``) has in
    pass ``kind``."""
    if kind == "Material":
        return [m.name for m in materials]
    return [(m.asset or m.name) if kind == "Asset" else m.name for m in meshes]


def triangle_ids(names: list[str], index: np.ndarray) -> np.ndarray:
    """(T,) uint64 ids of triangles whose name is ``names[index]``."""
    hashes = np.array([name_hash(n) for n in names] or [0], np.uint64)
    return hashes[index] if len(names) else np.zeros(len(index), np.uint64)


def manifest(scene, kind: str) -> dict[str, int]:
    """{name: id} of every name of ``kind`` in ``scene`` (a ``core.scene.Scene``; the
    materials its meshes use), as the metadata lists them."""
    names = names_of(scene.meshes, scene.materials, kind)
    if kind == "Material":
        used = np.unique(np.concatenate([np.unique(m.material) for m in scene.meshes]
                                        or [np.zeros(0, np.int64)]))
        names = [names[k] for k in used if 0 <= k < len(names)]
    return {n: name_hash(n) for n in names}


def clashes(names: dict[str, int]) -> list[tuple[str, str]]:
    """Pairs of different names of a manifest whose ids are the same (MurmurHash3 collides
    for about one pair in 2^32): their mattes cannot be told apart."""
    first: dict[int, str] = {}
    out = []
    for name, h in names.items():
        if h in first:
            out.append((first[h], name))
        else:
            first[h] = name
    return out
