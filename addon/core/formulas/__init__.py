"""The talk's formulas and the published ones beside them, as functions of NumPy arrays.

Each module cites the slides (or papers) it implements: the BRDF terms (``brdf``), the
environment BRDF (``env_brdf``), spherical harmonics (``sh``), cube maps (``cubemap``) and their
prefiltering (``prefilter``, its gather in ``cube_filter``), textures and their colour spaces
(``texture``), tangent frames and normal maps (``tangents``), ambient and specular occlusion
(``occlusion``) and affine transforms (``affine``).
"""
