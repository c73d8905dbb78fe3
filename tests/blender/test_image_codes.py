"""8-bit images stay 8-bit: their codes read without Blender's float copy, what they cost in
memory, and the texture cache bounded by size.

Independent values: the codes ``Image.pixels`` gives (code / 255, as Blender documents its byte
buffers) rounded back to integers, and NumPy's own allocation record (``tracemalloc``).
"""

import os
import tracemalloc

import bpy
import numpy as np
import pytest

from bo2_lighting.addon.blender import images
from bo2_lighting.addon.core.render.job import Warnings

RNG = np.random.default_rng(11)
ALPHA_MODES = ("STRAIGHT", "PREMUL", "CHANNEL_PACKED", "NONE")


def png(tmp_path, width=37, height=23, name="codes.png", mode="RGBA"):
    """An 8-bit PNG (``mode`` RGBA, RGB or BW) of random codes written by Blender, and the
    codes as Blender holds them (RGBA, row 0 at the top)."""
    codes = RNG.integers(0, 256, (height, width, 4)).astype(np.uint8)
    if mode != "RGBA":
        codes[..., 3] = 255
    if mode == "BW":
        codes[..., 1] = codes[..., 2] = codes[..., 0]
    image = bpy.data.images.new("writer", width, height, alpha=True)
    image.pixels.foreach_set((codes[::-1] / np.float32(255.0)).astype(np.float32).ravel())
    path = tmp_path / name
    scene = bpy.context.scene
    images.set_format(scene.render.image_settings, "PNG", "8", mode)
    scene.view_settings.view_transform = "Standard"
    image.save_render(filepath=str(path), scene=scene)
    bpy.data.images.remove(image)
    return path, codes


def pixel_codes(image) -> np.ndarray:
    return np.rint(images.image_pixels(image) * 255.0).astype(np.uint8)


@pytest.mark.parametrize("colorspace", ["sRGB", "Non-Color"])
@pytest.mark.parametrize("alpha_mode", ALPHA_MODES)
def test_codes_are_the_codes_blender_holds(empty_scene, tmp_path, colorspace, alpha_mode):
    path, codes = png(tmp_path)
    image = bpy.data.images.load(str(path), check_existing=False)
    image.colorspace_settings.name = colorspace
    image.alpha_mode = alpha_mode
    scenes = len(bpy.data.scenes)
    got = images.image_codes(image)
    assert got is not None and got.dtype == np.uint8 and got.shape == codes.shape
    np.testing.assert_array_equal(got, pixel_codes(image))
    if alpha_mode in ("STRAIGHT", "CHANNEL_PACKED"):
        np.testing.assert_array_equal(got, codes)  # what was written
    assert len(bpy.data.scenes) == scenes and not image.is_dirty


@pytest.mark.parametrize("mode", ["RGB", "BW"])
def test_codes_of_images_without_alpha(empty_scene, tmp_path, mode):
    path, codes = png(tmp_path, mode=mode)
    image = bpy.data.images.load(str(path), check_existing=False)
    got = images.image_codes(image)
    np.testing.assert_array_equal(got, pixel_codes(image))
    np.testing.assert_array_equal(got, codes)


def test_codes_of_generated_and_edited_images(empty_scene):
    image = bpy.data.images.new("grid", 16, 8, alpha=True)
    image.generated_type = "COLOR_GRID"
    np.testing.assert_array_equal(images.image_codes(image), pixel_codes(image))
    px = np.empty(16 * 8 * 4, np.float32)
    image.pixels.foreach_get(px)
    px[:40] = 0.3
    image.pixels.foreach_set(px)
    assert image.is_dirty
    np.testing.assert_array_equal(images.image_codes(image), pixel_codes(image))
    assert image.is_dirty  # the edit is still the user's to save


def test_no_codes_where_blender_would_convert(empty_scene, tmp_path):
    path, _ = png(tmp_path)
    image = bpy.data.images.load(str(path), check_existing=False)
    image.colorspace_settings.name = "Linear Rec.709"
    assert images.image_codes(image) is None
    assert images.image_codes(bpy.data.images.new("f", 4, 4, float_buffer=True)) is None


def test_load_image_keeps_eight_bits_and_releases_what_it_loaded(addon, tmp_path):
    path, codes = png(tmp_path)
    image = bpy.data.images.load(str(path), check_existing=False)
    assert not image.has_data
    warnings = Warnings()
    tex = images.load_image(image, "REPEAT", "Linear", warnings, "test")
    assert not warnings and tex.codes and tex.encoded == 3
    np.testing.assert_array_equal(tex.image, codes)
    assert not image.has_data  # loaded for the texture, released again
    # a linear 8-bit image: codes as well, its colour not decoded
    other = bpy.data.images.load(str(path), check_existing=False)
    other.colorspace_settings.name = "Linear Rec.709"
    tex = images.load_image(other, "REPEAT", "Linear", warnings, "test")
    assert tex.codes and tex.encoded == 0
    np.testing.assert_array_equal(tex.image, codes)
    # a float image stays float
    hdr = bpy.data.images.new("float", 8, 4, float_buffer=True)
    hdr.pixels.foreach_set(np.full(8 * 4 * 4, 2.5, np.float32))
    tex = images.load_image(hdr, "REPEAT", "Linear", warnings, "test")
    assert not tex.codes and tex.image.dtype == np.float32 and (tex.image == 2.5).all()


