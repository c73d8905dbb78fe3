"""Environment images from disk as cube maps: Radiance HDR and OpenEXR files, lat-long, cross or
six faces.

Readers:

- Radiance RGBE (``.hdr``, ``.pic``; Ward 1991, "Real pixels", Graphics Gems II; the file format
  of the Radiance reference manual): the text header, the ``-Y H +X W`` resolution line, flat or
  run-length encoded scanlines; a texel is m 2^(e - 136) per channel, as Blender and
  stb_image read it (Radiance's own ``colr_color`` adds 0.5 to m), and 0 where e = 0.
- OpenEXR (the ``OpenEXR`` package): the first part's R, G, B channels (or its packed RGB/RGBA).

Layouts (``to_cube``), told apart by the image's proportions:

- lat-long (width = 2 height): Blender's Environment Texture mapping
  (``cubemap.equirect_to_cube``);
- horizontal cross (4 x 3 faces) and vertical cross (3 x 4), the layout of AMD CubeMapGen and
  cmft: the six faces as a GPU stores them (``gpu_textures``: the OpenGL cube map face
  orientation, world Y up), unfolded around +Z::

          +Y                      +Y
      -X  +Z  +X  -Z          -X  +Z  +X
          -Y                      -Y
                                  -Z (turned by 180 degrees)

- six face images in the order +X, -X, +Y, -Y, +Z, -Z, each as a GPU stores it.

GPU faces are in Y-up axes, turned into Blender's (Z up) as the glTF exporter does
(``gpu_textures.Y_UP``).
"""

from __future__ import annotations

import os
import re
from pathlib import Path

import numpy as np

from ..formulas import cubemap
from . import exr, gpu_textures

__all__ = ["ImageError", "read_image", "to_cube"]

MAX_SIDE = 32768  # pixels per side of an image read here (Blender's limit is 65536)


class ImageError(ValueError):
    """An image that cannot be read or used as an environment; one-line message."""


def read_image(path: str | os.PathLike) -> np.ndarray:
    """(H, W, 3) float32 scene-linear RGB of a Radiance HDR or OpenEXR file, row 0 at the top.

    Non-finite texels are kept (the caller decides); raises ImageError for a missing,
    truncated or corrupt file or another format."""
    path = Path(path)
    if path.is_dir():
        raise ImageError(f"{path}: is a directory, not an image")
    if not path.is_file():
        raise ImageError(f"{path}: no such file")
    with open(path, "rb") as f:
        head = f.read(10)
    if head.startswith(b"#?"):
        return _read_hdr(path)
    if head[:4] == b"\x76\x2f\x31\x01":
        return _read_exr(path)
    raise ImageError(f"{path}: not a Radiance HDR or OpenEXR file")


def _read_hdr(path: Path) -> np.ndarray:
    data = path.read_bytes()
    end = data.find(b"\n\n")
    if end < 0:
        raise ImageError(f"{path}: truncated Radiance header")
    header = data[:end].decode("latin-1")
    fmt = re.search(r"^FORMAT=(\S+)", header, re.M)
    if fmt and fmt.group(1) != "32-bit_rle_rgbe":
        raise ImageError(f"{path}: Radiance format {fmt.group(1)} is not supported "
                                "(only 32-bit_rle_rgbe)")
    line_end = data.find(b"\n", end + 2)
    m = re.fullmatch(rb"-Y (\d+) \+X (\d+)", data[end + 2:line_end].strip())
    if line_end < 0 or not m:
        raise ImageError(f"{path}: unsupported Radiance resolution line "
                                f"{data[end + 2:line_end][:40]!r} (expected '-Y H +X W')")
    h, w = int(m.group(1)), int(m.group(2))
    if not (0 < h <= MAX_SIDE and 0 < w <= MAX_SIDE):
        raise ImageError(f"{path}: {w} x {h} pixels is not a usable image size")
    rgbe = _decode_scanlines(memoryview(data)[line_end + 1:], w, h, path)
    e = rgbe[..., 3].astype(np.int32)
    scale = np.where(e > 0, np.ldexp(np.float32(1.0), e - 136), 0.0).astype(np.float32)
    return rgbe[..., :3].astype(np.float32) * scale[..., None]


def _decode_scanlines(buf, w: int, h: int, path: Path) -> np.ndarray:
    """(h, w, 4) uint8 RGBE texels of the scanlines in ``buf`` (new RLE or flat)."""
    out = np.empty((h, w, 4), np.uint8)
    pos = 0
    size = len(buf)
    for y in range(h):
        if pos + 4 > size:
            raise ImageError(f"{path}: truncated at scanline {y} of {h}")
        b = bytes(buf[pos:pos + 4])
        if not (8 <= w < 32768 and b[0] == 2 and b[1] == 2 and (b[2] << 8 | b[3]) == w):
            flat = np.frombuffer(buf, np.uint8, count=min(size - pos, (h - y) * w * 4),
                                 offset=pos)
            if len(flat) < (h - y) * w * 4:
                raise ImageError(f"{path}: truncated at scanline {y} of {h}")
            out[y:] = flat.reshape(h - y, w, 4)  # flat (uncompressed) scanlines
            return out
        pos += 4
        for c in range(4):
            x = 0
            while x < w:
                if pos >= size:
                    raise ImageError(f"{path}: truncated at scanline {y} of {h}")
                count = buf[pos]
                if count > 128:  # a run of one value
                    count -= 128
                    if x + count > w or pos + 1 >= size:
                        raise ImageError(f"{path}: corrupt run at scanline {y}")
                    out[y, x:x + count, c] = buf[pos + 1]
                    pos += 2
                else:  # literal values
                    if count == 0 or x + count > w or pos + 1 + count > size:
                        raise ImageError(f"{path}: corrupt run at scanline {y}")
                    out[y, x:x + count, c] = np.frombuffer(buf, np.uint8, count, pos + 1)
                    pos += 1 + count
                x += count
    return out


