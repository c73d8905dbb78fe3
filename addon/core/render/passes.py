"""The render passes the engine writes: the one table of their names and channels.

Names are the pipeline's (Blender 4's pass names; ``blender/passes.py`` maps them to Blender
5's renames and to the view layer's flags). Channel ids are those Blender registers and the
multilayer EXR files store (``<layer>.<pass>.<id>``).

- Combined: RGBA radiance (alpha 0 for a transparent film).
- Depth: view-axis distance, metres (``EMPTY_DEPTH`` where no geometry is seen); IndexMA: the
  material's pass index. Both from one sample, the one nearest the pixel centre, as Cycles.
- Normal (world-space shading normal), Position (world space, metres), UV (u, v, 1 on meshes
  with a UV map).
- DiffDir, GlossDir, DiffInd, GlossInd, Emit: the light, direct and indirect (the probes).
- Albedo, Specular Color, Gloss: the material in the talk's parameters after texture lookups.
- Lightmap: the irradiance a baked lightmap gives the pixel (W/m^2; 0 where none); Lightmap
  Texels: each lightmap's texels as a checker of its own hue (their density; 0 where none).
"""

from __future__ import annotations

from dataclasses import dataclass

__all__ = ["EMPTY_DEPTH", "PASSES", "SAMPLED", "SAMPLED_WIDTH", "Pass"]

EMPTY_DEPTH = 1e10


@dataclass(frozen=True)
class Pass:
    """One render pass.

    name:     the pipeline's name (Blender 4's)
    ids:      channel ids, one letter per channel ("RGBA", "XYZ", "Z", ...)
    kind:     "COLOR", "VECTOR" or "VALUE", as Blender registers it
    group:    "data", "index", "light" or "material": where the pass panel shows it
    averaged: averaged over the anti-aliasing samples (else taken from the nearest sample)
    """

    name: str
    ids: str
    kind: str
    group: str
    averaged: bool = True

    @property
    def channels(self) -> int:
        """Number of channels."""
        return len(self.ids)


PASSES: dict[str, Pass] = {p.name: p for p in (
    Pass("Combined", "RGBA", "COLOR", "data"),
    Pass("Depth", "Z", "VALUE", "data", averaged=False),
    Pass("Normal", "XYZ", "VECTOR", "data"),
    Pass("Position", "XYZ", "VECTOR", "data"),
    Pass("UV", "UVA", "VECTOR", "data"),
    Pass("IndexMA", "X", "VALUE", "index", averaged=False),
    Pass("DiffDir", "RGB", "COLOR", "light"),
    Pass("GlossDir", "RGB", "COLOR", "light"),
    Pass("DiffInd", "RGB", "COLOR", "light"),
    Pass("GlossInd", "RGB", "COLOR", "light"),
    Pass("Emit", "RGB", "COLOR", "light"),
    Pass("AO", "RGB", "COLOR", "light"),
    Pass("Albedo", "RGB", "COLOR", "material"),
    Pass("Specular Color", "RGB", "COLOR", "material"),
    Pass("Gloss", "X", "VALUE", "material"),
    Pass("Lightmap", "RGB", "COLOR", "light"),
    Pass("Lightmap Texels", "RGB", "COLOR", "data"),
)}

def _sampled_columns() -> tuple[dict[str, slice], int]:
    columns, start = {}, 0
    for p in PASSES.values():
        if p.averaged:
            columns[p.name] = slice(start, start + p.channels)
            start += p.channels
    return columns, start


# The averaged passes side by side in one (N, SAMPLED_WIDTH) array: name -> column slice.
SAMPLED, SAMPLED_WIDTH = _sampled_columns()
