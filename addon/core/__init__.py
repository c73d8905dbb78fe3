"""Pure NumPy core of BO2 Lighting: the talk's model, the rasterizer and the pipeline.

Nothing here imports ``bpy``, ``mathutils`` or ``gpu``: the core is a reference implementation
of Lazarov 2013, "Getting More Physical in Call of Duty: Black Ops II", usable outside Blender.
"""
