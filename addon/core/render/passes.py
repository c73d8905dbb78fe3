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
- Shadow Catcher: on shadow catchers the share of the lights' light their shadows let through
  (Cycles' pass: multiply a backplate by it), 1 elsewhere.

After these, the passes the view layer names (``extras``): each light group's light
(``Combined_<group>``), then each shader AOV (its name: the AOV Output nodes' Color or Value).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = ["EMPTY_DEPTH", "PASSES", "SAMPLED", "SAMPLED_WIDTH", "Pass", "extra_columns",
           "extras", "film_width", "group_columns", "group_pass"]

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
    Pass("Shadow Catcher", "RGB", "COLOR", "light"),
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


def group_pass(group: str) -> str:
    """The name of light group ``group``'s pass, as Cycles names it."""
    return f"Combined_{group}"


def extras(settings) -> tuple[tuple[str, int], ...]:
    """The averaged passes after ``SAMPLED`` that ``settings`` (``RenderSettings``) asks for:
    (name, channels) of each light group (RGB), then of each shader AOV (RGBA or one value,
    as Cycles writes them)."""
    return (tuple((group_pass(g), 3) for g in settings.light_groups)
            + tuple((name, 4 if kind == "COLOR" else 1) for name, kind in settings.aovs))


def film_width(extra: tuple[tuple[str, int], ...]) -> int:
    """Columns of the averaged passes: ``SAMPLED``'s, then those of ``extras``."""
    return SAMPLED_WIDTH + sum(c for _, c in extra)


def extra_columns(extra: tuple[tuple[str, int], ...]) -> dict[str, slice]:
    """Each pass of ``extras``: its columns in the averaged passes."""
    out, start = {}, SAMPLED_WIDTH
    for name, channels in extra:
        out[name] = slice(start, start + channels)
        start += channels
    return out


def group_columns(k: int) -> slice:
    """The columns of the k-th light group in the averaged passes (the first of ``extras``)."""
    return slice(SAMPLED_WIDTH + 3 * k, SAMPLED_WIDTH + 3 * k + 3)


def _averaged(image: np.ndarray, extra: tuple[tuple[str, int], ...]) -> dict:
    out = {name: image[..., SAMPLED[name]] for name in SAMPLED}
    out.update({name: image[..., cols] for name, cols in extra_columns(extra).items()})
    return out


def tile_passes(tile, acc: np.ndarray, depth: np.ndarray, index: np.ndarray,
                crypto: dict | None = None, extra: tuple[tuple[str, int], ...] = ()) -> dict:
    """The passes stage of one tile (x0, y0, x1, y1): the averaged passes side by side
    ``acc`` (npx, ``film_width(extra)``), Depth and IndexMA (npx,), the Cryptomatte passes
    {name: (npx, 4)}, as {pass name: (h, w, C) float32}."""
    x0, y0, x1, y1 = tile
    shape = (y1 - y0, x1 - x0)
    image = acc.reshape(*shape, film_width(extra))
    out = _averaged(image, extra)
    out["Depth"], out["IndexMA"] = depth.reshape(*shape, 1), index.reshape(*shape, 1)
    for name, ranks in (crypto or {}).items():
        out[name] = ranks.reshape(*shape, 4)
    return out


class Film:
    """The passes stage of whole views: ``count`` films of ``height`` x ``width`` pixels that
    tiles are written into (with the passes ``extra``, ``extras``); outside them the passes
    are 0 (Depth: ``EMPTY_DEPTH``)."""

    def __init__(self, count: int, height: int, width: int,
                 extra: tuple[tuple[str, int], ...] = ()) -> None:
        self.extra = tuple(extra)
        self.film = np.zeros((count, height, width, film_width(self.extra)), np.float32)
        self.depth = np.full((count, height, width, 1), EMPTY_DEPTH, np.float32)
        self.index = np.zeros((count, height, width, 1), np.float32)
        self.crypto: dict[str, np.ndarray] = {}  # name -> (count, height, width, 4)

    def add(self, view: int, tile, acc: np.ndarray, depth: np.ndarray,
            index: np.ndarray, crypto: dict | None = None) -> None:
        """One tile of view ``view``: arrays as ``tile_passes``."""
        x0, y0, x1, y1 = tile
        shape = (y1 - y0, x1 - x0)
        self.film[view, y0:y1, x0:x1] = acc.reshape(*shape, film_width(self.extra))
        self.depth[view, y0:y1, x0:x1, 0] = depth.reshape(shape)
        self.index[view, y0:y1, x0:x1, 0] = index.reshape(shape)
        for name, ranks in (crypto or {}).items():
            if name not in self.crypto:
                self.crypto[name] = np.zeros((*self.film.shape[:3], 4), np.float32)
            self.crypto[name][view, y0:y1, x0:x1] = ranks.reshape(*shape, 4)

    def passes(self) -> list[dict]:
        """[{pass name: (H, W, C) float32}] per view; the averaged passes are views of one
        (H, W, ``film_width``) film."""
        out = []
        for k in range(len(self.film)):
            passes = _averaged(self.film[k], self.extra)
            passes["Depth"], passes["IndexMA"] = self.depth[k], self.index[k]
            passes.update({name: image[k] for name, image in self.crypto.items()})
            out.append(passes)
        return out
