"""A frame, stage by stage: the scene made into buffers, the raster (``raster``), shadow maps
(``shadows``), the world's occlusion (``sky``), materials, shading and the passes
(``passes``), ordered by ``pipeline``; the memory a frame takes (``memory``) and the viewport's
session (``viewport``).
"""
