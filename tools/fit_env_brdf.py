"""Fit our approximation of the environment BRDF (``env_brdf.fit_parts``) to the ground truth.

Usage: python tools/fit_env_brdf.py [--check | --no-fit]

The model (docs/env_brdf.md) is BO2's own curve with free coefficients, a free offset in its
exponent, and a metal part that follows the same capped exponential:

    t  = c g + d                      (float4: t.x, t.y, t.z, t.w)
    m  = min(t.y, 2^(k n.v + b))
    a0 = t.x m + t.z
    a1 = min(s m + t.w, 1)
    E  = saturate(a0 + rf0 (a1 - a0))

Cost, counted per scalar operation: MAD/FMA 1, add/sub/mul 1, min/max 1, exp2/log2/rcp/sqrt 1,
saturate 1; a vector operation counts once per component. Black Ops II's ``EnvironmentBRDF``
(slide "Final approximation"): t = g c + d (4 MAD), -9.28 n.v (1), exp2 (1), min (1),
a0 = t.x min + t.z (1), a1 - a0 (1), a0 + rf0 (a1 - a0) (3 MAD for RGB), saturate (3) = 15.
Ours: the same 15 with a MAD for k n.v + b in place of the multiply, plus s m + t.w (1 MAD) and
min(., 1) (1) = 17, two more than BO2, one exp2 as BO2.

Fit: the ground truth ``env_brdf.ground_truth`` (Schlick-Smith visibility) on the 201 x 201
grid g = 0, 0.005, ..., 1 by n.v = linspace(1e-4, 1, 201), about ten seconds. The error of E
is taken at rf0 = 0, 0.04 and 1 under three weightings of the grid: uniform over (g, n.v); n.v
weighted as it appears on screen (density 2 n.v: a sphere's pixels); n.v >= 0.05 alone. Each
of the 18 figures (3 weightings x 3 rf0 x max and mean |error|) is divided by BO2's on the same
grid and weighting, and the fit minimises the largest of these ratios (a soft maximum, made
sharper in four rounds); the dielectrics bind that maximum, so a last round then lowers the
metals' (rf0 = 1) errors with the largest ratio held. The minimiser is Nelder-Mead (written
here, NumPy only), started from BO2's own coefficients (every ratio 1), restarted from the best
point with smaller steps. The coefficients are rounded to 4 decimals.

Prints the coefficients (as the ``FIT_A0``, ``FIT_A1`` lines of ``addon/core/env_brdf.py``),
the operation counts and the error tables. ``--check`` refits and exits 1 unless every
unrounded coefficient lies within 1e-3 of the committed one. ``--no-fit`` prints the tables of
the committed coefficients only.
"""

from __future__ import annotations

import argparse
import sys

import numpy as np

from bo2_lighting.addon.core import env_brdf

GLOSS = np.linspace(0.0, 1.0, 201)
N_DOT_V = np.linspace(env_brdf.N_DOT_V_MIN, 1.0, 201)
RF0 = (0.0, 0.04, 1.0)
WEIGHTINGS = ("uniform", "screen (2 n.v)", "n.v >= 0.05")
DECIMALS = 4
CHECK_TOLERANCE = 1e-3
SHARPNESS = (10.0, 30.0, 100.0, 300.0)  # the soft maximum's rounds
# BO2's EnvironmentBRDF in this model's terms: (cx, dx, cy, dy, cz, dz, cw, dw, k, b, s)
START = (1 / 0.96, 0.0, 0.475, 0.0, (0.0275 - 0.25 * 0.04) / 0.96,
         (0.015 - 0.75 * 0.04) / 0.96, 0.25, 0.75, -9.28, 0.0, 0.0)

# (operation, count) of each model, counted as in the module docstring
OPS_BO2 = (("t = g c + d, float4 MAD", 4), ("-9.28 n.v", 1), ("exp2", 1), ("min", 1),
           ("a0 = t.x min + t.z", 1), ("a1 - a0", 1), ("a0 + rf0 (a1 - a0), RGB MAD", 3),
           ("saturate, RGB", 3))
