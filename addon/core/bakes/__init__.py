"""Bakes: probe captures by the renderer (``capture``) and the probe bake's bounces (``bake``),
lightmaps (``lightmap_bake``), and the coarse volume baked where no probe was placed
(``bounce``).
"""
