"""The scene as a final render evaluates it, for work outside a render (bakes).

Blender evaluates modifiers (Subdivision's and Multires' Render levels, a modifier shown in
renders only), geometry nodes (``Is Viewport``), particles, curve resolution and object
visibility with their render settings only in the dependency graph it gives a render engine;
Python cannot make one. ``evaluate(scene, read)`` renders the scene with this engine, at the
smallest size and with nothing drawn, and calls ``read(depsgraph)`` from the engine's
``render()`` (``serve``) with that graph: what it returns must not keep references into it.

The render result the Image Editor shows is kept: the render goes into a render slot of its
own (``SLOT``), and the slot shown before is shown again; without an earlier render, the
Render Result image this render made is removed. The settings changed for it (the scene's
engine, size, border, compositing and sequencer, the view layer's Use for Rendering) are
restored whatever happens.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import bpy

ENGINE = "BO2_LIGHTING"


class _Request:
    def __init__(self, scene_name: str, read: Callable[[Any], Any]):
        self.scene_name = scene_name
        self.read = read
        self.done = False
        self.value = None
        self.error: BaseException | None = None


_pending: _Request | None = None


def serve(depsgraph) -> bool:
    """Called first by the engine's ``render()``: when ``evaluate`` waits for this render,
    run its ``read`` on ``depsgraph`` and return True (the render draws nothing)."""
    global _pending
    request = _pending
    if request is None or request.scene_name != depsgraph.scene.name:
        return False
    _pending = None
    request.done = True
    try:
        request.value = request.read(depsgraph)
    except BaseException as exc:  # noqa: BLE001 - re-raised by ``evaluate``, outside the render
        request.error = exc
    return True


def evaluate(scene, read: Callable[[Any], Any], view_layer=None):
    """``read(depsgraph)`` with ``scene``'s render dependency graph (``depsgraph.mode`` is
    "RENDER") for ``view_layer`` (the window's, when None); returns what it returns, raises
    what it raises. RuntimeError, one line, when Blender would not render (a render already
    runs, an output size it refuses)."""
    global _pending
    layer = view_layer or bpy.context.view_layer
    r = scene.render
    saved = (r.engine, r.resolution_percentage, r.use_border, r.use_compositing,
             r.use_sequencer, layer.use)
    camera = scene.camera
    stand_in = None
    slots = _spare_slot()
    request = _Request(scene.name, read)
    _pending = request
    try:
        if camera is None:  # Blender renders only through a camera; a bake needs none
            stand_in = bpy.data.objects.new("BO2 scene reading",
                                            bpy.data.cameras.new("BO2 scene reading"))
            scene.camera = stand_in
        r.engine = ENGINE
        # the smallest image Blender renders: 8 pixels on the short side
        r.resolution_percentage = min(100, max(1, -(-800 // max(1, min(r.resolution_x,
                                                                       r.resolution_y)))))
        r.use_border = r.use_compositing = r.use_sequencer = False
        layer.use = True  # a view layer off for renders is still the one the bake reads
        try:
            bpy.ops.render.render(layer=layer.name, scene=scene.name)
        except RuntimeError as exc:  # "Cannot render, ...": Blender's reason, one line
            reason = str(exc).strip().splitlines()[-1].removeprefix("Error: ")
            raise RuntimeError(f"Blender could not read scene '{scene.name}' as a render "
                               f"does ({reason})") from None
    finally:
        _pending = None
        if stand_in is not None:
            scene.camera = camera
            data = stand_in.data
            bpy.data.objects.remove(stand_in)
            bpy.data.cameras.remove(data)
        (r.engine, r.resolution_percentage, r.use_border, r.use_compositing,
         r.use_sequencer, layer.use) = saved
        if slots is not None:
            _restore_slot(*slots)
        else:  # Blender made the Render Result image for this render: no render of the user's
            for image in [i for i in bpy.data.images if i.type == "RENDER_RESULT"]:
                bpy.data.images.remove(image)
    if request.error is not None:
        raise request.error
    if not request.done:
        raise RuntimeError(f"Blender did not render scene '{scene.name}' (is a render "
                           "running?)")
    return request.value


SLOT = "BO2 scene reading"


def _spare_slot():
    """The Render Result image's slot named ``SLOT`` (made once, then reused: Blender keeps
    the slot last rendered into), made active: (image, the slot active before), or None
    when there is no Render Result yet."""
    image = next((i for i in bpy.data.images if i.type == "RENDER_RESULT"), None)
    if image is None:
        return None
    slots = image.render_slots
    before = slots.active_index
    slot = next((s for s in slots if s.name == SLOT), None)
    slots.active = slot if slot is not None else slots.new(name=SLOT)
    return image, before


def _restore_slot(image, before: int) -> None:
    slots = image.render_slots
    slots.active_index = min(before, len(slots) - 1)
