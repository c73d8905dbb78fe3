"""``bo2 env-brdf``: the environment BRDF of one (gloss, n.v, rf0), pure NumPy."""

from __future__ import annotations

import json

import numpy as np

from ..core.formulas import env_brdf
from . import CommandError


def run(args) -> int:
    """Print the environment BRDF of one (gloss, n.v, rf0): one value per rf0 channel."""
    if len(args.rf0) not in (1, 3):
        raise CommandError(f"--rf0 takes one value or three (R G B), got {len(args.rf0)}")
    values = env_brdf.environment_brdf(np.float64(args.gloss), np.float64(args.nov),
                                       np.array(args.rf0, np.float64), args.model)
    values = [float(x) for x in np.atleast_1d(values)]
    if args.json:
        def num(x):
            return x if np.isfinite(x) else None  # NaN and infinities are not JSON: null

        print(json.dumps({"model": args.model, "gloss": num(args.gloss), "nov": num(args.nov),
                          "rf0": [num(x) for x in args.rf0], "value": [num(x) for x in values]},
                         allow_nan=False))
    else:
        print(" ".join(f"{x:.6f}" for x in values))
    return 0
