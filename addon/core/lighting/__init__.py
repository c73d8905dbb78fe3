"""The light that reaches a point: a lamp's incidence and the talk's direct terms (``shade``),
the indirect light of probes (``probes``), of lightmaps (``lightmap``) and of the world alone
(``world_probes``), and the world's sun taken out as a lamp (``world_sun``).
"""
