"""Comparison of two renders of one frame (BO2 Lighting against Cycles): error metrics, SSIM and
the comparison's report (metrics.json's content, its one-line headline), in NumPy only. The
pictures are ``imaging.py``'s.

What the module follows, and where from:

- Luminance: the Rec. ITU-R BT.709 weights (0.2126, 0.7152, 0.0722), the primaries of
  Blender's default scene-linear space (Linear Rec.709). On scene-linear RGB they give the
  relative luminance Y; on display-encoded R'G'B' they give the luma Y' (BT.709 eq. 3.2).
- RMSE, PSNR: PSNR = 10 log10(peak^2 / MSE) dB with the peak of the value range (1 for
  display-referred values in [0, 1]); identical images have MSE 0 and PSNR +inf.
- Mean relative error: mean over pixels and channels of |a - b| / (|b| + eps), b the reference
  (Cycles) and eps = 0.01 so that black pixels do not dominate (the "relative MSE" of
  Rousselle, Knaus and Zwicker, "Adaptive sampling and reconstruction using greedy error
  minimization", SIGGRAPH Asia 2011, guards its squared errors the same way).
- SSIM: Z. Wang, A. C. Bovik, H. R. Sheikh and E. P. Simoncelli, "Image quality assessment:
  from error visibility to structural similarity", IEEE TIP 13(4), 2004, eq. 13 with
  C1 = (K1 L)^2, C2 = (K2 L)^2, K1 = 0.01, K2 = 0.03, L the dynamic range, local statistics
  under an 11 x 11 circular-symmetric Gaussian window of standard deviation 1.5 normalized to
  unit sum (their section III.C), population (biased) variances, and the mean SSIM over the
  window positions that lie wholly inside the image (their reference implementation's
  ``filter2(..., 'valid')``). An image smaller than 11 pixels along an axis uses the largest
  odd window that fits (the same Gaussian, truncated).
Images are (H, W, C) float32 with row 0 at the TOP (the project's convention); display images
hold display-encoded values in [0, 1].
"""

from __future__ import annotations

import math

import numpy as np

REC709_WEIGHTS = np.array([0.2126, 0.7152, 0.0722], np.float32)
RELATIVE_EPS = 0.01
SSIM_SIGMA = 1.5
SSIM_K1, SSIM_K2 = 0.01, 0.03


# ---------------------------------------------------------------------------------------------
# Metrics


def luminance(rgb) -> np.ndarray:
    """Rec. 709 weighted sum of the first three channels.

    rgb:     (..., C >= 3) scene-linear RGB (gives luminance Y) or display-encoded (luma Y')
    returns: (...,) float32
    """
    rgb = np.asarray(rgb, np.float32)
    return rgb[..., 0] * REC709_WEIGHTS[0] + rgb[..., 1] * REC709_WEIGHTS[1] + (
        rgb[..., 2] * REC709_WEIGHTS[2])


def mse(a, b) -> float:
    """Mean squared difference over every element (float64 accumulation).

    a, b:    same shape, any units
    returns: MSE in the units squared
    """
    d = np.asarray(a, np.float64) - np.asarray(b, np.float64)
    return float(np.mean(d * d))


def rmse(a, b) -> float:
    """Root mean squared difference over every element, in the images' units."""
    return math.sqrt(mse(a, b))


def psnr(a, b, peak: float = 1.0) -> float:
    """Peak signal-to-noise ratio 10 log10(peak^2 / MSE) in dB; +inf for identical images.

    a, b:    same shape; values in [0, peak] (display-referred for the comparison)
    peak:    largest possible value
    """
    m = mse(a, b)
    return math.inf if m == 0.0 else 10.0 * math.log10(peak * peak / m)


def mean_relative_error(test, reference, eps: float = RELATIVE_EPS) -> float:
    """Mean of |test - reference| / (|reference| + eps) over every element (dimensionless).

    test, reference: same shape, scene-linear values (reference: Cycles)
    eps:             guard against dividing by black pixels
    """
    t = np.asarray(test, np.float64)
    r = np.asarray(reference, np.float64)
    return float(np.mean(np.abs(t - r) / (np.abs(r) + eps)))


