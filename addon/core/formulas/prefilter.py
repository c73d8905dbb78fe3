"""Prefiltered environment maps: the cosine-power (Phong lobe) mip chain of Black Ops II and the
angular-Gaussian chain of Black Ops (AMD CubeMapGen), both seamless.

Sources:

- Lazarov 2013, "Getting More Physical in Call of Duty: Black Ops II", slides "Black Ops:
  environment map pre-filtering" (BO1: offline CubeMapGen, angular Gaussian filter, edge fixup;
  the shader picks lod = nMips - gloss * nMips) and "Improved environment map pre-filtering"
  (BO2: a cosine power filter, each mip filtered with the specular power of its gloss, the top
  mip's resolution tied to the maximum specular power, 256 -> 128, and the Blinn-Phong to Phong
  conversion alpha_phong = alpha_blinn_phong / 4).
- AMD CubeMapGen 1.1 (ATI Research 2005, ``CCubeMapProcessor``), and its modified version by
  Lagarde 2012, "AMD Cubemapgen for physically based rendering" (the cosine power filter that
  BO2's customised CubeMapGen and this module's BO2 chain follow).

BO2 chain (``prefilter_cosine_power``). A face size S = 2^M gives M + 1 mips (S, S/2, ..., 1).
The shader reads lod = M - gloss M, so mip m holds gloss g_m = 1 - m / M, whose Blinn-Phong power
is 8192^g_m (the project's alpha = 8192^g) and whose Phong power is p_m = 8192^g_m / 4. Mip m
is the normalized convolution of the radiance with the Phong lobe around each texel's direction r:

    L_m(r) = sum_d max(r.d, 0)^p_m L(d) dOmega(d) / sum_d max(r.d, 0)^p_m dOmega(d)

over source texels d with exact solid angles dOmega. The Phong lobe (r.d)^p ~ exp(-p theta^2 / 2)
is close to a Gaussian of standard deviation 1 / sqrt(p) radians, which ties the top mip to the
maximum power (``top_resolution``): a face of S texels has a texel spacing of 2 / S radians at
its centre, and keeping it within one standard deviation of the sharpest lobe needs
S >= 2 sqrt(p_0). For p_0 = 8192 / 4 = 2048 that is 90.5, so S = 128; without the Blinn-Phong to
Phong conversion (p_0 = 8192) it would be 181, so S = 256: the talk's drop from 256 to 128.

BO1 chain (``prefilter_angular_gaussian``), CubeMapGen's "Angular Gaussian" filter with its
parameters "base filter angle" (default 20 degrees), "initial mip filter angle" (1 degree) and
"mip filter angle scale" (2), the defaults of CubeMapGen's library sample. A filter of cone angle
A (degrees) averages the source texels within the half-angle h = A / 2 of the output direction,
each weighted by its solid angle and by exp(-theta^2 / (2 sigma^2)) with sigma = h / 3 ("fit 3
standard deviations within the angular extent"); h is clamped to [atan(1 / S_src), 90 degrees],
S_src the face size being filtered. Mip 0 filters the input with A = base angle; mip m >= 1
filters mip m - 1 (already filtered, twice the size) with A = initial * scale^(m - 1): a cascade,
so mip m's lobe is the composition of all the passes before it (``angular_gaussian_angles``
lists each pass's half-angle and the accumulated standard deviation). Nothing ties the angles to
gloss, the problem the BO2 chain fixes. Differences from CubeMapGen, all deliberate: the Gaussian
is evaluated exactly (CubeMapGen reads it from a 4096-entry table indexed by floor(4095 cos
theta), which flattens it below about 1.3 degrees); solid angles are exact (CubeMapGen 1.1 used
two planar triangles per texel); where no source texel centre falls inside the cone (small
angles at a face centre, where each output texel sits on the corner of four source texels)
CubeMapGen copies the texel under the centre tap, one of four equidistant texels picked by
rounding, while this module takes the seamless bilinear sample there (their average); and the
edge fixup (averaging the texels along the 12 edges for hardware that could not filter across
faces) is not applied, since the filters read across edges by construction and
``cubemap.sample`` filters seamlessly.

Implementation: the symmetric gather of ``cube_filter``.
"""

from __future__ import annotations

import math

import numpy as np

from . import cube_filter, cubemap

__all__ = [
    "BLINN_PHONG_MAX_POWER",
    "DEFAULT_BASE_ANGLE",
    "DEFAULT_INITIAL_MIP_ANGLE",
    "DEFAULT_MIP_ANGLE_SCALE",
    "angular_gaussian_angles",
    "cone_angle",
    "gloss_to_lod",
    "mip_gloss",
    "mip_powers",
    "cmft_powers",
    "prefilter_angular_gaussian",
    "prefilter_cosine_power",
    "prefilter_powers",
    "top_resolution",
]