def _read_exr(path: Path) -> np.ndarray:
    try:
        return exr.rgb(path)
    except exr.ExrError as exc:
        raise ImageError(f"{path}: unreadable OpenEXR file ({exc})") from None

def layout_of_or_none(shape: tuple) -> str | None:
    """``layout_of``, or None for other proportions."""
    try:
        return layout_of(shape)
    except ImageError:
        return None


def layout_of(shape: tuple) -> str:
    """"latlong", "hcross" or "vcross" from an image's (H, W, ...) shape; raises
    ImageError for other proportions."""
    h, w = shape[:2]
    if w == 2 * h:
        return "latlong"
    if w * 3 == h * 4 and w % 4 == 0:
        return "hcross"
    if w * 4 == h * 3 and w % 3 == 0:
        return "vcross"
    raise ImageError(f"a {w} x {h} image is neither a lat-long (2:1) nor a cube cross "
                            "(4:3 or 3:4) image; give six face images instead")


_CROSS = {  # (row, column) of each GPU face, in face-size cells
    "hcross": ((1, 2), (1, 0), (0, 1), (2, 1), (1, 1), (1, 3)),
    "vcross": ((1, 2), (1, 0), (0, 1), (2, 1), (1, 1), (3, 1)),
}


def to_cube(images: list[np.ndarray], size: int | None = None) -> np.ndarray:
    """A cube map (``cubemap.FACES`` layout, Blender axes) of one lat-long or cross image, or of
    six face images.

    images:  [(H, W, 3)] or six (S, S, 3) float32 images, row 0 at the top
    size:    face size of the result (a power of two); default: the faces' own for crosses and
             faces (rounded up to a power of two), H / 2 for a lat-long (rounded down)
    returns: (6, S, S, 3) float32, non-finite texels set to 0
    """
    if len(images) == 6:
        faces = [np.asarray(i, np.float32) for i in images]
        side = faces[0].shape[0]
        if any(f.shape[:2] != (side, side) for f in faces):
            raise ImageError("the six face images must be square and of one size, got "
                                    + ", ".join(f"{f.shape[1]} x {f.shape[0]}" for f in faces))
        gpu = np.stack(faces)
    elif len(images) == 1:
        image = np.asarray(images[0], np.float32)
        kind = layout_of(image.shape)
        if kind == "latlong":
            if image.shape[0] < 2:
                raise ImageError(f"a {image.shape[1]} x {image.shape[0]} lat-long image "
                                        "is too small")
            size = size or 1 << (image.shape[0] // 2).bit_length() - 1
            return np.nan_to_num(cubemap.equirect_to_cube(image, _power_of_two(size)),
                                 nan=0.0, posinf=0.0, neginf=0.0)
        side = image.shape[1] // (4 if kind == "hcross" else 3)
        gpu = np.stack([image[r * side:(r + 1) * side, c * side:(c + 1) * side]
                        for r, c in _CROSS[kind]])
        if kind == "vcross":
            gpu[5] = gpu[5, ::-1, ::-1]
    else:
        raise ImageError(f"give one lat-long or cross image, or six face images, not "
                                f"{len(images)}")
    gpu = np.nan_to_num(gpu[..., :3], nan=0.0, posinf=0.0, neginf=0.0)
    cube = gpu_textures.from_gpu_faces(gpu)
    want = _power_of_two(size or 1 << max(0, (cube.shape[1] - 1).bit_length()))
    return _resize(cube, want)


def _power_of_two(size: int) -> int:
    size = int(size)
    if size < 1 or size & (size - 1):
        raise ImageError(f"face size {size} is not a power of two")
    return size


def _resize(cube: np.ndarray, size: int) -> np.ndarray:
    """``cube`` at face size ``size``: halvings by solid-angle weighted 2 x 2 boxes when
    smaller, else each target texel the seamless bilinear sample at its direction."""
    while cube.shape[1] > size and cube.shape[1] % 2 == 0 and cube.shape[1] // 2 >= size:
        cube = cubemap.downsample(cube)
    if cube.shape[1] == size:
        return np.ascontiguousarray(cube, np.float32)
    d = cubemap.texel_directions(size).reshape(-1, 3)
    return cubemap.sample([cube], d).reshape(6, size, size, -1).astype(np.float32)
