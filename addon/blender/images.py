"""The one bridge between Blender's images and NumPy: Image and Render Result pixels, image files
written and read through Blender, multilayer EXR passes.

Arrays are float32 (H, W, C) with row 0 at the top; Blender's rows run bottom to top. Blender 5.0
chooses single-layer or multilayer EXR by the output's ``media_type``, 4.5 by the file format:
``set_format`` takes the format names of 4.5 and handles both.
"""

from __future__ import annotations

import contextlib
import hashlib
import os
import tempfile
import threading
from pathlib import Path

import bpy
import numpy as np

from ..core.files import exr
from ..core.formulas import texture
from ..core.render.job import Warnings
from ..core.system import atomic
from ..core.system.cache import Cache
from .passes import blender_name, channel_ids

SETTINGS = ("media_type", "file_format", "color_mode", "color_depth", "exr_codec",
             "color_management")


class ImageError(Exception):
    """An image that cannot be written or read: one line for the user."""


def image_pixels(image) -> np.ndarray:
    """(H, W, C) float32 pixels of a Blender image as ``Image.pixels`` holds them (float images
    scene-linear, byte images encoded), row 0 at the top: a view of Blender's row order."""
    width, height = image.size
    flat = np.empty(width * height * image.channels, np.float32)
    image.pixels.foreach_get(flat)
    return flat.reshape(height, width, image.channels)[::-1]


def image_codes(image, release: bool = False) -> np.ndarray | None:
    """(H, W, 4) uint8 codes of an 8-bit Blender image as it holds them, row 0 at the top, read
    without the float copy ``Image.pixels`` makes (four times the image): Blender writes its
    byte buffer to an uncompressed Targa file, which is read back. Blender writes the codes of
    images in sRGB or a data colour space unchanged through a Standard view; for other colour
    spaces, float images, a file Blender cannot write or an unexpected one it returns None.
    Call it on Blender's main thread: it adds and removes a scene.

    release: free Blender's own copy of the pixels once written (an image that was not in
             memory before), before the file is read
    """
    settings = image.colorspace_settings
    if image.is_float or not (settings.name == "sRGB" or getattr(settings, "is_data", False)
                              or settings.name == "Non-Color"):
        return None
    width, height = image.size
    scene = bpy.data.scenes.new("BO2 image codes")
    try:
        try:  # no view, look, dither or display that would change a code
            scene.display_settings.display_device = "sRGB"
            scene.view_settings.view_transform = "Standard"
            scene.view_settings.look = "None"
            scene.render.dither_intensity = 0.0
            set_format(scene.render.image_settings, "TARGA_RAW", "8", "RGBA")
        except (TypeError, ValueError):  # a colour configuration without them
            return None
        with tempfile.TemporaryDirectory() as tmp:
            path = Path(tmp) / "codes.tga"
            try:
                image.save_render(filepath=str(path), scene=scene)
            except RuntimeError:
                return None
            if release:
                image.buffers_free()
            return _targa_codes(path, width, height)
    finally:
        bpy.data.scenes.remove(scene)


def _targa_codes(path: Path, width: int, height: int) -> np.ndarray | None:
    """RGBA codes (H, W, 4) uint8, row 0 at the top, of an uncompressed 32-bit Targa file of
    the given size (Truevision TGA 2.0: an 18-byte header, an optional id, BGRA texels from the
    bottom row up unless bit 5 of the descriptor says top); None for any other file."""
    with open(path, "rb") as f:
        header = f.read(18)
        if len(header) < 18:
            return None
        id_length, colormap, kind = header[0], header[1], header[2]
        w, h = int.from_bytes(header[12:14], "little"), int.from_bytes(header[14:16], "little")
        if (colormap, kind, header[16], w, h) != (0, 2, 32, width, height):
            return None
        f.seek(18 + id_length)
        data = np.fromfile(f, np.uint8, width * height * 4)
    if data.size != width * height * 4:
        return None
    data = data.reshape(height, width, 4)
    for y in range(0, height, 256):  # BGRA to RGBA, a band of rows at a time
        band = data[y:y + 256]
        blue = band[..., 0].copy()
        band[..., 0] = band[..., 2]
        band[..., 2] = blue
    return data if header[17] & 0x20 else data[::-1]


def new_image(name: str, pixels: np.ndarray):
    """A float Blender image holding ``pixels`` (H, W, 3 or 4), row 0 at the top."""
    h, w = pixels.shape[:2]
    rgba = np.ones((h, w, 4), np.float32)
    rgba[..., :pixels.shape[2]] = pixels
    image = bpy.data.images.new(name, w, h, alpha=pixels.shape[2] == 4, float_buffer=True)
    image.pixels.foreach_set(np.ascontiguousarray(rgba[::-1]).ravel())
    return image


