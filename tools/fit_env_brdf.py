"""Fit our approximation of the environment BRDF (``env_brdf.fit_parts``) to the ground truth.

Usage: python tools/fit_env_brdf.py [--check | --no-fit]

The model (docs/env_brdf.md) is BO2's own curve (slide "Final approximation") with every
coefficient free, and a metal part that follows the same capped exponential:

    t  = c g + d                      (float4: t.x, t.y, t.z, t.w)
    m  = min(t.y, 2^(k n.v))
    a0 = t.x m + t.z
    a1 = min(s m + t.w, 1)
    E  = saturate(a0 + rf0 (a1 - a0))

(An offset b in the exponent, 2^(k n.v + b), would add nothing: scaling t.x and s by 2^b and
t.y by 2^-b gives the same function, so the fit would not be unique.)

Cost, counted per scalar operation: MAD/FMA 1, add/sub/mul 1, min/max 1, exp2/log2/rcp/sqrt 1,
saturate 1; a vector operation counts once per component. Black Ops II's ``EnvironmentBRDF``
(slide "Final approximation"): t = g c + d (4 MAD: the slide's ``t *= g; t += c``), -9.28 n.v
(1), exp2 (1), min (1), a0 = t.x min + t.z (1), a1 - a0 (1), a0 + rf0 (a1 - a0) (3 MAD for
RGB), saturate (3) = 15. Ours: the same 15 plus s m + t.w (1 MAD) and min(., 1) (1) = 17, two
more than BO2, one exp2 as BO2.

Criteria: over the grid of 64 gloss values g = 0 ... 1 by 64 values n.v = 0.05 ... 1 (both
evenly spaced) of the ground truth ``env_brdf.ground_truth`` (Schlick-Smith visibility), the
error of E at rf0 = 0, 0.04 and 1 measured three ways: the maximum and the mean absolute error,
and the maximum relative error |E - truth| / truth where the truth is above 0.01. Each of the
9 figures is divided by BO2's on the same grid, and the fit minimises the largest of these
ratios: a minimax (L-infinity) objective, smoothed as a soft maximum (log-sum-exp) made
sharper in five rounds. The minimiser is Nelder-Mead (written here, NumPy only), restarted at
each round from the best point with smaller steps; the whole is run from BO2's own coefficients
(every ratio 1) and from seven random perturbations of them (fixed seed), and the best kept. A
last round lowers the mean of the 9 ratios with the largest one held. The coefficients are
rounded to 4 decimals.

Prints the coefficients (as the ``FIT_A0``, ``FIT_A1`` lines of
``addon/core/formulas/env_brdf.py``), the operation counts and the error tables. ``--check`` refits
and exits 1 unless every unrounded coefficient lies within 1e-3 of the committed one. ``--no-fit``
prints the tables of the committed coefficients only. About two minutes for the fit and one for the
tables.
"""

from __future__ import annotations

import argparse
import sys
from functools import lru_cache

import numpy as np

from bo2_lighting.addon.core.formulas import env_brdf

# The grid of the error tables of docs/env_brdf.md and of its figures (the whole domain).
GLOSS = np.linspace(0.0, 1.0, 201)
N_DOT_V = np.linspace(env_brdf.N_DOT_V_MIN, 1.0, 201)
# The grid of the criteria and of the fit.
FIT_GLOSS = np.linspace(0.0, 1.0, 64)
FIT_N_DOT_V = np.linspace(0.05, 1.0, 64)
RELATIVE_FLOOR = 0.01  # the relative error counts where the truth is above this
RF0 = (0.0, 0.04, 1.0)
CRITERIA = ("max", "mean", "max rel")
WEIGHTINGS = ("uniform", "screen (2 n.v)", "n.v >= 0.05")
DECIMALS = 4
CHECK_TOLERANCE = 1e-3
SHARPNESS = (10.0, 30.0, 100.0, 300.0, 1000.0)  # the soft maximum's rounds
RESTARTS = 8  # BO2's coefficients, then seven random perturbations of them
SEED = 2013
# BO2's EnvironmentBRDF in this model's terms, the flat vector FIT_A0 + FIT_A1:
# (cx, dx, cy, dy, cz, dz, k, cw, dw, s)
START = (1 / 0.96, 0.0, 0.475, 0.0, (0.0275 - 0.25 * 0.04) / 0.96,
         (0.015 - 0.75 * 0.04) / 0.96, -9.28, 0.25, 0.75, 0.0)