OPS_FIT = (("t = g c + d, float4 MAD", 4), ("k n.v + b", 1), ("exp2", 1), ("min", 1),
           ("a0 = t.x m + t.z", 1), ("s m + t.w", 1), ("a1 = min(., 1)", 1), ("a1 - a0", 1),
           ("a0 + rf0 (a1 - a0), RGB MAD", 3), ("saturate, RGB", 3))


def grid():
    """The (201, 201) arrays g, n.v of the fit and of the error tables (indexing "ij")."""
    return np.meshgrid(GLOSS, N_DOT_V, indexing="ij")


def truth_parts(visibility: str = "reference"):
    """Ground-truth parts (a0, a1) on :func:`grid`, (2, 201, 201) float64."""
    g, nv = grid()
    return np.array(env_brdf.ground_truth(g, nv, visibility))


def split(params):
    """Coefficient tuples (FIT_A0, FIT_A1) from the flat vector
    (cx, dx, cy, dy, cz, dz, cw, dw, k, b, s)."""
    cx, dx, cy, dy, cz, dz, cw, dw, k, b, s = (float(p) for p in params)
    return (cx, dx, cy, dy, cz, dz, k, b), (cw, dw, s)


def shader(a0, a1, rf0):
    """The final step both models share: saturate(a0 + rf0 (a1 - a0))."""
    return np.clip(a0 + rf0 * (a1 - a0), 0.0, 1.0)


def weights(nv):
    """The weights of each of ``WEIGHTINGS`` on the grid's n.v, (3, ...) float64."""
    return np.array([np.ones_like(nv), 2.0 * nv, (nv >= 0.05).astype(np.float64)])


def errors(values, truth, weight=None):
    """(max, mean, rms) absolute error of values (R, G, N) per rf0 of RF0 against truth, over
    the grid points of non-zero ``weight`` (the mean and RMS weighted by it)."""
    w = np.ones_like(truth[0]) if weight is None else weight
    sel = w > 0
    out = []
    for v, rf0 in zip(values, RF0, strict=True):
        d = np.abs(np.asarray(v, np.float64) - (truth[0] + rf0 * (truth[1] - truth[0])))
        out.append((float(d[sel].max()), float((d * w).sum() / w.sum()),
                    float(np.sqrt((d * d * w).sum() / w.sum()))))
    return out


def model_values(name: str, g, nv):
    """E at each rf0 of RF0 for one model: "bo1", "bo2", "fit" or "table"."""
    if name == "bo1":
        return [env_brdf.bo1_environment_fresnel(g, nv, r) for r in RF0]
    if name == "bo2":
        return [env_brdf.environment_brdf_bo2(g, nv, r) for r in RF0]
    if name == "fit":
        a0, a1 = env_brdf.fit_parts(g, nv)
        return [shader(a0, a1, r) for r in RF0]
    if name == "table":
        return [env_brdf.environment_brdf(g, nv, r, "table") for r in RF0]
    raise ValueError(name)


class Objective:
    """The ratios of the module docstring, and their soft maximum, for flat parameter vectors."""

    def __init__(self, truth):
        self.truth = truth
        self.g, self.nv = grid()
        self.w = weights(self.nv)
        self.target = [truth[0] + r * (truth[1] - truth[0]) for r in RF0]
        bo2 = model_values("bo2", self.g, self.nv)
        self.bo2 = [errors(bo2, truth, w) for w in self.w]

    def ratios(self, params) -> np.ndarray:
        """(3 weightings, 3 rf0, 2) max and mean |error| divided by BO2's."""
        a0, a1 = env_brdf.fit_parts(self.g, self.nv, *split(params))
        values = [shader(a0, a1, r) for r in RF0]
        return np.array([[(m / b[0], a / b[1]) for (m, a, _), b in
                          zip(errors(values, self.truth, w), bo2, strict=True)]
                         for w, bo2 in zip(self.w, self.bo2, strict=True)])

    def soft_max(self, params, sharpness) -> float:
        r = self.ratios(params).ravel()
        top = r.max()
        return float(top + np.log(np.exp(sharpness * (r - top)).sum()) / sharpness)


