"""A frame, stage by stage: the job (``job``), prepare (``buffers``), shadow maps
(``shadow_maps``), what each sample sees (``visibility``), contact occlusion
(``contact_occlusion``), the world's occlusion (``world_occlusion``), materials (``surfaces``),
shading (``shading``) and the passes (``passes``), ordered by ``pipeline``. What they draw
with: the raster (``raster``, ``projection``, ``clipping``, ``transparency``), shadow maps
(``shadows``, queried by ``shadow_filter``) and the world's dome (``sky``). The memory a frame
takes (``memory``) and the viewport's session (``viewport``).
"""