def gaussian_window(sigma: float = SSIM_SIGMA, size: int = 11) -> np.ndarray:
    """The 1-D factor of SSIM's separable Gaussian window, normalized to unit sum.

    sigma:   standard deviation in pixels
    size:    odd number of taps (11 for Wang et al.'s window)
    returns: (size,) float64; the 2-D window is its outer product with itself
    """
    x = np.arange(size, dtype=np.float64) - (size - 1) / 2
    w = np.exp(-0.5 * (x / sigma) ** 2)
    return w / w.sum()


def _filter_valid(image: np.ndarray, w: np.ndarray) -> np.ndarray:
    """Correlate a 2-D image with the separable window w x w, keeping only the positions where
    the window lies inside the image: (H, W) -> (H - n + 1, W - n + 1), n = len(w)."""
    n = len(w)
    h, wd = image.shape
    rows = sum(w[i] * image[i:h - n + 1 + i] for i in range(n))
    return sum(w[j] * rows[:, j:wd - n + 1 + j] for j in range(n))


def ssim_map(x, y, data_range: float = 1.0, sigma: float = SSIM_SIGMA, size: int = 11,
             k1: float = SSIM_K1, k2: float = SSIM_K2) -> np.ndarray:
    """Local SSIM of two greyscale images (Wang et al. 2004, eq. 13).

    x, y:       (H, W) images on the same scale (display-referred luma for the comparison)
    data_range: L, the dynamic range of the values (1 for values in [0, 1])
    sigma:      standard deviation of the Gaussian window in pixels
    size:       window size, odd; reduced to the largest odd size that fits the image
    returns:    (H - n + 1, W - n + 1) float64 SSIM per window position, n the window size
    """
    x = np.asarray(x, np.float64)
    y = np.asarray(y, np.float64)
    if x.shape != y.shape or x.ndim != 2:
        raise ValueError(f"SSIM needs two 2-D images of one shape, got {x.shape} and {y.shape}")
    n = min(size, *x.shape)
    n -= 1 - n % 2  # odd
    w = gaussian_window(sigma, n)
    c1, c2 = (k1 * data_range) ** 2, (k2 * data_range) ** 2
    mx, my = _filter_valid(x, w), _filter_valid(y, w)
    sxx = _filter_valid(x * x, w) - mx * mx
    syy = _filter_valid(y * y, w) - my * my
    sxy = _filter_valid(x * y, w) - mx * my
    return ((2 * mx * my + c1) * (2 * sxy + c2)) / ((mx * mx + my * my + c1) * (sxx + syy + c2))


def ssim(x, y, data_range: float = 1.0, sigma: float = SSIM_SIGMA) -> float:
    """Mean SSIM (MSSIM, Wang et al. 2004 eq. 17) of two greyscale images; 1 when identical."""
    return float(np.mean(ssim_map(x, y, data_range, sigma)))


def image_metrics(linear_test, linear_ref, display_test, display_ref) -> dict:
    """The comparison's four numbers for one image or pass.

    linear_*:  (H, W, 3) scene-linear RGB (test: BO2 Lighting, ref: Cycles)
    display_*: (H, W, 3) the same through the view transform, display-encoded in [0, 1]
    returns:   {"rmse": scene-linear RGB, "mean_relative_error": scene-linear RGB,
                "psnr_db": display RGB (None when identical), "ssim": display luma}
    """
    p = psnr(display_test, display_ref)
    return {
        "rmse": rmse(linear_test, linear_ref),
        "mean_relative_error": mean_relative_error(linear_test, linear_ref),
        "psnr_db": None if math.isinf(p) else p,
        "ssim": ssim(luminance(display_test), luminance(display_ref)),
    }