def nelder_mead(f, x0, step, iterations=3000, tol=1e-12):
    """Minimise f from x0 (standard Nelder-Mead, initial simplex x0 + step_i e_i)."""
    pts = np.vstack([x0, x0 + np.diag(step)])
    vals = np.array([f(p) for p in pts])
    for _ in range(iterations):
        order = np.argsort(vals, kind="stable")
        pts, vals = pts[order], vals[order]
        if vals[-1] - vals[0] <= tol * abs(vals[0]) and np.ptp(pts, 0).max() < 1e-9:
            break
        centre = pts[:-1].mean(0)
        xr = 2.0 * centre - pts[-1]
        fr = f(xr)
        if fr < vals[0]:
            xe = 3.0 * centre - 2.0 * pts[-1]
            fe = f(xe)
            pts[-1], vals[-1] = (xe, fe) if fe < fr else (xr, fr)
        elif fr < vals[-2]:
            pts[-1], vals[-1] = xr, fr
        else:
            xc = centre + 0.5 * ((xr if fr < vals[-1] else pts[-1]) - centre)
            fc = f(xc)
            if fc < min(fr, vals[-1]):
                pts[-1], vals[-1] = xc, fc
            else:  # shrink towards the best point
                pts[1:] = pts[0] + 0.5 * (pts[1:] - pts[0])
                vals[1:] = [f(p) for p in pts[1:]]
    best = int(np.argmin(vals))
    return pts[best], float(vals[best])


def fit(truth, verbose=True):
    """The fitted flat vector (cx, dx, cy, dy, cz, dz, cw, dw, k, b, s), unrounded, and its
    largest ratio to BO2's errors."""
    objective = Objective(truth)
    x = np.array(START, np.float64)
    step = 0.1 * np.abs(x) + 0.02
    for sharpness in SHARPNESS:
        for _ in range(3):
            x, _ = nelder_mead(lambda p, k=sharpness: objective.soft_max(p, k), x, step,
                               iterations=4000)
            step = 0.5 * step
        if verbose:
            print(f"  sharpness {sharpness:g}: largest ratio to BO2 "
                  f"{objective.ratios(x).max():.4f}", flush=True)
    cap = float(objective.ratios(x).max())

    def metals(p):  # the metals' errors, the largest ratio held (the dielectrics bind it)
        r = objective.ratios(p)
        return (1000.0 * max(float(r.max()) - cap, 0.0) + r[:, 2, 1].mean()
                + 0.3 * r[:, 2, 0].mean() + 0.1 * r[:, 1, 1].mean())

    step = 0.05 * np.abs(x) + 0.01
    for _ in range(4):
        x, _ = nelder_mead(metals, x, step, iterations=4000)
        step = 0.5 * step
    if verbose:
        r = objective.ratios(x)
        print(f"  metals: mean ratio {r[:, 2, 1].mean():.4f}, largest ratio {r.max():.4f}")
    return x, float(objective.ratios(x).max())


def op_count_lines():
    lines = []
    for name, ops in (("BO2 EnvironmentBRDF", OPS_BO2), ("our fit", OPS_FIT)):
        total = sum(c for _, c in ops)
        parts = sum(c for _, c in ops[:-3])
        lines.append(f"{name}: {total} operations ({parts} for the parts): "
                     + ", ".join(f"{o} [{c}]" for o, c in ops))
    return lines