def test_reading_an_image_allocates_about_its_eight_bit_size(addon, tmp_path):
    """NumPy allocations while an 8-bit image becomes a texture: the codes, one swap of two
    channels and the chain (whose levels 1, 2, ... take no memory until filled); the float copy
    of ``Image.pixels`` alone would be four times the image."""
    path, _ = png(tmp_path, 1024, 512, "big.png")
    image = bpy.data.images.load(str(path), check_existing=False)
    image.size[0]  # noqa: B018 (Blender's own load is not NumPy's)
    tracemalloc.start()
    try:
        tex = images.load_image(image, "REPEAT", "Linear", Warnings(), "test")
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    size = 1024 * 512 * 4
    assert tex.codes and tex.pending
    assert peak < 2.6 * size, f"{peak / size:.2f} times the image"


def test_cache_drops_the_least_recently_used_beyond_its_size(addon, monkeypatch):
    images._textures.clear()
    made = []
    for k in range(3):
        image = bpy.data.images.new(f"cache {k}", 64, 64, alpha=True)
        image.pixels.foreach_set(np.full(64 * 64 * 4, k / 4, np.float32))
        made.append(image)
    one = images.load_image(made[0], "REPEAT", "Linear", Warnings(), "t")
    monkeypatch.setattr(images._textures, "budget", int(2.5 * one.nbytes))
    images.load_image(made[1], "REPEAT", "Linear", Warnings(), "t")
    images.load_image(made[0], "REPEAT", "Linear", Warnings(), "t")  # used again: now the newest
    images.load_image(made[2], "REPEAT", "Linear", Warnings(), "t")
    kept = {key[0] for key in images._textures.keys()}
    assert kept == {"cache 0", "cache 2"}
    assert sum(t.nbytes for t, _ in images._textures.values()) <= images._textures.budget


def test_an_image_file_is_read_again_only_when_it_changes(addon, tmp_path, monkeypatch):
    """A cached image file is not loaded to be recognised (its path, size and modification
    time are), and a new file at the same path makes a new texture."""
    from bo2_lighting.addon.core.formulas import texture

    made = []
    real = texture.make_texture
    monkeypatch.setattr(texture, "make_texture", lambda *a, **k: made.append(1) or real(*a, **k))
    path, codes = png(tmp_path, name="file.png")
    image = bpy.data.images.load(str(path), check_existing=False)
    first = images.load_image(image, "REPEAT", "Linear", Warnings(), "t")
    assert images.load_image(image, "REPEAT", "Linear", Warnings(), "t") is first
    assert len(made) == 1 and not image.has_data
    png(tmp_path, name="file.png")
    stat = path.stat()
    os.utime(path, ns=(stat.st_atime_ns, stat.st_mtime_ns + 10**9))
    image.reload()
    second = images.load_image(image, "REPEAT", "Linear", Warnings(), "t")
    assert len(made) == 2 and not np.array_equal(second.image, codes)
    # an edit, rendered, then taken back by Reload: the file's pixels again
    image.size[0]  # noqa: B018 (loads it)
    px = np.empty(image.size[0] * image.size[1] * 4, np.float32)
    image.pixels.foreach_get(px)
    image.pixels.foreach_set(np.zeros_like(px))
    assert image.is_dirty
    edited = images.load_image(image, "REPEAT", "Linear", Warnings(), "t")
    assert not edited.image[..., :3].any()
    image.reload()
    assert not image.is_dirty
    again = images.load_image(image, "REPEAT", "Linear", Warnings(), "t")
    np.testing.assert_array_equal(again.image, second.image)


def test_settings_of_one_image_share_its_levels(addon, tmp_path):
    """Two nodes reading one image with other extensions and interpolations: one chain in
    memory and in the cache, filled once for both."""
    from bo2_lighting.addon.core.formulas import texture

    path, _ = png(tmp_path, 64, 32, name="shared.png")
    image = bpy.data.images.load(str(path), check_existing=False)
    a = images.load_image(image, "REPEAT", "Linear", Warnings(), "t")
    b = images.load_image(image, "CLIP", "Closest", Warnings(), "t")
    assert (b.extension, b.interpolation) == ("CLIP", "Closest")
    assert np.shares_memory(a.image, b.image) and a.pending and b.pending
    assert len([k for k in images._textures.keys() if k[0] == image.name_full]) == 1
    texture.sample(b.sampled_as("REPEAT", "Linear"), np.full((4, 2), 0.5), np.full(4, 2.0))
    assert not a.pending and not b.pending
