"""Write the environment BRDF table shipped with the add-on (``addon/core/env_brdf_table.npz``).

Usage: python tools/make_env_brdf_table.py [--check]

The ground truth of ``core.formulas.env_brdf.ground_truth`` (deterministic quadrature) on 64 gloss
values 0, 1/63, ..., 1 and 64 values of n.v = (j/63)^2 (the first clamped to 1e-4), squared
so that the grazing angles, where the parts change fastest, get more samples: the bilinear
look-up stays within 1e-3 of the quadrature everywhere (the test checks it). Both parts
(a0, a1) for the Schlick-Smith visibility ("reference") and for the BO2 optimized one ("bo2").
``--check`` recomputes the table and compares it with the committed file instead of writing.
"""

from __future__ import annotations

import argparse
import sys

import numpy as np

from bo2_lighting.addon.core.formulas import env_brdf

SIZE = 64


def build() -> dict[str, np.ndarray]:
    """The table's arrays: gloss (64,), n_dot_v (64,), reference and bo2 (2, 64, 64) float32."""
    gloss = np.linspace(0.0, 1.0, SIZE)
    n_dot_v = np.maximum(np.linspace(0.0, 1.0, SIZE) ** 2, env_brdf.N_DOT_V_MIN)
    g, nv = np.meshgrid(gloss, n_dot_v, indexing="ij")
    out = {"gloss": gloss.astype(np.float32), "n_dot_v": n_dot_v.astype(np.float32)}
    for visibility in ("reference", "bo2"):
        out[visibility] = np.array(env_brdf.ground_truth(g, nv, visibility), np.float32)
    return out


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--check", action="store_true",
                        help="compare with the committed table instead of writing it")
    args = parser.parse_args()
    table = build()
    if args.check:
        with np.load(env_brdf.TABLE_PATH) as old:
            worst = max(float(np.abs(old[k] - table[k]).max()) for k in table)
        print(f"largest difference from the committed table: {worst:.3g}")
        return 0 if worst < 1e-6 else 1
    np.savez_compressed(env_brdf.TABLE_PATH, **table)
    print(f"wrote {env_brdf.TABLE_PATH.name}: {SIZE} x {SIZE}, parts a0 and a1, "
          f"visibilities reference and bo2")
    return 0


if __name__ == "__main__":
    sys.exit(main())
