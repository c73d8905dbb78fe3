"""How close the GPU's passes are to the CPU's: PSNR per pass, and the Combined pass after the
view transform (Blender's Standard: sRGB) pixel by pixel, outside edge pixels."""

import numpy as np


def psnr(test: np.ndarray, reference: np.ndarray) -> float:
    """dB, peak = the reference's largest absolute value (at least 1e-6)."""
    peak = max(float(np.abs(reference).max()), 1e-6)
    mse = float(((np.asarray(test, np.float64) - reference) ** 2).mean())
    return 10.0 * np.log10(peak * peak / max(mse, 1e-30))


def srgb(linear: np.ndarray) -> np.ndarray:
    x = np.clip(linear, 0.0, 1.0)
    return np.where(x <= 0.0031308, 12.92 * x, 1.055 * x ** (1 / 2.4) - 0.055)


def edges(depth: np.ndarray, normal: np.ndarray) -> np.ndarray:
    """(H, W) bool: pixels next to a depth jump (over 2%) or a crease (normals over ~25 deg
    apart), the pixels whose samples see different surfaces."""
    h, w = depth.shape
    d = np.pad(depth, 1, mode="edge")
    n = np.pad(normal, ((1, 1), (1, 1), (0, 0)), mode="edge")
    out = np.zeros((h, w), bool)
    for dy in (-1, 0, 1):
        for dx in (-1, 0, 1):
            nd = d[1 + dy:1 + dy + h, 1 + dx:1 + dx + w]
            nn = n[1 + dy:1 + dy + h, 1 + dx:1 + dx + w]
            out |= np.abs(nd - depth) > 0.02 * np.minimum(np.abs(nd), np.abs(depth))
            both = (np.abs(nn).sum(-1) > 0) & (np.abs(normal).sum(-1) > 0)
            out |= both & ((nn * normal).sum(-1) < 0.9)
    return out


def off_pixels(gpu: dict, cpu: dict, limit: float = 4 / 255) -> tuple[int, int]:
    """(pixels of Combined off by more than ``limit`` after the view transform outside
    edges, edge pixels)."""
    edge = edges(cpu["Depth"][..., 0], cpu["Normal"])
    diff = np.abs(srgb(gpu["Combined"][..., :3]) - srgb(cpu["Combined"][..., :3])).max(-1)
    return int(((diff > limit) & ~edge).sum()), int(edge.sum())


def cell_interiors(image: np.ndarray) -> np.ndarray:
    """(H, W) bool: pixels whose eight neighbours hold the same value (inside a checker's
    cells)."""
    h, w = image.shape[:2]
    padded = np.pad(image, ((1, 1), (1, 1), (0, 0)), mode="edge")
    same = np.ones((h, w), bool)
    for dy in (-1, 0, 1):
        for dx in (-1, 0, 1):
            same &= (padded[1 + dy:1 + dy + h, 1 + dx:1 + dx + w] == image).all(-1)
    return same
