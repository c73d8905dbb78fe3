"""Helpers that the demo scene scripts share: materials, lights, light probes and a sky.

Imported by the ``build_*.py`` scripts next to it (run as scripts, their folder is on the path)
and by ``tools/make_probe_images.py`` and ``tools/make_motion_blur_images.py``.
"""

import math

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


def slab(name, lo, hi, material):
    """An axis-aligned box mesh from corner ``lo`` to ``hi`` (3,), metres."""
    centre = [(a + b) / 2 for a, b in zip(lo, hi, strict=True)]
    bpy.ops.mesh.primitive_cube_add(size=1.0, location=centre)
    obj = bpy.context.object
    obj.name = name
    obj.scale = [b - a for a, b in zip(lo, hi, strict=True)]
    obj.data.materials.append(material)
    return obj


def ball(name, radius, location, material):
    """A smooth UV sphere mesh."""
    bpy.ops.mesh.primitive_uv_sphere_add(segments=64, ring_count=32, radius=radius,
                                         location=location)
    obj = bpy.context.object
    obj.name = name
    bpy.ops.object.shade_smooth()
    obj.data.materials.append(material)
    return obj


def bo2_material(name, albedo, rf0, gloss, emission=(0.0, 0.0, 0.0), strength=0.0):
    """A material made of the BO2 Material node group (the talk's parameters); an emission
    of ``strength`` is added through an Emission shader when it is above 0."""
    from bo2_lighting.addon.blender import node_groups

    mat = node_groups.new_material(name)
    group = next(n for n in mat.node_tree.nodes if node_groups.is_bo2_material_node(n))
    group.inputs["Albedo"].default_value = (*albedo, 1.0)
    group.inputs["Specular Color"].default_value = (*rf0, 1.0)
    group.inputs["Gloss"].default_value = gloss
    if strength > 0.0:
        nodes, links = mat.node_tree.nodes, mat.node_tree.links
        output = next(n for n in nodes if n.type == "OUTPUT_MATERIAL")
        glow = nodes.new("ShaderNodeEmission")
        glow.inputs["Color"].default_value = (*emission, 1.0)
        glow.inputs["Strength"].default_value = strength
        add = nodes.new("ShaderNodeAddShader")
        links.new(group.outputs[0], add.inputs[0])
        links.new(glow.outputs[0], add.inputs[1])
        links.new(add.outputs[0], output.inputs["Surface"])
    return mat


def closed_room(lo, hi, material, thickness=0.2, window=None):
    """Floor, ceiling and four walls of ``thickness`` around the inside box ``lo``-``hi``;
    ``window`` (y0, y1, z0, z1) opens the wall at x = lo[0]."""
    (x0, y0, z0), (x1, y1, z1), t = lo, hi, thickness
    slab("Floor", (x0 - t, y0 - t, z0 - t), (x1 + t, y1 + t, z0), material)
    slab("Ceiling", (x0 - t, y0 - t, z1), (x1 + t, y1 + t, z1 + t), material)
    slab("Wall back", (x0 - t, y1, z0), (x1 + t, y1 + t, z1), material)
    slab("Wall front", (x0 - t, y0 - t, z0), (x1 + t, y0, z1), material)
    slab("Wall right", (x1, y0, z0), (x1 + t, y1, z1), material)
    if window is None:
        slab("Wall left", (x0 - t, y0, z0), (x0, y1, z1), material)
        return
    wy0, wy1, wz0, wz1 = window
    slab("Wall left 1", (x0 - t, y0, z0), (x0, wy0, z1), material)
    slab("Wall left 2", (x0 - t, wy1, z0), (x0, y1, z1), material)
    slab("Wall left 3", (x0 - t, wy0, z0), (x0, wy1, wz0), material)
    slab("Wall left 4", (x0 - t, wy0, wz1), (x0, wy1, z1), material)


def empty_scene(resolution=(480, 270)):
    """Blender's factory settings without objects, the add-on registered, and a scene that
    renders with BO2 Lighting at ``resolution`` (100%) through the Standard view; returns it."""
    import bo2_lighting

    bpy.ops.wm.read_factory_settings(use_empty=True)
    bo2_lighting.register()
    scene = bpy.context.scene
    scene.render.resolution_x, scene.render.resolution_y = resolution
    scene.render.resolution_percentage = 100
    scene.render.engine = "BO2_LIGHTING"
    scene.view_settings.view_transform = "Standard"
    return scene


def camera(lens, location, rotation_deg):
    """A camera of focal length ``lens`` (mm) at ``location``, XYZ Euler ``rotation_deg``
    (degrees), linked to the scene and made its camera."""
    cam = bpy.data.objects.new("Camera", bpy.data.cameras.new("Camera"))
    cam.data.lens = lens
    cam.location = location
    cam.rotation_euler = [math.radians(a) for a in rotation_deg]
    bpy.context.scene.collection.objects.link(cam)
    bpy.context.scene.camera = cam
    return cam


def save(out):
    """Save the open file as ``out`` (a Path; its folder made), and say so."""
    out.parent.mkdir(parents=True, exist_ok=True)
    bpy.ops.wm.save_as_mainfile(filepath=str(out))
    print(f"wrote {out}")