def nice_ceil(x: float) -> float:
    """The smallest of 1, 1.5, 2, 2.5, 3, 4, 5, 6, 8 times a power of ten that is >= x (x > 0):
    the end of a colour scale."""
    x = max(float(x), 1e-12)
    e = math.floor(math.log10(x))
    for m in (1.0, 1.5, 2.0, 2.5, 3.0, 4.0, 5.0, 6.0, 8.0, 10.0):
        v = float(f"{m * 10.0 ** e:.12g}")
        if v >= x * (1 - 1e-9):
            return v
    return 10.0 ** (e + 1)


def format_seconds(seconds: float) -> str:
    """A render time for a label: 0.84 s, 12.3 s, 2 min 05 s."""
    if seconds < 10:
        return f"{seconds:.2f} s"
    if seconds < 60:
        return f"{seconds:.1f} s"
    minutes, rest = divmod(round(seconds), 60)
    return f"{minutes} min {rest:02d} s"


# ---------------------------------------------------------------------------------------------
# The report

# Light passes (pipeline names) compared, with the Cycles colour pass they are multiplied by:
# Cycles' Diffuse and Glossy light passes exclude the surface colour, BO2 Lighting's include it.
LIGHT_PASSES = {"DiffDir": "DiffCol", "GlossDir": "GlossCol", "DiffInd": "DiffCol",
                "GlossInd": "GlossCol", "Emit": None}
DATA_PASSES = ("Depth", "Normal", "Position", "UV", "IndexMA")
GEOMETRY_DEPTH = 1e9  # both engines write 1e10 where the camera sees no geometry

DEFINITIONS = {
    "rmse": "root mean square of BO2 - Cycles over pixels and RGB channels, scene-linear "
            "(EXR values)",
    "mean_relative_error": "mean of |BO2 - Cycles| / (|Cycles| + 0.01) over pixels and RGB "
                           "channels, scene-linear",
    "psnr_db": "10 log10(1 / MSE) of the display-referred RGB in [0, 1] (through the scene's "
               "view transform); null when the images are identical",
    "ssim": "mean SSIM (Wang et al. 2004; 11x11 Gaussian window, sigma 1.5, K1 0.01, K2 0.03, "
            "L 1) of the display-referred Rec.709 luma",
    "cycles_times_color": "Cycles' Diffuse/Glossy Direct/Indirect passes exclude the surface "
                          "colour; they are multiplied by Cycles' Diffuse/Glossy Color pass "
                          "before the comparison with BO2 Lighting's, which include it",
    "data_passes": "Depth, Normal, Position, UV: rmse and mean_abs_error over the pixels where "
                   "both engines see geometry; Material Index: fraction of those pixels equal",
    "heat_map": "difference.png: |Y(BO2) - Y(Cycles)|, Y the Rec.709 luminance of the "
                "scene-linear Combined pass, in the colour map from 0 to scale_max",
}


def light_pairs(bo2: dict, cycles: dict) -> dict[str, tuple[np.ndarray, np.ndarray]]:
    """The scene-linear images compared: {pass: (BO2 (H, W, 3), Cycles (H, W, 3))}, Combined
    first, then each light pass both engines wrote, Cycles' times its colour pass.

    bo2, cycles: {pipeline pass name: (H, W, C) float32} of each engine
    """
    pairs = {"Combined": (bo2["Combined"][..., :3], cycles["Combined"][..., :3])}
    for name, color in LIGHT_PASSES.items():
        if name in bo2 and name in cycles and (color is None or color in cycles):
            pairs[name] = (bo2[name], cycles[name] * cycles[color] if color else cycles[name])
    return pairs


def data_metrics(name: str, bo2: np.ndarray, cycles: np.ndarray, geometry: np.ndarray) -> dict:
    """A G-buffer pass (H, W, C) of each engine compared where ``geometry`` (H, W) is True."""
    a, b = bo2[geometry], cycles[geometry]
    if name == "IndexMA":
        equal = float(np.mean(a == b)) if a.size else 1.0
        return {"fraction_equal": equal, "pixels": int(geometry.sum())}
    if not a.size:
        return {"rmse": 0.0, "mean_abs_error": 0.0, "pixels": 0}
    return {"rmse": rmse(a, b),
            "mean_abs_error": float(np.mean(np.abs(a.astype(np.float64) - b))),
            "pixels": int(geometry.sum())}


