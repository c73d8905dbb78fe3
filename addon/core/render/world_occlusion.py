"""The world-occlusion stage: how much of the world's light reaches the visible points through
the dome of shadow maps (``sky``), joined with the contact occlusion.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from ..formulas import occlusion, sh
from . import sky as sky_light
from .buffers import Frame


def world_visibility(frame: Frame, p: np.ndarray, n: np.ndarray, geo: np.ndarray,
                     sx: np.ndarray, sy: np.ndarray, albedo: np.ndarray, ao: np.ndarray,
                     tick: Callable[[float], None] | None = None
                     ) -> Callable[[np.ndarray], np.ndarray] | None:
    """The world's visibility at N points (``probes.indirect``'s ``sky``): a function of the
    indices k (K,) of the points the world's light reaches, giving (K,) float32; None when the
    frame has no dome.

    p, n, geo: (N, 3) positions, shading and geometric normals; sx, sy: (N,) window positions;
    albedo: (N, 3); ao: (N,) contact occlusion; tick: the tile's, called with 0 between steps.

    The world's light is occluded by the darker of the dome and the contact occlusion (both see
    the near surfaces: not their product), with what bounces off the occluders put back as for
    the latter (``occlusion.multi_bounce``) unless the bounce without probes holds it; divided
    by the contact occlusion's, which all indirect light gets.
    """
    sky = frame.sky
    if sky is None:
        return None
    scene = frame.scene
    rho = (albedo @ sh.LUMINANCE_REC709.astype(np.float32))[:, None]
    if scene.probes.bounce is not None:  # what bounces off the occluders is baked
        rho = rho * (1.0 - scene.probes.bounce.weight(p))[:, None]

    def seen(k):
        pk, nk, gk = p[k], n[k], geo[k]
        vis = sky_light.upsampled(
            lambda j: sky_light.visibility(sky, scene.probes.world_sh, pk[j], nk[j], gk[j],
                                           poll=None if tick is None else lambda: tick(0.0)),
            sx[k], sy[k], pk, gk, sky_light.stride(scene.camera.height))
        both = occlusion.multi_bounce(np.minimum(vis, ao[k]), rho[k])[:, 0]
        return both / np.maximum(occlusion.multi_bounce(ao[k], rho[k])[:, 0], 1e-3)

    return seen
