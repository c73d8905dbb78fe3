"""NVIDIA FLIP, the perceptual error of a rendered image against its reference, through the
reference implementation (PyPI ``flip-evaluator``, the authors' own C++ with Python bindings).

- LDR-FLIP: P. Andersson, J. Nilsson, T. Akenine-Moeller, M. Oskarsson, K. Astroem and
  M. D. Fairchild, "FLIP: A Difference Evaluator for Alternating Images", Proc. ACM Comput.
  Graph. Interact. Tech. 3(2), 2020. Inputs are display-encoded sRGB values in [0, 1]: here the
  output of the scene's view transform, which is what a viewer sees.
- HDR-FLIP: P. Andersson, J. Nilsson, P. Shirley and T. Akenine-Moeller, "Visualizing Errors in
  Rendered High Dynamic Range Images", Eurographics 2021 short papers. Inputs are scene-linear
  Rec.709 (linear sRGB) values >= 0: here the EXRs. It tone-maps both images at a range of
  exposures chosen from the reference and keeps each pixel's largest LDR-FLIP error.

Both use the implementation's defaults: 67 pixels per degree (a 0.7 m wide 3840-pixel monitor
seen from 0.7 m), and for HDR its ACES tone mapper and automatic exposure range. An error map is
(H, W) float32 in [0, 1], 0 where the images cannot be told apart; its mean is the figure a
report ranks by. Images are (H, W, 3) with row 0 at the top.

The package has wheels for CPython 3.11 and 3.13 (Linux, Windows, macOS arm64), not 3.14:
``unavailable()`` says why it cannot be used, and callers report without FLIP.
"""

from __future__ import annotations

import numpy as np

PIXELS_PER_DEGREE = 67.0
# HDR-FLIP's automatic exposure range starts at the reference's largest luminance and ends at
# its median, clamped below; for a reference darker than that clamp the range is reversed and
# the implementation ends the process. Below this largest luminance HDR-FLIP is not computed.
HDR_BLACK = 1e-5


def unavailable() -> str | None:
    """None when FLIP can be computed here, else one line saying why not."""
    try:
        import flip_evaluator  # noqa: F401
    except ImportError as exc:
        return f"FLIP is not available: the flip-evaluator package cannot be imported ({exc})"
    return None


def _prepare(image, hdr: bool) -> np.ndarray:
    a = np.asarray(image, np.float32)[..., :3]
    if a.ndim != 3 or a.shape[-1] != 3:
        raise ValueError(f"FLIP needs (H, W, 3) images, got {a.shape}")
    a = np.nan_to_num(a, nan=0.0, posinf=65504.0, neginf=0.0)
    return np.ascontiguousarray(np.clip(a, 0.0, None if hdr else 1.0))


def evaluate(reference, test, hdr: bool = False, colour: bool = False):
    """FLIP of ``test`` against ``reference``.

    reference, test: (H, W, 3) of one shape; display-encoded in [0, 1] (LDR) or scene-linear
                     >= 0 (HDR); NaN counts as 0, values outside the range are clipped
    hdr:             HDR-FLIP instead of LDR-FLIP
    colour:          return the error map through FLIP's magma colour map, (H, W, 3) float32 in
                     [0, 1], instead of the errors (H, W)
    returns:         (error map, mean error in [0, 1]); for HDR-FLIP of a black reference
                     (luminance below ``HDR_BLACK`` everywhere) (None, None): it is undefined
    """
    import flip_evaluator

    ref, tst = _prepare(reference, hdr), _prepare(test, hdr)
    if ref.shape != tst.shape:
        raise ValueError(f"FLIP needs two images of one shape, got {ref.shape} and {tst.shape}")
    if hdr and float((ref @ np.float32([0.2126, 0.7152, 0.0722])).max(initial=0.0)) < HDR_BLACK:
        return None, None
    error, mean, _ = flip_evaluator.evaluate(ref, tst, "HDR" if hdr else "LDR", inputsRGB=True,
                                             applyMagma=colour, computeMeanError=True,
                                             parameters={"ppd": PIXELS_PER_DEGREE})
    error = np.asarray(error, np.float32)
    if not colour:
        error = error.reshape(ref.shape[:2])
    return error, float(mean)
