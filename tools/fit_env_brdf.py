"""Fit our approximation of the environment BRDF (``env_brdf.fit_parts``) to the ground truth.

Usage: python tools/fit_env_brdf.py [--check | --no-fit]

The model (docs/env_brdf.md): one capped exponential m serves both parts,

    y  = y1 g + y0,   q = q1 g + q0
    m  = min(y, 2^(k n.v + b))
    a0 = y m
    a1 = min(s m + q, 1)
    E  = saturate(a0 + rf0 (a1 - a0))

Cost, counted per scalar operation: MAD/FMA 1, add/sub/mul 1, min/max 1, exp2/log2/rcp/sqrt 1,
saturate 1; a vector operation counts once per component. Black Ops II's ``EnvironmentBRDF``
(slide "Final approximation"): t = g c + d (4 MAD), -9.28 n.v (1), exp2 (1), min (1),
a0 = t.x min + t.z (1), a1 - a0 (1), a0 + rf0 (a1 - a0) (3 MAD for RGB), saturate (3) = 15.
Both models share the last 7 (the RGB interpolation and saturate); the parts get the other 8:
ours take y and q (2 MAD), k n.v + b (1 MAD), exp2 (1), min (1), a0 (1 mul), s m + q (1 MAD)
and min(., 1) (1) = 8, with one exp2. With the fitted coefficients 0 <= a0 and 0 <= a1 <= 1
everywhere, so the saturate never clamps.

Fit: the ground truth ``env_brdf.ground_truth`` (Schlick-Smith visibility) on the 201 x 201
grid g = 0, 0.005, ..., 1 by n.v = linspace(1e-4, 1, 201), about half a minute. The error of
E is taken at rf0 = 0, 0.04 and 1, and the fit minimises

    J = sum over the three rf0 of  max|error| / BO2's max|error| + 2 mean|error| / BO2's mean

(every figure of the error table counted relative to BO2's on the same grid; the mean weighs
twice, since it is what a surface shows on average, while the maximum sits in a thin rim of
grazing views at high gloss, a peak of a0 that no monotone curve in n.v follows). The
minimiser is Nelder-Mead (written here, NumPy only): first on the root-mean-square error from
a fixed start, then on J, restarted from the best point and from perturbations of it drawn
with a fixed seed. The coefficients are rounded to 4 decimals.

Prints the coefficients (as the ``FIT_A0``, ``FIT_A1`` lines of ``addon/core/env_brdf.py``),
the operation counts and the error tables. ``--check`` refits and exits 1 unless every
unrounded coefficient lies within 1e-4 (the printed precision) of the committed one.
``--no-fit`` prints the tables of the committed coefficients only.
"""

from __future__ import annotations

import argparse
import sys

import numpy as np

from bo2_lighting.addon.core import env_brdf

GLOSS = np.linspace(0.0, 1.0, 201)
N_DOT_V = np.linspace(env_brdf.N_DOT_V_MIN, 1.0, 201)
RF0 = (0.0, 0.04, 1.0)
MEAN_WEIGHT = 2.0
DECIMALS = 4
START = (0.6, 0.03, 1.1, 0.4, -10.0, 1.0, -1.5)  # y1, y0, q1, q0, k, b, s
SEED = 2013

# (operation, count) of each model, counted as in the module docstring
OPS_BO2 = (("t = g c + d, float4 MAD", 4), ("-9.28 n.v", 1), ("exp2", 1), ("min", 1),
           ("a0 = t.x min + t.z", 1), ("a1 - a0", 1), ("a0 + rf0 (a1 - a0), RGB MAD", 3),
           ("saturate, RGB", 3))
OPS_FIT = (("(y, q) = g c + d, float2 MAD", 2), ("k n.v + b", 1), ("exp2", 1), ("min", 1),
           ("a0 = y m", 1), ("s m + q", 1), ("a1 = min(., 1)", 1), ("a1 - a0", 1),
           ("a0 + rf0 (a1 - a0), RGB MAD", 3), ("saturate, RGB", 3))


def grid():
    """The (201, 201) arrays g, n.v of the fit and of the error tables (indexing "ij")."""
    return np.meshgrid(GLOSS, N_DOT_V, indexing="ij")


def truth_parts(visibility: str = "reference"):
    """Ground-truth parts (a0, a1) on :func:`grid`, (2, 201, 201) float64."""
    g, nv = grid()
    return np.array(env_brdf.ground_truth(g, nv, visibility))


def split(params):
    """Coefficient tuples (FIT_A0, FIT_A1) from the flat vector (y1, y0, q1, q0, k, b, s)."""
    y1, y0, q1, q0, k, b, s = (float(p) for p in params)
    return (y1, y0, k, b), (q1, q0, s)


def shader(a0, a1, rf0):
    """The final step both models share: saturate(a0 + rf0 (a1 - a0))."""
    return np.clip(a0 + rf0 * (a1 - a0), 0.0, 1.0)


