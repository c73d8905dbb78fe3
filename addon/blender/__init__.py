"""Blender glue of BO2 Lighting: the only package that imports ``bpy``."""