def read_file(path: str | os.PathLike, colorspace: str | None = None,
              linear: bool = False) -> np.ndarray:
    """(H, W, C) float32 pixels of an image file, loaded by Blender and removed again.

    colorspace: the image's colour space ("Non-Color" keeps encoded values as they are);
                None leaves Blender's choice
    linear:     decode an 8-bit sRGB image's colour to linear (``Image.pixels`` holds its
                encoded values; float images are scene-linear already)
    """
    image = bpy.data.images.load(str(path), check_existing=False)
    try:
        if colorspace is not None:
            image.colorspace_settings.name = colorspace
        width, height = image.size  # reading the size loads the pixels (or fails to)
        if width == 0 or height == 0 or not image.has_data:
            raise ImageError(f"{path}: not an image Blender can read")
        pixels = np.ascontiguousarray(image_pixels(image))
        if linear and not image.is_float and image.colorspace_settings.name == "sRGB":
            colour = slice(0, min(3, pixels.shape[2]))
            pixels[..., colour] = texture.srgb_to_linear(pixels[..., colour])
        return pixels
    finally:
        bpy.data.images.remove(image)


def set_format(settings, fmt: str, depth: str | None = None, mode: str | None = None,
               follow_scene: bool = False) -> None:
    """Set image output ``settings`` to ``fmt`` (4.5's names: "PNG", "OPEN_EXR",
    "OPEN_EXR_MULTILAYER", ...), colour ``depth`` and ``mode`` where given;
    ``follow_scene``: drop an override of the scene's colour management."""
    if follow_scene and hasattr(settings, "color_management"):
        settings.color_management = "FOLLOW_SCENE"
    if hasattr(settings, "media_type"):
        settings.media_type = "MULTI_LAYER_IMAGE" if fmt == "OPEN_EXR_MULTILAYER" else "IMAGE"
    settings.file_format = fmt
    if mode is not None:
        settings.color_mode = mode
    if depth is not None:
        settings.color_depth = depth


@contextlib.contextmanager
def kept_settings(scene):
    """Restore the scene's image output settings on exit."""
    settings = scene.render.image_settings
    saved = {k: getattr(settings, k) for k in SETTINGS if hasattr(settings, k)}
    try:
        yield settings
    finally:
        for key, value in saved.items():
            with contextlib.suppress(TypeError, ValueError):
                setattr(settings, key, value)


def _save(image, scene, path: Path) -> None:
    """``image.save_render`` to ``path`` through a temporary file beside it, swapped in whole."""
    try:
        atomic.write_atomically(path, lambda tmp: image.save_render(filepath=str(tmp),
                                                                   scene=scene))
    except RuntimeError as exc:
        raise ImageError(f"cannot write {path}: {str(exc).strip().splitlines()[-1]}") from None
    except OSError as exc:
        raise ImageError(f"cannot write {path}" + (f" ({exc.strerror})" if exc.strerror
                                                   else "")) from None


def save_render_result(scene, path: str | os.PathLike, fmt: str, depth: str | None = None,
                       mode: str | None = None, follow_scene: bool = False) -> None:
    """Write the Render Result to ``path`` (replaced atomically) as ``fmt`` and the other
    settings of ``set_format``; the scene's output settings are left as they were."""
    result = bpy.data.images.get("Render Result")
    if result is None:
        raise ImageError("the render produced no image")
    with kept_settings(scene) as settings:
        set_format(settings, fmt, depth, mode, follow_scene)
        _save(result, scene, Path(path))


def save_pixels(scene, pixels: np.ndarray, path: str | os.PathLike, fmt: str = "PNG",
                depth: str = "8", mode: str = "RGB") -> None:
    """Write scene-linear ``pixels`` (H, W, 3 or 4) to ``path`` as Blender saves a render:
    through the scene's colour management for display formats."""
    image = new_image("BO2 Output", pixels)
    try:
        with kept_settings(scene) as settings:
            set_format(settings, fmt, depth, mode, follow_scene=True)
            _save(image, scene, Path(path))
    finally:
        bpy.data.images.remove(image)


def render_result_pixels(scene) -> np.ndarray:
    """(H, W, 4) float32 scene-linear RGBA of the Render Result's Combined pass."""
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "result.exr"
        save_render_result(scene, path, "OPEN_EXR", "32", "RGBA")
        return read_file(path)


def to_display(scene, images: list[np.ndarray]) -> list[np.ndarray]:
    """Scene-linear images through the scene's colour management, as Blender saves a render.

    scene:   its view transform, look, exposure, gamma, curves and display device are applied
    images:  (H, W, >=3) scene-linear RGB, each of the same width, row 0 at the top
    returns: the same shapes with 3 channels, display-encoded float32 in [0, 1] (16-bit)
    """
    if not images:
        return []
    stack = np.concatenate([np.asarray(i[..., :3], np.float32) for i in images], 0)
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "display.png"
        save_pixels(scene, stack, path, "PNG", "16", "RGB")
        px = read_file(path, colorspace="Non-Color")[..., :3]  # the encoded values as they are
    out, row = [], 0
    for i in images:
        out.append(np.ascontiguousarray(px[row:row + i.shape[0]]))
        row += i.shape[0]
    return out