# (operation, count) of each model, counted as in the module docstring
OPS_BO2 = (("t = g c + d, float4 MAD", 4), ("-9.28 n.v", 1), ("exp2", 1), ("min", 1),
           ("a0 = t.x min + t.z", 1), ("a1 - a0", 1), ("a0 + rf0 (a1 - a0), RGB MAD", 3),
           ("saturate, RGB", 3))
OPS_FIT = (("t = g c + d, float4 MAD", 4), ("k n.v", 1), ("exp2", 1), ("min", 1),
           ("a0 = t.x m + t.z", 1), ("s m + t.w", 1), ("a1 = min(., 1)", 1), ("a1 - a0", 1),
           ("a0 + rf0 (a1 - a0), RGB MAD", 3), ("saturate, RGB", 3))


def grid():
    """The (201, 201) arrays g, n.v of the error tables and figures (indexing "ij")."""
    return np.meshgrid(GLOSS, N_DOT_V, indexing="ij")


def fit_grid():
    """The (64, 64) arrays g, n.v of the criteria and of the fit (indexing "ij")."""
    return np.meshgrid(FIT_GLOSS, FIT_N_DOT_V, indexing="ij")


def truth_parts(visibility: str = "reference"):
    """Ground-truth parts (a0, a1) on :func:`grid`, (2, 201, 201) float64."""
    g, nv = grid()
    return np.array(env_brdf.ground_truth(g, nv, visibility))


@lru_cache(maxsize=1)
def fit_truth():
    """Ground-truth parts (a0, a1) on :func:`fit_grid`, (2, 64, 64) float64 (a few seconds)."""
    g, nv = fit_grid()
    return np.array(env_brdf.ground_truth(g, nv))


def split(params):
    """Coefficient tuples (FIT_A0, FIT_A1) from the flat vector
    (cx, dx, cy, dy, cz, dz, k, cw, dw, s)."""
    p = tuple(float(c) for c in params)
    return p[:7], p[7:]


def shader(a0, a1, rf0):
    """The final step both models share: saturate(a0 + rf0 (a1 - a0))."""
    return np.clip(a0 + rf0 * (a1 - a0), 0.0, 1.0)


def weights(nv):
    """The weights of each of ``WEIGHTINGS`` on the grid's n.v, (3, ...) float64."""
    return np.array([np.ones_like(nv), 2.0 * nv, (nv >= 0.05).astype(np.float64)])


def errors(values, truth, weight=None):
    """(max, mean, max rel) error of values (R, G, N) per rf0 of RF0 against truth (2, G, N),
    over the grid points of non-zero ``weight`` (the mean weighted by it): the absolute error's
    maximum and mean, and the largest |error| / truth where the truth is above
    ``RELATIVE_FLOOR``."""
    w = np.ones_like(truth[0]) if weight is None else weight
    sel = w > 0
    out = []
    for v, rf0 in zip(values, RF0, strict=True):
        target = truth[0] + rf0 * (truth[1] - truth[0])
        d = np.abs(np.asarray(v, np.float64) - target)
        rel = sel & (target > RELATIVE_FLOOR)
        out.append((float(d[sel].max()), float((d * w).sum() / w.sum()),
                    float((d[rel] / target[rel]).max())))
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
    """The 9 ratios of the module docstring, and their soft maximum, for flat vectors."""

    def __init__(self, truth):
        self.truth = truth
        self.g, self.nv = fit_grid()
        self.bo2 = np.array(errors(model_values("bo2", self.g, self.nv), truth))

    def ratios(self, params) -> np.ndarray:
        """(3 rf0, 3 criteria) max, mean and max relative error divided by BO2's."""
        with np.errstate(all="ignore"):
            a0, a1 = env_brdf.fit_parts(self.g, self.nv, *split(params))
            r = np.array(errors([shader(a0, a1, rf0) for rf0 in RF0], self.truth)) / self.bo2
        return r if np.isfinite(r).all() else np.full_like(r, 1e3)

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