# alpha = 8192^g (Lazarov 2013, slide "Black Ops: normal distribution function"); the BO2 chain's
# top power is the Phong equivalent 8192 / 4 (slide "Improved environment map pre-filtering").
BLINN_PHONG_MAX_POWER = 8192.0

# AMD CubeMapGen's defaults (CubeMapGen library sample: base filter angle 20, initial mip filter
# angle 1, mip filter angle scale 2, angular Gaussian, solid-angle weighting).
DEFAULT_BASE_ANGLE = 20.0
DEFAULT_INITIAL_MIP_ANGLE = 1.0
DEFAULT_MIP_ANGLE_SCALE = 2.0



# ---------------------------------------------------------------------------------------------
# Gloss, powers and resolutions (BO2)


def mip_gloss(size: int) -> np.ndarray:
    """Gloss held by each mip of a chain: g_m = 1 - m / M, M = log2(S).

    The shader's lod = nMips - gloss * nMips with nMips = M (Lazarov 2013, slide "Black Ops:
    environment map pre-filtering") reads mip m at gloss g_m. A 1 x 1 cube (M = 0) holds g = 1.

    size:    S, the top mip's face size, a power of two
    returns: (M + 1,) float64 gloss in [0, 1], decreasing
    """
    m_count = cube_filter.mip_count(size)
    if m_count == 0:
        return np.ones(1)
    return 1.0 - np.arange(m_count + 1) / m_count


def gloss_to_lod(gloss, n_mips: int) -> np.ndarray:
    """The shader's mip selection, lod = nMips - gloss * nMips.

    Lazarov 2013, slide "Black Ops: environment map pre-filtering".

    gloss:   any shape, gloss in [0, 1]
    n_mips:  nMips = M = log2(S), the index of the chain's 1 x 1 mip
    returns: same shape, float32 lod in mips
    """
    g = np.asarray(gloss, np.float32)
    return (np.float32(n_mips) - g * np.float32(n_mips)).astype(np.float32)


def mip_powers(size: int) -> np.ndarray:
    """Phong power of each BO2 mip: p_m = 8192^(g_m) / 4, g_m = 1 - m / M.

    Slide "Improved environment map pre-filtering" (each mip filtered with the matching gloss;
    alpha_phong = alpha_blinn_phong / 4), with alpha = 8192^g.

    size:    S, the top mip's face size, a power of two
    returns: (M + 1,) float64 Phong exponents, 2048 at mip 0 down to 0.25 at the 1 x 1 mip
    """
    return BLINN_PHONG_MAX_POWER ** mip_gloss(size) / 4.0


def top_resolution(max_power: float = BLINN_PHONG_MAX_POWER / 4.0) -> int:
    """Smallest power-of-two face size that resolves the sharpest Phong lobe of a chain.

    The lobe (r.d)^p ~ exp(-p theta^2 / 2) has a standard deviation of 1 / sqrt(p) radians; a
    face of S texels has a texel spacing of 2 / S radians at its centre (the largest on the
    face). Asking for one texel per standard deviation gives S >= 2 sqrt(p). Slide "Improved
    environment map pre-filtering": "top mip resolution tied to max specular power", which let
    BO2 drop from 256 to 128: top_resolution(8192 / 4) = 128, top_resolution(8192) = 256.

    max_power: Phong power of mip 0 (2048 = 8192 / 4 by default)
    returns:   face size S, a power of two
    """
    need = 2.0 * math.sqrt(float(max_power))
    return 1 << max(0, math.ceil(math.log2(max(need, 1.0)) - 1e-9))


def cone_angle(power: float, cutoff: float = 1e-4) -> float:
    """Half-angle of the cone where the Phong lobe (cos theta)^p is at least ``cutoff`` of its peak.

    power:   Phong exponent p > 0
    cutoff:  relative weight at the cone's edge, in (0, 1)
    returns: theta_c = acos(cutoff^(1/p)) in radians, at most pi / 2
    """
    return float(np.arccos(np.clip(cutoff ** (1.0 / float(power)), 0.0, 1.0)))


# ---------------------------------------------------------------------------------------------
# Angular Gaussian schedule (BO1)


