"""Install the built extension zip the way a user does, render with it, and remove it."""

import os
import sys
import tempfile
import tomllib
from pathlib import Path

import bpy
import pytest
from util import engine_available

ROOT = Path(__file__).resolve().parents[2]
with open(ROOT / "blender_manifest.toml", "rb") as _fh:
    MANIFEST = tomllib.load(_fh)
ZIP = ROOT / "dist" / f"{MANIFEST['id']}-{MANIFEST['version']}-linux_x64.zip"
REPO = "bo2_install_test"
MODULE = f"bl_ext.{REPO}.bo2_lighting"



def small_scene():
    bpy.ops.mesh.primitive_plane_add(size=2.0)
    cam = bpy.data.objects.new("Camera", bpy.data.cameras.new("Camera"))
    cam.location = (0.0, 0.0, 3.0)
    bpy.context.scene.collection.objects.link(cam)
    bpy.context.scene.camera = cam
    light = bpy.data.objects.new("Sun", bpy.data.lights.new("Sun", "SUN"))
    bpy.context.scene.collection.objects.link(light)
    scene = bpy.context.scene
    scene.render.resolution_x = scene.render.resolution_y = 24
    scene.render.resolution_percentage = 100


@pytest.fixture
def user_repo():
    if not ZIP.exists():
        pytest.fail(f"{ZIP.name} is missing: run 'make build' (tools/build_extension.py) first")
    bpy.ops.wm.read_factory_settings(use_empty=True)
    with tempfile.TemporaryDirectory() as directory:
        repos = bpy.context.preferences.extensions.repos
        repo = repos.new(name="BO2 install test", module=REPO, custom_directory=directory)
        yield repo, Path(directory)
        if MODULE in bpy.context.preferences.addons:
            bpy.ops.preferences.addon_disable(module=MODULE)
        repos.remove(repo)


def install(repo):
    result = bpy.ops.extensions.package_install_files(
        filepath=str(ZIP), repo=REPO, enable_on_install=True)
    assert result == {"FINISHED"}


def uninstall(repo):
    index = list(bpy.context.preferences.extensions.repos).index(repo)
    assert bpy.ops.extensions.package_uninstall(
        repo_index=index, pkg_id=MANIFEST["id"]) == {"FINISHED"}


def test_install_render_disable_remove(user_repo):
    repo, directory = user_repo
    assert not engine_available("BO2_LIGHTING")
    install(repo)
    assert (directory / "bo2_lighting" / "blender_manifest.toml").exists()
    assert MODULE in bpy.context.preferences.addons
    assert engine_available("BO2_LIGHTING")
    # The zip's wheels (numba, llvmlite, OpenEXR, Dask and its dependencies; FLIP where it has
    # wheels) are installed for this platform and Python.
    site = (Path(bpy.utils.user_resource("EXTENSIONS", path=".local")) / "lib"
            / f"python{sys.version_info.major}.{sys.version_info.minor}" / "site-packages")
    found = {p.name for p in site.glob("*.dist-info")}
    assert {"numba-0.68.1.dist-info", "llvmlite-0.50.0.dist-info",
            "openexr-3.5.3.dist-info", "dask-2026.8.0.dist-info",
            "distributed-2026.8.0.dist-info", "msgpack-1.2.4.dist-info",
            "psutil-7.2.2.dist-info", "tornado-6.6.1.dist-info"} <= found, found
    assert ("flip_evaluator-1.7.dist-info" in found) == (sys.version_info[:2] < (3, 14)), found
    import OpenEXR  # noqa: F401

    small_scene()
    scene = bpy.context.scene
    scene.render.engine = "BO2_LIGHTING"
    # The node group specs ship in the zip: a BO2 Material can be made on the plane.
    bpy.context.view_layer.objects.active = bpy.data.objects["Plane"]
    assert bpy.ops.material.bo2_new() == {"FINISHED"}
    assert "BO2 Material" in bpy.data.node_groups
    assert scene.bo2.samples >= 1
    with tempfile.TemporaryDirectory() as out:
        scene.render.filepath = os.path.join(out, "frame.png")
        assert bpy.ops.render.render(write_still=True) == {"FINISHED"}
        image = bpy.data.images.load(scene.render.filepath)
        pixels = list(image.pixels)
        assert image.size[0] == 24 and max(pixels[0::4]) > 0.05

    bpy.ops.preferences.addon_disable(module=MODULE)
    assert not engine_available("BO2_LIGHTING")
    assert not hasattr(bpy.types.Scene, "bo2")
    assert "BO2_LIGHTING" not in bpy.types.RENDER_PT_format.COMPAT_ENGINES
    assert not hasattr(bpy.types, "RENDER_PT_bo2_settings")
    uninstall(repo)
    assert not (directory / "bo2_lighting").exists()


def test_install_twice_and_toggle_never_raises(user_repo):
    repo, _ = user_repo
    install(repo)
    bpy.ops.preferences.addon_disable(module=MODULE)
    bpy.ops.preferences.addon_enable(module=MODULE)
    bpy.ops.preferences.addon_enable(module=MODULE)
    result = bpy.ops.extensions.package_install_files(
        filepath=str(ZIP), repo=REPO, enable_on_install=True, overwrite=True)
    assert result == {"FINISHED"}
    assert engine_available("BO2_LIGHTING")
    bpy.ops.preferences.addon_disable(module=MODULE)
    assert not engine_available("BO2_LIGHTING")
    uninstall(repo)
