"""Helpers that the demo scene scripts share: materials, lights, light probes and a sky.

Imported by the ``build_*.py`` scripts next to it (run as scripts, their folder is on the path)
and by ``tools/make_probe_images.py``.
"""

import bpy


def principled(name, base, metallic=0.0, roughness=0.5, ior=1.5):
    """A Principled BSDF material of linear colour ``base`` (3,)."""
    mat = bpy.data.materials.new(name)
    if mat.node_tree is None:  # Blender 4.5; 5.0 materials always have a node tree
        mat.use_nodes = True
    node = mat.node_tree.nodes["Principled BSDF"]
    node.inputs["Base Color"].default_value = (*base, 1.0)
    node.inputs["Metallic"].default_value = metallic
    node.inputs["Roughness"].default_value = roughness
    node.inputs["IOR"].default_value = ior
    return mat


def light(kind, name, location, rotation, **settings):
    """A light object of ``kind`` linked to the scene; ``settings`` go to its light data."""
    data = bpy.data.lights.new(name, kind)
    for key, value in settings.items():
        setattr(data, key, value)
    obj = bpy.data.objects.new(name, data)
    obj.location, obj.rotation_euler = location, rotation
    bpy.context.scene.collection.objects.link(obj)
    return obj


def probe(kind, name, location, scale=None, **settings):
    """A light probe object ("SPHERE" or "VOLUME") linked to the scene; ``settings`` go to its
    probe data (influence_distance, falloff, resolution_x, ...)."""
    obj = bpy.data.objects.new(name, bpy.data.lightprobes.new(name, kind))
    obj.location = location
    if scale is not None:
        obj.scale = scale
    for key, value in settings.items():
        setattr(obj.data, key, value)
    bpy.context.scene.collection.objects.link(obj)
    return obj


def sky(color, name="Sky"):
    """A world of one colour (3,), made the scene's world; returns it."""
    world = bpy.data.worlds.new(name)
    if world.node_tree is None:
        world.use_nodes = True
    world.node_tree.nodes["Background"].inputs["Color"].default_value = (*color, 1.0)
    bpy.context.scene.world = world
    return world
