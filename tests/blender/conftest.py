"""Blender tests run against the real ``bpy`` module; each starts from factory settings."""

import sys
from pathlib import Path

import bpy
import pytest

# ``tests/panel_walk.py`` is shared with the walk in a real window (``tests/gui``)
sys.path.insert(0, str(Path(__file__).resolve().parent.parent))


@pytest.fixture
def empty_scene():
    """A fresh factory-startup file with no objects."""
    bpy.ops.wm.read_factory_settings(use_empty=True)
    return bpy.context.scene


@pytest.fixture
def addon(empty_scene):
    """The add-on registered from the source tree (as the ``bo2`` command does) for one test."""
    import bo2_lighting

    bo2_lighting.register()
    yield bo2_lighting
    bo2_lighting.unregister()