def angular_gaussian_angles(
    size: int,
    base_angle: float = DEFAULT_BASE_ANGLE,
    initial_mip_angle: float = DEFAULT_INITIAL_MIP_ANGLE,
    mip_angle_scale: float = DEFAULT_MIP_ANGLE_SCALE,
) -> tuple[np.ndarray, np.ndarray]:
    """Per-mip filter angles of CubeMapGen's angular Gaussian chain, as this module applies them.

    Pass m filters a face of S_src texels (the input for m = 0, mip m - 1 otherwise) with the cone
    angle A_0 = base_angle, A_m = initial_mip_angle * mip_angle_scale^(m - 1); its half-angle is
    h_m = clamp(A_m / 2, atan(1 / S_src), 90 degrees) and its Gaussian sigma_m = h_m / 3
    (CubeMapGen's ``FilterCubeMapMipChain`` and ``PrecomputeFilterLookupTables``; slide "Black
    Ops: environment map pre-filtering"). Passes compose: for angles small against a radian,
    Gaussians on the sphere add their variances, so mip m's lobe has the accumulated standard
    deviation sqrt(sigma_0^2 + ... + sigma_m^2) (ignoring the resampling to half resolution,
    which adds about a texel's width).

    size:              S, the input face size, a power of two
    base_angle:        A_0 in degrees
    initial_mip_angle: A_1 in degrees
    mip_angle_scale:   ratio A_{m+1} / A_m
    returns:           half_angles (M + 1,) float64 degrees, the h_m used by each pass;
                       sigmas (M + 1,) float64 degrees, the accumulated standard deviations
    """
    m_count = cube_filter.mip_count(size)
    half = np.empty(m_count + 1)
    for m in range(m_count + 1):
        src = size if m == 0 else size >> (m - 1)
        angle = base_angle if m == 0 else initial_mip_angle * mip_angle_scale ** (m - 1)
        texel = math.degrees(math.atan2(1.0, src))
        half[m] = min(max(angle / 2.0, texel), 90.0)
    return half, np.sqrt(np.cumsum((half / 3.0) ** 2))


# ---------------------------------------------------------------------------------------------
# Public filters


def prefilter_cosine_power(
    cube,
    *,
    cutoff: float = 1e-4,
    texels_per_sigma: float = 4.0,
    min_source: int = 32,
    workers: int = 2,
) -> list[np.ndarray]:
    """BO2 prefiltered mip chain: mip m convolved with the Phong lobe (r.d)^p_m, p_m = 8192^g_m / 4.

    Slide "Improved environment map pre-filtering" (cosine power filter, each mip filtered with
    the matching gloss, alpha_phong = alpha_blinn_phong / 4), with the mip <-> gloss mapping of
    slide "Black Ops: environment map pre-filtering" (g_m = 1 - m / M, ``mip_gloss``). Each
    output texel r gets sum (r.d)^p L(d) dOmega(d) / sum (r.d)^p dOmega(d) over the source
    texels d where (r.d)^p >= cutoff; mip m reads the coarsest level of the source pyramid whose
    face size is at least 2 texels_per_sigma sqrt(p_m) (texel spacing 2 / S_src <= sigma /
    texels_per_sigma, sigma = 1 / sqrt(p_m)), at least the mip's own size and at least
    min_source (or the input's size if smaller). See the module docstring for the method.

    cube:             (6, S, S, C) float32 radiance, S a power of two, ``cubemap.FACES`` layout
    cutoff:           relative lobe weight below which source texels are skipped
    texels_per_sigma: source texels per lobe standard deviation (accuracy vs time)
    min_source:       smallest source face size used for the wide lobes
    workers:          threads
    returns:          list of M + 1 float32 arrays (6, S >> m, S >> m, C), M = log2(S)
    """
    return prefilter_powers(cube, mip_powers(cube.shape[1]), cutoff=cutoff,
                            texels_per_sigma=texels_per_sigma, min_source=min_source,
                            workers=workers)


def prefilter_powers(
    cube,
    powers,
    *,
    cutoff: float = 1e-4,
    texels_per_sigma: float = 4.0,
    min_source: int = 32,
    workers: int = 2,
    warp: bool = False,
    exclude_base: bool = False,
    should_stop=None,
) -> list[np.ndarray]:
    """A mip chain whose mip m is the cube convolved with the Phong lobe (r.d)^powers[m]
    (``prefilter_cosine_power``'s method, any powers: cmft's ``cmft_powers`` for instance).

    cube:         (6, S, S, C) float32 radiance, S a power of two
    powers:       (N,) Phong exponents of mips 0 .. N - 1, N <= log2(S) + 1
    warp:         filter at the edge fixup's directions (``_output_directions``)
    exclude_base: mip 0 is the input itself, unfiltered (cmft's ``excludeBase``)
    should_stop:  called before each mip; True stops with ``InterruptedError``
    returns:      list of N float32 arrays (6, S >> m, S >> m, C)
    """
    cube = cube_filter.check_cube(cube)
    size = cube.shape[1]
    powers = [float(p) for p in np.atleast_1d(powers)]
    count = cube_filter.mip_count(size) + 1
    if not 1 <= len(powers) <= count or not all(p > 0 for p in powers):
        raise ValueError(f"expected 1 to {count} positive powers for a face of {size}, got "
                         f"{powers}")
    pyramid = cubemap.build_pyramid(cube)
    mips = []
    for m, power in enumerate(powers):
        if should_stop is not None and should_stop():
            raise InterruptedError("prefiltering stopped")
        out_size = size >> m
        if m == 0 and exclude_base:
            mips.append(cube.copy())
            continue
        want = 2.0 * texels_per_sigma * math.sqrt(power)
        src_size = 1 << max(0, math.ceil(math.log2(max(want, 1.0)) - 1e-9))
        src_size = min(size, max(src_size, out_size, min(min_source, size)))
        source = pyramid[cube_filter.mip_count(size) - cube_filter.mip_count(src_size)]
        reach = cone_angle(power, cutoff)
        mips.append(cube_filter.filter_level(source, out_size,
                                             cube_filter.weights_phong(power, cutoff), reach,
                                             workers, warp))
    return mips