def minimax(objective, x):
    """The soft maximum's rounds from x: the point reached."""
    step = 0.1 * np.abs(x) + 0.02
    for sharpness in SHARPNESS:
        for _ in range(2):
            x, _ = nelder_mead(lambda p, k=sharpness: objective.soft_max(p, k), x, step,
                               iterations=2000)
            step = 0.5 * step
    return x


def fit(truth, verbose=True):
    """The fitted flat vector (cx, dx, cy, dy, cz, dz, k, cw, dw, s), unrounded, and its
    largest ratio to BO2's figures."""
    objective = Objective(truth)
    rng = np.random.default_rng(SEED)
    start = np.array(START, np.float64)
    best, best_ratio = start, np.inf
    for i in range(RESTARTS):
        x0 = start if i == 0 else (start * (1.0 + 0.3 * rng.standard_normal(start.size))
                                   + 0.015 * rng.standard_normal(start.size))
        x = minimax(objective, x0)
        ratio = float(objective.ratios(x).max())
        if verbose:
            print(f"  start {i}: largest ratio to BO2 {ratio:.4f}", flush=True)
        if ratio < best_ratio:
            best, best_ratio = x, ratio

    def mean_ratio(p):  # the mean of the 9 ratios, the largest one held
        r = objective.ratios(p)
        return 1000.0 * max(float(r.max()) - best_ratio, 0.0) + float(r.mean())

    x = best
    step = 0.05 * np.abs(x) + 0.01
    for _ in range(4):
        x, _ = nelder_mead(mean_ratio, x, step, iterations=4000)
        step = 0.5 * step
    if verbose:
        r = objective.ratios(x)
        print(f"  last round: mean ratio {r.mean():.4f}, largest ratio {r.max():.4f}")
    return x, float(objective.ratios(x).max())


def op_count_lines():
    lines = []
    for name, ops in (("BO2 EnvironmentBRDF", OPS_BO2), ("our fit", OPS_FIT)):
        total = sum(c for _, c in ops)
        parts = sum(c for _, c in ops[:-3])
        lines.append(f"{name}: {total} operations ({parts} for the parts): "
                     + ", ".join(f"{o} [{c}]" for o, c in ops))
    return lines


NAMES = {"bo1": "BO1 environment \"Fresnel\"", "bo2": "BO2 EnvironmentBRDF",
         "fit": "our fit", "table": "table (64 x 64, bilinear)"}


def _header():
    return ["| model | " + " | ".join(f"rf0 = {r:g}: max / mean / max rel" for r in RF0)
            + " |", "|---|" + "---|" * len(RF0)]


def _cells(figures):
    return " | ".join(f"{m:.4f} / {a:.5f} / {r:.3f}" for m, a, r in figures)


def criteria_table(truth=None):
    """Markdown table of the criteria (max / mean / max relative error) of BO1, BO2, the fit
    and the table on :func:`fit_grid` (truth: its parts there, default :func:`fit_truth`)."""
    truth = fit_truth() if truth is None else truth
    g, nv = fit_grid()
    rows = _header()
    for key, label in NAMES.items():
        rows.append(f"| {label} | {_cells(errors(model_values(key, g, nv), truth))} |")
    return rows


