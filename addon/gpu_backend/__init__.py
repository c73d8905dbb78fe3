"""The GPU backend: the render job's stages as shaders drawn through Blender's ``gpu`` module.

Each stage takes the same inputs as the core's stage of its name (``core/render``) and gives
the same outputs, so that it is tested against it stage by stage; the NumPy references and
numba kernels stay the reference and the path where no GPU context exists. The shader sources
are the ``.glsl`` files of ``glsl/``; the uniform blocks they read are declared once in Python
(``uniforms``). Modules here import Blender's ``gpu`` (only inside functions that draw), never
``bpy``: what a Blender scene is comes from the core's dataclasses.
"""