def error_table(truth):
    """Markdown tables of max / mean / RMS errors of BO1, BO2, the fit and the table, one per
    weighting of ``WEIGHTINGS``."""
    g, nv = grid()
    names = {"bo1": "BO1 environment \"Fresnel\"", "bo2": "BO2 EnvironmentBRDF",
             "fit": "our fit", "table": "table (64 x 64, bilinear)"}
    values = {key: model_values(key, g, nv) for key in names}
    rows = []
    for title, w in zip(WEIGHTINGS, weights(nv), strict=True):
        rows += [f"{title}:", "",
                 "| model | " + " | ".join(f"rf0 = {r:g}: max / mean / RMS" for r in RF0)
                 + " |", "|---|" + "---|" * len(RF0)]
        for key, label in names.items():
            cells = [f"{m:.4f} / {a:.5f} / {s:.5f}" for m, a, s in
                     errors(values[key], truth, w)]
            rows.append(f"| {label} | " + " | ".join(cells) + " |")
        rows.append("")
    return rows


def visibility_table(truth_reference, truth_bo2):
    """Markdown table: BO2's EnvironmentBRDF against the ground truth of each visibility."""
    g, nv = grid()
    values = model_values("bo2", g, nv)
    rows = ["| BO2 EnvironmentBRDF against | "
            + " | ".join(f"rf0 = {r:g}: max / mean / RMS" for r in RF0) + " |",
            "|---|" + "---|" * len(RF0)]
    for label, truth in (("ground truth, Schlick-Smith visibility (reference)", truth_reference),
                         ("ground truth, BO2 visibility", truth_bo2)):
        cells = [f"{m:.4f} / {a:.5f} / {s:.5f}" for m, a, s in errors(values, truth)]
        rows.append(f"| {label} | " + " | ".join(cells) + " |")
    return rows


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    mode = parser.add_mutually_exclusive_group()
    mode.add_argument("--check", action="store_true",
                      help="refit and compare with the committed coefficients")
    mode.add_argument("--no-fit", action="store_true",
                      help="print the tables of the committed coefficients only")
    args = parser.parse_args(argv)

    print("ground truth on the 201 x 201 grid ...", flush=True)
    truth = truth_parts()
    if not args.no_fit:
        print("fitting ...", flush=True)
        x, worst = fit(truth)
        a0c, a1c = split(np.round(x, DECIMALS))
        rounded = Objective(truth).ratios(np.round(x, DECIMALS)).max()
        print(f"largest ratio to BO2's errors: {worst:.4f} (unrounded), {rounded:.4f} (rounded)")
        print(f"FIT_A0 = ({', '.join(f'{c:.{DECIMALS}f}' for c in a0c)})"
              "  # cx, dx, cy, dy, cz, dz, k, b")
        print(f"FIT_A1 = ({', '.join(f'{c:.{DECIMALS}f}' for c in a1c)})  # cw, dw, s")
        if args.check:
            refit = np.concatenate(split(x))  # unrounded
            committed = np.array(env_brdf.FIT_A0 + env_brdf.FIT_A1, np.float64)
            diff = float(np.abs(committed - refit).max())
            print(f"largest difference from the committed coefficients: {diff:.3g} "
                  f"(allowed: {CHECK_TOLERANCE:g})")
            return 0 if diff <= CHECK_TOLERANCE else 1
    print()
    for line in op_count_lines():
        print(line)
    ratios = Objective(truth).ratios(np.concatenate([env_brdf.FIT_A0[:6], env_brdf.FIT_A1[:2],
                                                     env_brdf.FIT_A0[6:], env_brdf.FIT_A1[2:]]))
    print(f"committed coefficients: largest ratio to BO2's max or mean |error| over the three "
          f"weightings and three rf0: {ratios.max():.4f}")
    print()
    print("Errors of E against the ground truth (Schlick-Smith visibility), 201 x 201 grid:")
    print("\n".join(error_table(truth)))
    print()
    print("BO2's EnvironmentBRDF against the ground truth of each visibility:")
    print("\n".join(visibility_table(truth, truth_parts("bo2"))))
    return 0


if __name__ == "__main__":
    sys.exit(main())