def error_table(truth):
    """Markdown tables: the criteria on the fit's grid (:func:`criteria_table`), then max /
    mean / max relative errors of BO1, BO2, the fit and the table on :func:`grid` (truth: the
    parts there), one per weighting of ``WEIGHTINGS``."""
    g, nv = grid()
    values = {key: model_values(key, g, nv) for key in NAMES}
    rows = [f"criteria of the fit: {FIT_GLOSS.size} gloss x {FIT_N_DOT_V.size} n.v in "
            f"[{FIT_N_DOT_V[0]:g}, 1], relative error where the truth > {RELATIVE_FLOOR:g}:",
            ""] + criteria_table() + [""]
    for title, w in zip(WEIGHTINGS, weights(nv), strict=True):
        rows += [f"201 x 201, n.v in [1e-4, 1], {title}:", ""] + _header()
        for key, label in NAMES.items():
            rows.append(f"| {label} | {_cells(errors(values[key], truth, w))} |")
        rows.append("")
    return rows


def visibility_table(truth_reference, truth_bo2):
    """Markdown table: BO2's EnvironmentBRDF against the ground truth of each visibility."""
    g, nv = grid()
    values = model_values("bo2", g, nv)
    rows = ["| BO2 EnvironmentBRDF against | "
            + " | ".join(f"rf0 = {r:g}: max / mean / max rel" for r in RF0) + " |",
            "|---|" + "---|" * len(RF0)]
    for label, truth in (("ground truth, Schlick-Smith visibility (reference)", truth_reference),
                         ("ground truth, BO2 visibility", truth_bo2)):
        rows.append(f"| {label} | {_cells(errors(values, truth))} |")
    return rows


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    mode = parser.add_mutually_exclusive_group()
    mode.add_argument("--check", action="store_true",
                      help="refit and compare with the committed coefficients")
    mode.add_argument("--no-fit", action="store_true",
                      help="print the tables of the committed coefficients only")
    args = parser.parse_args(argv)

    print(f"ground truth on the {FIT_GLOSS.size} x {FIT_N_DOT_V.size} grid ...", flush=True)
    truth = fit_truth()
    objective = Objective(truth)
    if not args.no_fit:
        print("fitting ...", flush=True)
        x, worst = fit(truth)
        a0c, a1c = split(np.round(x, DECIMALS))
        rounded = objective.ratios(np.round(x, DECIMALS)).max()
        print(f"largest ratio to BO2's figures: {worst:.4f} (unrounded), {rounded:.4f} "
              "(rounded)")
        print(f"FIT_A0 = ({', '.join(f'{c:.{DECIMALS}f}' for c in a0c)})"
              "  # cx, dx, cy, dy, cz, dz, k")
        print(f"FIT_A1 = ({', '.join(f'{c:.{DECIMALS}f}' for c in a1c)})  # cw, dw, s")
        if args.check:
            committed = np.array(env_brdf.FIT_A0 + env_brdf.FIT_A1, np.float64)
            diff = float(np.abs(committed - x).max())  # x unrounded
            print(f"largest difference from the committed coefficients: {diff:.3g} "
                  f"(allowed: {CHECK_TOLERANCE:g})")
            return 0 if diff <= CHECK_TOLERANCE else 1
    print()
    for line in op_count_lines():
        print(line)
    ratios = objective.ratios(env_brdf.FIT_A0 + env_brdf.FIT_A1)
    print("committed coefficients: ratios to BO2's max / mean / max rel error (rows rf0 = "
          + ", ".join(f"{r:g}" for r in RF0) + "):")
    for r, row in zip(RF0, ratios, strict=True):
        print(f"  rf0 = {r:g}: " + " / ".join(f"{v:.3f}" for v in row))
    verdict = "beats" if ratios.max() < 1.0 else "does NOT beat"
    print(f"the fit {verdict} BO2 on all {ratios.size} figures (largest ratio "
          f"{ratios.max():.4f})")
    print()
    print("ground truth on the 201 x 201 grid ...", flush=True)
    full = truth_parts()
    print("Errors of E against the ground truth (Schlick-Smith visibility):")
    print("\n".join(error_table(full)))
    print()
    print("BO2's EnvironmentBRDF against the ground truth of each visibility:")
    print("\n".join(visibility_table(full, truth_parts("bo2"))))
    return 0


if __name__ == "__main__":
    sys.exit(main())
