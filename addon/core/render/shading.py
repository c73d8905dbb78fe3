"""The shading stage: the visible points lit by every light (the talk's direct terms, their
shadow maps) and by the indirect light (probes, lightmaps, the world's occlusion), composed
into the passes' columns; the world seen where no surface is.
"""

from __future__ import annotations

import numpy as np

from ..formulas import affine, occlusion, sh, texture
from ..lighting import lightmap as lightmap_light
from ..lighting import probes, shade, world_sun
from ..scene import Scene, linking
from . import shadow_filter
from .buffers import Frame
from .passes import SAMPLED, SAMPLED_WIDTH, extra_columns, extras, film_width, group_columns
from .surfaces import surface_aovs, surface_params
from .world_occlusion import world_visibility


def background_radiance(scene: Scene, x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """(N, 3) world radiance seen through window positions x, y (N,); a texture's times the
    background's opacity (``World.background_alpha``, a studio light's)."""
    world = scene.world
    if world.texture is None:
        return np.broadcast_to(np.asarray(world.color, np.float32), (len(x), 3))
    _, d = scene.camera.rays(x, y)
    px = texture.sample(world.texture,
                        texture.direction_to_equirect_uv(affine.linear(d, world.rotation)),
                        world.background_lod or None)
    scale = np.float32(world.strength * world.background_alpha)
    out = px[:, :3] * scale
    if world.sun is not None:
        out += world_sun.disc_radiance(world, d) * np.float32(world.background_alpha)
    return out.astype(np.float32)


def has_indirect(frame: Frame) -> bool:
    """The frame has indirect light that can reach a point: probes that send light
    (``probes.sends_light``) or lightmaps."""
    probes_ = frame.scene.probes
    return probes_ is not None and (frame.lightmaps is not None or probes.sends_light(probes_))


def shade_points(frame: Frame, tri, bary, sx, sy, tick=None, ao_tile=None,
                 seeds=None, eyes=None) -> np.ndarray:
    """Shade N visible points: tri (N,), bary (N, 3), window positions sx, sy (N,);
    ``tick`` (the tile's) is called with 0 between the long steps, so a stop comes soon;
    ``ao_tile``: the tile's ``tile_ambient`` and its origin (x, y) in the frame, or None;
    ``seeds``: (N, 3) the shadow filter's rotation seeds (``shadow_filter.pixel_seeds``), or
    None (the positions'); ``eyes``: (N, 3) where each point is seen from (a lens point,
    ``depth_of_field``), or None: the camera.

    returns: (N, ``passes.film_width``) float32, the averaged passes side by side (columns
             ``SAMPLED``; Combined with alpha 1), then each light group's light
             (``passes.group_columns``)
    """
    from ..kernels import shading

    scene, cam = frame.scene, frame.scene.camera
    m = len(tri)
    p, n, geo = (np.empty((m, 3), np.float32) for _ in range(3))
    uv = np.empty((m, 2), np.float32)
    if eyes is None:
        _, d = cam.rays(sx, sy)
        v = -d
    else:
        v = eyes - np.einsum("nk,nkc->nc", bary, frame.positions[tri]).astype(np.float32)
        v /= np.maximum(np.linalg.norm(v, axis=1, keepdims=True), np.float32(1e-20))
    # position, normals (turned towards the camera), UV
    shading.surface(np.ascontiguousarray(tri, np.int32), np.ascontiguousarray(bary, np.float32),
                    frame.positions, frame.normals, frame.uvs, v, p, n, geo, uv)
    mat = surface_params(frame, tri, bary, p, n, geo, v, sx, sy)
    n = mat.normal

    diffuse = np.zeros((len(tri), 3), np.float32)
    specular = np.zeros((len(tri), 3), np.float32)
    model = scene.settings.specular_model
    groups = scene.settings.light_groups
    grouped = np.zeros((len(tri), 3 * len(groups)), np.float32)  # each light group's light
    # shadow catchers: the lights' irradiance on them, shadowed (held) and not (free)
    caught = (np.zeros(0, np.int64) if frame.catcher is None else
              np.flatnonzero(frame.catcher[tri]))
    held, free = (np.zeros((len(caught), 3), np.float32) for _ in range(2))
    for light, smap in zip(scene.lights, frame.shadow_maps[:len(scene.lights)], strict=True):
        # The geometric normal decides what faces the light (a shading normal may not).
        l_dir, irradiance, lit = shade.light_incidence(light, p, geo)
        if light.receivers:  # a linked light lights the meshes of its set alone
            lit &= linking.in_set(frame.receives[tri], light.receivers)
            irradiance[~lit] = 0.0
        if not lit.any():
            continue
        vis = None if smap is None else shadow_filter.shadow_visibility(smap, p, geo, where=lit,
                                                                          seeds=seeds)
        if len(caught):
            e = irradiance[caught] * np.maximum(
                np.einsum("nk,nk->n", n[caught], l_dir[caught]), 0.0)[:, None]
            free += e
            held += e if vis is None else e * vis[caught, None]
        if light.group not in groups:
            shade.add_direct(n, v, l_dir, irradiance, mat.albedo, mat.rf0, mat.gloss, model,
                             diffuse, specular, visibility=vis)
            continue
        own = np.zeros_like(diffuse), np.zeros_like(specular)
        shade.add_direct(n, v, l_dir, irradiance, mat.albedo, mat.rf0, mat.gloss, model,
                         *own, visibility=vis)
        diffuse += own[0]
        specular += own[1]
        k = groups.index(light.group)
        grouped[:, 3 * k:3 * k + 3] += own[0] + own[1]
    ao = np.ones(len(tri), np.float32)
    if ao_tile is not None:
        image, x0, y0 = ao_tile
        ao = image[np.clip(np.floor(sy).astype(np.int64) - y0, 0, image.shape[0] - 1),
                   np.clip(np.floor(sx).astype(np.int64) - x0, 0, image.shape[1] - 1)]
    baked = None
    if has_indirect(frame):
        s = scene.settings
        seen = world_visibility(frame, p, n, geo, sx, sy, mat.albedo, ao, tick)
        baked = lightmap_sh(frame, tri, bary)
        diff_ind, gloss_ind = probes.indirect(scene.probes, p, n, v, mat.albedo, mat.rf0,
                                              mat.gloss, s.normalization, s.prefilter, s.env_brdf,
                                              sky=seen,
                                              baked=None if baked is None else baked[:2],
                                              extrapolate=s.volume_extrapolation,
                                              visibility=s.volume_visibility,
                                              nearest=s.nearest_reflections)
        if mat.occlusion is not None:  # the glTF importer's occlusion dims indirect light
            diff_ind *= mat.occlusion[:, None]
            gloss_ind *= mat.occlusion[:, None]
        if ao_tile is not None:
            bounce = occlusion.multi_bounce(ao, mat.albedo)
            if baked is not None:  # a lightmap holds its surface's occlusion already
                bounce[baked[0]] = 1.0
            diff_ind *= bounce
            if s.specular_occlusion:
                n_dot_v = np.einsum("nk,nk->n", n, v)
                gloss_ind *= occlusion.specular(ao, n_dot_v, mat.gloss)[:, None]
    else:
        diff_ind = gloss_ind = np.zeros((len(tri), 3), np.float32)
    extra = extras(scene.settings)
    out = np.empty((len(tri), film_width(extra)), np.float32)
    if scene.settings.aovs:
        first = extra_columns(extra)[scene.settings.aovs[0][0]].start
        out[:, first:] = surface_aovs(frame, tri, bary, p, n, geo, v, sx, sy)
    if groups:
        if scene.world.group in groups:  # the probes' light is the world's
            k = groups.index(scene.world.group)
            grouped[:, 3 * k:3 * k + 3] += diff_ind + gloss_ind
        emits = frame.group[tri]
        for k in np.unique(emits[emits >= 0]):
            at = emits == k
            grouped[at, 3 * k:3 * k + 3] += mat.emission[at]
        out[:, SAMPLED_WIDTH:SAMPLED_WIDTH + grouped.shape[1]] = grouped
    f32 = np.ascontiguousarray
    cols = np.array([SAMPLED[name].start for name in shading.COMPOSED], np.int64)
    shading.compose(out, cols, n, p, uv, f32(frame.has_uv[tri]), diffuse, specular,
                    f32(diff_ind, np.float32), f32(gloss_ind, np.float32),
                    *(f32(a, np.float32) for a in (mat.emission, mat.albedo, mat.rf0,
                                                   mat.gloss)))
    out[:, SAMPLED["AO"]] = ao[:, None]
    out[:, SAMPLED["Shadow Catcher"]] = 1.0
    if len(caught):
        catch_shadows(out, caught, held, free, scene, sx, sy)
    lm, texels = SAMPLED["Lightmap"], SAMPLED["Lightmap Texels"]
    out[:, lm] = 0.0
    out[:, texels] = 0.0
    if baked is not None:
        k, coeffs, checker = baked
        out[k, lm] = np.einsum("nk,nkc->nc", sh.basis(n[k]) * sh.BAND_FACTORS, coeffs)
        out[k, texels] = checker
    return out


def catch_shadows(out: np.ndarray, caught: np.ndarray, held: np.ndarray, free: np.ndarray,
                  scene: Scene, sx, sy) -> None:
    """Shadow catchers (Blender's Shadow Catcher, as Cycles renders them) among the shaded
    points, rows ``caught`` of ``out`` (the passes, ``shade_points``): the share of the lights'
    irradiance their shadows let through, ``held`` over ``free`` (K, 3) (1 where no light
    reaches), is the Shadow Catcher pass. Combined shows the world behind them times that
    share, or with a transparent film black of opacity one less its mean; with the Shadow
    Catcher pass wanted, nothing (alpha 0: the shadows are in the pass alone). Their light is
    in no light group but the world's."""
    share = np.where(free > 0.0, held / np.maximum(free, np.float32(1e-30)), np.float32(1.0))
    share = np.clip(share, 0.0, 1.0).astype(np.float32)
    combined = SAMPLED["Combined"]
    out[caught, SAMPLED["Shadow Catcher"]] = share
    if scene.settings.shadow_catcher_pass:
        out[caught, combined] = 0.0
    elif scene.settings.film_transparent:
        out[caught, combined.start:combined.start + 3] = 0.0
        out[caught, combined.start + 3] = 1.0 - share.mean(1)
    else:
        out[caught, combined.start:combined.start + 3] = background_radiance(
            scene, sx[caught], sy[caught]) * share
    groups = scene.settings.light_groups
    if groups:
        out[caught, SAMPLED_WIDTH:SAMPLED_WIDTH + 3 * len(groups)] = 0.0
        if scene.world.group in groups:
            k = groups.index(scene.world.group)
            out[caught, group_columns(k)] = out[caught, combined.start:combined.start + 3]


def lightmap_sh(frame: Frame, tri, bary) -> tuple | None:
    """The lightmapped points among those on triangles ``tri`` (N,) at weights ``bary``
    (N, 3): their indices (K,), the SH (K, 9, 3) of the light their lightmap holds
    (``lightmap.as_sh``) and their texels' checker colour (K, 3) (the Lightmap Texels pass),
    or None when none is lightmapped."""
    if frame.lightmap is None:
        return None
    which = frame.lightmap[tri]
    k = np.flatnonzero(which >= 0)
    if not k.size:
        return None
    uv = np.einsum("nk,nkc->nc", bary[k], frame.lightmap_uvs[tri[k]])
    out = np.zeros((k.size, 9, 3), np.float32)
    checker = np.zeros((k.size, 3), np.float32)
    for m in np.unique(which[k]):
        sel = np.flatnonzero(which[k] == m)
        image = frame.lightmaps[m].image
        out[sel] = lightmap_light.as_sh(lightmap_light.sample(image, uv[sel]))
        h, w = image.shape[:2]
        cell = (np.floor(uv[sel, 0] * w) + np.floor((1.0 - uv[sel, 1]) * h)) % 2
        hue = np.asarray(LIGHTMAP_HUES[m % len(LIGHTMAP_HUES)], np.float32)
        checker[sel] = hue * (0.45 + 0.55 * cell)[:, None].astype(np.float32)
    return k, out, checker


# The Lightmap Texels pass: one hue per lightmap, its texels a checker of two shades of it
LIGHTMAP_HUES = ((0.9, 0.35, 0.3), (0.3, 0.65, 0.9), (0.4, 0.85, 0.35), (0.95, 0.8, 0.3),
                 (0.75, 0.45, 0.9), (0.3, 0.85, 0.8))