def read_exr_passes(path: str | os.PathLike, layer: str, names) -> dict[str, np.ndarray]:
    """The passes ``names`` (pipeline names, ``blender.passes``) of one view layer of a
    multilayer EXR written by Blender 4.5 or 5.0.

    returns: {pipeline pass name: (H, W, C) float32, row 0 at the top}, for the passes present
    """
    by_blender = {blender_name(n): n for n in names}
    components: dict[str, dict[str, np.ndarray]] = {}
    grouped: dict[str, np.ndarray] = {}
    for part in exr.read(path):  # 5.0: one part per pass; 4.5: one part
        for key, pixels in part.channels.items():
            if not key.startswith(f"{layer}."):
                continue
            rest = key[len(layer) + 1:]
            if rest in by_blender:  # RGB(A) channels come grouped in one array
                grouped[by_blender[rest]] = pixels
            else:
                name, _, comp = rest.rpartition(".")
                if name in by_blender:
                    components.setdefault(by_blender[name], {})[comp] = pixels
    out = {n: (a if a.ndim == 3 else a[..., None]) for n, a in grouped.items()}
    for name, comps in components.items():
        order = [c for c in channel_ids(name) if c in comps]
        out[name] = np.stack([np.asarray(comps[c], np.float32) for c in order], -1)
    return out


# image key -> (texture, digest): kept for later renders, the least recently used dropped
# beyond 2 GiB (a texture a material still holds lives on with it)
_textures = Cache("image textures", kept=1 << 16, size=lambda value: value[0].nbytes,
                  budget=2 << 30)
_lock = threading.Lock()  # the viewport and a final render may load images at once


def _on_disk(image) -> bool:
    return image.source == "FILE" and image.packed_file is None


def _image_key(image) -> tuple:
    """What identifies an image's pixels. An image file on disk that is not in memory: its
    path, size and modification time (read without loading it); an image in memory (edited,
    packed, generated, or loaded by Blender before): its size, type and generator, which load
    it. The two never match, so pixels read from memory are not taken for the file's."""
    common = (image.name_full, image.filepath_raw, image.colorspace_settings.name,
              image.alpha_mode, image.source)
    if _on_disk(image) and not image.has_data:
        try:
            stat = os.stat(bpy.path.abspath(image.filepath, library=image.library))
            return (*common, "file", stat.st_size, stat.st_mtime_ns)
        except (OSError, ValueError):
            pass
    generator = ((image.generated_type, tuple(image.generated_color),
                  image.use_generated_float) if image.source == "GENERATED" else ())
    return (*common, "memory", tuple(image.size), bool(image.is_float), *generator)


def load_image(image, extension: str, interpolation: str, warnings: Warnings, where: str):
    """A Blender image as a mipmapped ``Texture``, or None (with a warning) if unusable. 8-bit
    images stay 8-bit (``image_codes``), float images float32. Prepared once per image
    (its nodes' extensions and interpolations share its levels) and reused across renders
    while it is unchanged (an image edited in Blender and not saved is compared by a digest
    of its pixels). An image file that was not in memory before is released again once read
    (on Blender's main thread)."""
    if image is None:
        warnings.add(f"{where}: the Image Texture node has no image")
        return None
    with _lock:
        return _load(image, extension, interpolation, warnings, where)


def _load(image, extension, interpolation, warnings, where):
    main = threading.current_thread() is threading.main_thread()
    release = main and _on_disk(image) and not image.has_data
    key = _image_key(image)
    cached = _textures.get(key)
    dirty = image.is_dirty
    if cached is not None and not dirty:
        return cached[0].sampled_as(extension, interpolation)
    width, height = image.size
    if width == 0 or height == 0 or not image.has_data:
        warnings.add(f"{where}: image '{image.name}' could not be loaded "
                     f"({image.filepath or 'no file'}); it renders magenta, as in Cycles")
        return None
    is_float = image.is_float
    # Byte images hold encoded values; float images are already scene-linear in memory.
    srgb = not is_float and image.colorspace_settings.name == "sRGB"
    # Blender writes the codes of an image only on its main thread (a final render in the UI
    # runs on another)
    pixels = image_codes(image, release=release) if main else None
    if pixels is None:
        pixels = image_pixels(image)
        if not is_float:  # byte images hold codes / 255
            pixels = np.rint(pixels * np.float32(255.0)).astype(np.uint8)
    if release and image.has_data:
        image.buffers_free()  # (reading the image's properties would load it again)
    digest = None
    if dirty:  # an edited image is compared by its pixels
        rows = pixels[::-1] if pixels[::-1].flags.c_contiguous else np.ascontiguousarray(pixels)
        digest = hashlib.blake2b(memoryview(rows).cast("B"), digest_size=16).hexdigest()
        if cached is not None and cached[1] == digest:
            return cached[0].sampled_as(extension, interpolation)
    tex = texture.make_texture(pixels, srgb=srgb, extension=extension,
                               interpolation=interpolation, name=image.name)
    _textures.put(key, (tex, digest))  # with the digest of an edited image's pixels
    return tex