CMFT_MODELS = ("phong", "phongbrdf", "blinn", "blinnbrdf")


def cmft_powers(mip_count: int, gloss_scale: float = 10.0, gloss_bias: float = 1.0,
                model: str = "blinnbrdf") -> np.ndarray:
    """Phong exponents of the mips of cmft's radiance filter (Manesku, cmft, "specularPowerFor"
    and "applyLightningModel"): gloss g_m = max(0, 1 - m / (N - 1)), specular power
    2^(glossScale g_m + glossBias), then by lighting model: phong p, phongbrdf p + 1, blinn
    p / 4, blinnbrdf p / 4 + 1 (Lagarde 2012, the Blinn-Phong to Phong conversion). The BO2
    chain (slide "Improved environment map pre-filtering") is blinn with glossScale 13,
    glossBias 0 (8192^g / 4) over the whole chain. Defaults: cmft's.

    mip_count: N >= 1
    returns:   (N,) float64 Phong exponents
    """
    if model not in CMFT_MODELS:
        raise ValueError(f"lighting model {model!r}: expected one of {', '.join(CMFT_MODELS)}")
    m = np.arange(int(mip_count), dtype=np.float64)
    gloss = np.maximum(0.0, 1.0 - m / (mip_count - 1.0)) if mip_count > 1 else np.ones(1)
    power = 2.0 ** (gloss_scale * gloss + gloss_bias)
    if model.startswith("blinn"):
        power = power / 4.0
    return power + 1.0 if model.endswith("brdf") else power


def prefilter_angular_gaussian(
    cube,
    base_angle: float = DEFAULT_BASE_ANGLE,
    initial_mip_angle: float = DEFAULT_INITIAL_MIP_ANGLE,
    mip_angle_scale: float = DEFAULT_MIP_ANGLE_SCALE,
    *,
    workers: int = 2,
    warp: bool = False,
) -> list[np.ndarray]:
    """BO1 prefiltered mip chain: AMD CubeMapGen's angular Gaussian cascade.

    Slide "Black Ops: environment map pre-filtering" (offline CubeMapGen, angular Gaussian
    filter). Mip 0 filters the input with the cone angle ``base_angle``; mip m >= 1 filters mip
    m - 1 with initial_mip_angle * mip_angle_scale^(m - 1). A pass of half-angle h (clamped to
    [atan(1 / S_src), 90 degrees]) averages the source texels within h of the output direction
    with weights dOmega exp(-theta^2 / (2 sigma^2)), sigma = h / 3, renormalized; where no
    source texel centre lies within h, the output is the seamless bilinear sample of the source.
    ``angular_gaussian_angles`` gives each mip's angles; the module docstring lists the
    differences from CubeMapGen.

    cube:              (6, S, S, C) float32 radiance, S a power of two
    base_angle:        cone angle of mip 0, degrees (CubeMapGen "Base Filter Angle")
    initial_mip_angle: cone angle of mip 1, degrees ("Initial Mip Filter Angle")
    mip_angle_scale:   ratio of successive cone angles ("Mip Filter Angle Scale")
    workers:           threads
    warp:              filter at the edge fixup's directions (``_output_directions``)
    returns:           list of M + 1 float32 arrays (6, S >> m, S >> m, C)
    """
    cube = cube_filter.check_cube(cube)
    size = cube.shape[1]
    half_angles, _ = angular_gaussian_angles(size, base_angle, initial_mip_angle,
                                             mip_angle_scale)
    mips = []
    source = cube
    for m, half in enumerate(half_angles):
        h = math.radians(float(half))
        edge = h * (1.0 + cube_filter.EDGE_TOLERANCE)
        weight = cube_filter.weights_gaussian(h / 3.0, edge)
        level = cube_filter.filter_level(source, size >> m, weight, edge, workers, warp)
        mips.append(level)
        source = level
    return mips