def difference(pairs: dict) -> tuple[np.ndarray, float, float]:
    """The heat map's quantity |Y(BO2) - Y(Cycles)| (H, W) of the Combined pair, its scale end
    (``nice_ceil`` of the 99th percentile, or of the maximum when that is 0) and the
    percentile."""
    bo2, cycles = pairs["Combined"]
    diff = np.abs(luminance(bo2) - luminance(cycles))
    high = float(np.percentile(diff, 99)) if diff.size else 0.0
    high = high if high > 0 else float(diff.max(initial=0.0))
    return diff, (nice_ceil(high) if high > 0 else 1.0), high


def report(pairs: dict, display: dict, bo2: dict, cycles: dict, info: dict, context: dict,
           files: dict, label=str) -> dict:
    """metrics.json's content.

    pairs:   ``light_pairs``; display: the same images through the view transform
    bo2, cycles: every pass of each engine (the data passes are compared where both engines
             see geometry)
    info:    {"bo2": {...}, "cycles": {...}}: each engine's render, with "render_seconds"
    context: what was rendered (scene, file, frame, view layer, Blender version, resolution,
             colour management), first in the report
    files:   {file name: path} written by the comparison
    label:   the name of a pass in the report, from its pipeline name
    """
    metrics = {name: image_metrics(*pairs[name], *display[name]) for name in pairs}
    passes = {label(name): metrics[name] for name in pairs if name != "Combined"}
    if "Depth" in bo2 and "Depth" in cycles:
        geometry = ((bo2["Depth"][..., 0] < GEOMETRY_DEPTH)
                    & (cycles["Depth"][..., 0] < GEOMETRY_DEPTH))
        for name in DATA_PASSES:
            if name in bo2 and name in cycles and bo2[name].shape == cycles[name].shape:
                passes[label(name)] = data_metrics(name, bo2[name], cycles[name], geometry)
    _, scale_max, high = difference(pairs)
    t_bo2, t_cyc = info["bo2"]["render_seconds"], info["cycles"]["render_seconds"]
    return {
        **context,
        "engines": info,
        "speedup": t_cyc / t_bo2 if t_bo2 > 0 else None,
        "cycles_times_color": True,
        "image": metrics["Combined"],
        "passes": passes,
        "heat_map": {"quantity": "abs_linear_luminance_difference", "scale_max": scale_max,
                     "percentile_99": high},
        "definitions": DEFINITIONS,
        "files": files,
    }


def metrics_line(m: dict) -> str:
    """RMSE, PSNR and SSIM of ``image_metrics`` on one line."""
    psnr_text = "inf" if m["psnr_db"] is None else f"{m['psnr_db']:.1f}"
    return f"RMSE {m['rmse']:.4g}  PSNR {psnr_text} dB  SSIM {m['ssim']:.3f}"


def headline(result: dict) -> str:
    """One line: BO2 1.2 s, Cycles 30 s (25x); RMSE 0.031, PSNR 31.2 dB, SSIM 0.950."""
    t_bo2 = result["engines"]["bo2"]["render_seconds"]
    t_cyc = result["engines"]["cycles"]["render_seconds"]
    m = result["image"]
    speed = f" ({result['speedup']:.1f}x)" if result["speedup"] else ""
    psnr_text = "inf" if m["psnr_db"] is None else f"{m['psnr_db']:.1f}"
    return (f"BO2 {format_seconds(t_bo2)}, Cycles {format_seconds(t_cyc)}{speed}; "
            f"RMSE {m['rmse']:.3g}, PSNR {psnr_text} dB, SSIM {m['ssim']:.3f}")