def errors(values, truth):
    """(max, mean, rms) absolute error of values (R, G, N) per rf0 of RF0 against truth."""
    out = []
    for v, rf0 in zip(values, RF0, strict=True):
        d = np.abs(np.asarray(v, np.float64) - (truth[0] + rf0 * (truth[1] - truth[0])))
        out.append((float(d.max()), float(d.mean()), float(np.sqrt((d * d).mean()))))
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
    """J of the module docstring (and the RMS start) for flat parameter vectors."""

    def __init__(self, truth):
        self.truth = truth
        self.g, self.nv = grid()
        self.target = [truth[0] + r * (truth[1] - truth[0]) for r in RF0]
        self.bo2 = errors(model_values("bo2", self.g, self.nv), truth)

    def _diffs(self, params):
        a0, a1 = env_brdf.fit_parts(self.g, self.nv, *split(params))
        return [np.abs(shader(a0, a1, r) - t) for r, t in zip(RF0, self.target, strict=True)]

    def rms(self, params):
        return sum(float(np.sqrt((d * d).mean())) for d in self._diffs(params))

    def __call__(self, params):
        total = 0.0
        for d, (bo2_max, bo2_mean, _) in zip(self._diffs(params), self.bo2, strict=True):
            total += float(d.max()) / bo2_max + MEAN_WEIGHT * float(d.mean()) / bo2_mean
        return total


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


def _restarted(f, x, rounds=3):
    val = f(x)
    for _ in range(rounds):
        x, val = nelder_mead(f, x, 0.1 * np.maximum(np.abs(x), 0.05))
    return x, val


def fit(truth, verbose=True):
    """The fitted flat vector (y1, y0, q1, q0, k, b, s), unrounded, and its J."""
    objective = Objective(truth)
    x, _ = _restarted(objective.rms, np.array(START, np.float64))
    x, val = _restarted(objective, x)
    if verbose:
        print(f"  from the root-mean-square fit: J = {val:.5f}")
    rng = np.random.default_rng(SEED)
    for trial in range(4):
        xs, vs = _restarted(objective, x * (1.0 + 0.2 * rng.standard_normal(x.size)))
        if verbose:
            print(f"  restart {trial + 1}: J = {vs:.5f}")
        if vs < val:
            x, val = xs, vs
    return x, val


def op_count_lines():
    lines = []
    for name, ops in (("BO2 EnvironmentBRDF", OPS_BO2), ("our fit", OPS_FIT)):
        total = sum(c for _, c in ops)
        parts = sum(c for _, c in ops[:-3])
        lines.append(f"{name}: {total} operations ({parts} for the parts): "
                     + ", ".join(f"{o} [{c}]" for o, c in ops))
    return lines


def error_table(truth):
    """Markdown table of max / mean / RMS errors of BO1, BO2, the fit and the table."""
    g, nv = grid()
    rows = ["| model | " + " | ".join(f"rf0 = {r:g}: max / mean / RMS" for r in RF0) + " |",
            "|---|" + "---|" * len(RF0)]
    names = {"bo1": "BO1 environment \"Fresnel\"", "bo2": "BO2 EnvironmentBRDF",
             "fit": "our fit", "table": "table (64 x 64, bilinear)"}
    for key, label in names.items():
        errs = errors(model_values(key, g, nv), truth)
        cells = [f"{m:.4f} / {a:.5f} / {s:.5f}" for m, a, s in errs]
        rows.append(f"| {label} | " + " | ".join(cells) + " |")
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
        x, val = fit(truth)
        a0c, a1c = split(np.round(x, DECIMALS))
        print(f"J = {val:.5f} (unrounded), {Objective(truth)(np.round(x, DECIMALS)):.5f} "
              "(rounded)")
        print(f"FIT_A0 = ({', '.join(f'{c:.{DECIMALS}f}' for c in a0c)})  # y1, y0, k, b")
        print(f"FIT_A1 = ({', '.join(f'{c:.{DECIMALS}f}' for c in a1c)})  # q1, q0, s")
        if args.check:
            refit = np.concatenate(split(x))  # unrounded
            committed = np.array(env_brdf.FIT_A0 + env_brdf.FIT_A1, np.float64)
            worst = float(np.abs(committed - refit).max())
            print(f"largest difference from the committed coefficients: {worst:.3g} "
                  f"(allowed: {10.0 ** -DECIMALS:g})")
            return 0 if worst <= 10.0 ** -DECIMALS else 1
    print()
    for line in op_count_lines():
        print(line)
    y1, y0, _, _ = env_brdf.FIT_A0
    q1, q0, s = env_brdf.FIT_A1
    # 0 < y <= 1 gives 0 < m <= y, so 0 < a0 = y m <= 1 and a1 >= q + min(s, 0) y (both
    # bounds linear in g, so checked at g = 0 and 1); a1 <= 1 by its min
    never = 0 < min(y0, y1 + y0) and max(y0, y1 + y0) <= 1 and min(q0 + min(s, 0.0) * y0,
                                         q1 + q0 + min(s, 0.0) * (y1 + y0)) >= 0
    print(f"committed coefficients: 0 <= a0 and 0 <= a1 <= 1 on the whole domain "
          f"(saturate never clamps): {never}")
    print()
    print("Errors of E against the ground truth (Schlick-Smith visibility), 201 x 201 grid:")
    print("\n".join(error_table(truth)))
    print()
    print("BO2's EnvironmentBRDF against the ground truth of each visibility:")
    print("\n".join(visibility_table(truth, truth_parts("bo2"))))
    return 0


if __name__ == "__main__":
    sys.exit(main())
