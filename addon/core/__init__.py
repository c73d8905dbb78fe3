"""Pure NumPy core of BO2 Lighting: the talk's model, the rasterizer and the renderer.

Nothing here imports ``bpy``, ``mathutils`` or ``gpu``: the core is a reference implementation
of Lazarov 2013, "Getting More Physical in Call of Duty: Black Ops II", usable outside Blender.

Its rooms, bottom floor first (a module imports from its own floor or those below; the
import-graph test keeps it so):

- ``system``: the machine: its memory, and the bounded caches that keep work between renders.
- ``kernels``: the compiled loops (numba).
- ``formulas``: the talk's formulas and the published ones beside them (BRDF, environment
  BRDF, SH, cube maps and their prefiltering, textures, occlusion), functions of arrays.
- ``scene``: what a scene is (meshes, lights, camera, world, settings) and the materials'
  programs that a node tree compiles to.
- ``lighting``: the light that reaches a point: a lamp's incidence and the talk's direct terms,
  probes, lightmaps, the world's probes and its sun.
- ``render``: a frame, stage by stage (raster, shadow maps, world and contact occlusion,
  materials, shading, passes), and the viewport's session.
- ``bakes``: probe captures, lightmap bakes and the bounce without probes.
- ``files``: what bakes and exports write to disk and read back.
- ``review``: comparisons with Cycles: metrics, pictures, the review page.
"""
