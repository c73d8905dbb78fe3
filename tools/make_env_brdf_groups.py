"""Write the node group specs of the environment BRDF models into ``node_groups/``.

Usage: python tools/make_env_brdf_groups.py [--check]

One shader node group per analytic model of ``addon/core/formulas/env_brdf.py``, built from Math and
Vector Math nodes only, so that Cycles and EEVEE evaluate the same formula as the engine:

- "BO2 Environment BRDF":        Black Ops II's EnvironmentBRDF (slide "Final approximation")
- "BO2 Environment BRDF (BO1)":  Black Ops' environment "Fresnel"
- "BO2 Environment BRDF (Fit)":  our fit (docs/env_brdf.md), coefficients from env_brdf.py

Inputs: Gloss, Specular Color (rf0), NoV and Normal; output: Color. A negative NoV (the
default) means "from the geometry": n.v of the Normal input (the shading normal when left at
zero) and the Geometry node's Incoming direction. The specs are data; this script writes them
so that each formula is spelled once, here, next to its Python twin. ``--check`` compares with
the committed files instead of writing.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

from bo2_lighting.addon.core.formulas import env_brdf

OUT = Path(__file__).resolve().parents[1] / "node_groups"


class Graph:
    """Collects nodes and links of one group spec, laid out in columns."""

    def __init__(self):
        self.nodes: list[dict] = []
        self.links: list[dict] = []
        self._column: dict[int, int] = {}

    def node(self, name, bl_idname, column, label=None, properties=None, inputs=None):
        row = self._column.get(column, 0)
        self._column[column] = row + 1
        spec = {"name": name, "bl_idname": bl_idname, "location": [column * 200, -row * 160]}
        if label:
            spec["label"] = label
        if properties:
            spec["properties"] = properties
        if inputs:
            spec["inputs"] = inputs
        self.nodes.append(spec)
        return name

    def link(self, src, out, dst, inp):
        self.links.append({"from": [src, out], "to": [dst, inp]})

    def math(self, name, op, column, a, b=None, c=None, label=None, clamp=False):
        """A Math node; each operand is a number or (node, output socket)."""
        inputs = {}
        links = []
        for key, value in zip(("Value", "Value_001", "Value_002"), (a, b, c), strict=True):
            if isinstance(value, (int, float)):
                inputs[key] = float(value)
            elif value is not None:
                links.append((value, key))
        props = {"operation": op}
        if clamp:
            props["use_clamp"] = True
        self.node(name, "ShaderNodeMath", column, label, props, inputs)
        for (src, out), key in links:
            self.link(src, out, name, key)
        return (name, "Value")


def _interface(description: str) -> list[dict]:
    return [
        {"name": "Gloss", "in_out": "INPUT", "socket_type": "NodeSocketFloat",
         "subtype": "FACTOR", "default": 0.5, "min": 0.0, "max": 1.0,
         "description": "Gloss g in [0, 1]; specular power 8192^g"},
        {"name": "Specular Color", "in_out": "INPUT", "socket_type": "NodeSocketColor",
         "default": [0.04, 0.04, 0.04, 1.0],
         "description": "rf0, the specular colour at normal incidence (linear)"},
        {"name": "NoV", "in_out": "INPUT", "socket_type": "NodeSocketFloat",
         "default": -1.0, "min": -1.0, "max": 1.0,
         "description": "Cosine between the normal and the view; negative: from the Normal "
                        "input and the incoming view direction"},
        {"name": "Normal", "in_out": "INPUT", "socket_type": "NodeSocketVector",
         "subtype": "NONE", "default": [0.0, 0.0, 0.0], "hide_value": True,
         "description": "Normal for NoV when NoV is negative; unconnected: the shading normal"},
        {"name": "Color", "in_out": "OUTPUT", "socket_type": "NodeSocketColor",
         "description": description},
    ]


def _inputs(g: Graph):
    """Group input, clamped gloss and n.v: returns (gloss, nov) operand tuples."""
    g.node("Group Input", "NodeGroupInput", 0)
    g.node("Geometry", "ShaderNodeNewGeometry", 0)
    # n = Normal input, or the shading normal when the input is zero
    g.node("Normal Length", "ShaderNodeVectorMath", 1, "|Normal|",
           {"operation": "LENGTH"})
    g.link("Group Input", "Normal", "Normal Length", "Vector")
    has_normal = g.math("Has Normal", "GREATER_THAN", 2, ("Normal Length", "Value"), 0.0,
                        label="Normal given?")
    g.node("Pick Normal", "ShaderNodeMix", 3, "Normal input or shading normal",
           {"data_type": "VECTOR"})
    g.link(*has_normal, "Pick Normal", "Factor_Float")
    g.link("Geometry", "Normal", "Pick Normal", "A_Vector")
    g.link("Group Input", "Normal", "Pick Normal", "B_Vector")
    g.node("Unit Normal", "ShaderNodeVectorMath", 4, "normalize", {"operation": "NORMALIZE"})
    g.link("Pick Normal", "Result_Vector", "Unit Normal", "Vector")
    g.node("Geometry NoV", "ShaderNodeVectorMath", 5, "n . incoming",
           {"operation": "DOT_PRODUCT"})
    g.link("Unit Normal", "Vector", "Geometry NoV", "Vector")
    g.link("Geometry", "Incoming", "Geometry NoV", "Vector_001")
    # NoV input when it is >= 0, else the geometry's
    use_input = g.math("NoV Given", "GREATER_THAN", 1, ("Group Input", "NoV"), -1e-6,
                       label="NoV given?")
    diff = g.math("NoV Difference", "SUBTRACT", 6, ("Group Input", "NoV"),
                  ("Geometry NoV", "Value"))
    nov = g.math("Pick NoV", "MULTIPLY_ADD", 7, use_input, diff, ("Geometry NoV", "Value"))
    nov = g.math("Clamp NoV", "MAXIMUM", 8, nov, env_brdf.N_DOT_V_MIN, label="n.v >= 1e-4")
    nov = g.math("Clamp NoV Top", "MINIMUM", 9, nov, 1.0, label="n.v <= 1")
    gloss = g.math("Clamp Gloss", "MULTIPLY", 1, ("Group Input", "Gloss"), 1.0,
                   label="g = clamp(Gloss)", clamp=True)
    return gloss, nov


def _finish(g: Graph, a0, a1, column: int) -> None:
    """Color = saturate(a0 + rf0 (a1 - a0)), per channel."""
    span = g.math("a1 - a0", "SUBTRACT", column, a1, a0)
    g.node("Interpolate", "ShaderNodeVectorMath", column + 1, "a0 + rf0 (a1 - a0)",
           {"operation": "MULTIPLY_ADD"})
    g.link("Group Input", "Specular Color", "Interpolate", "Vector")
    g.link(*span, "Interpolate", "Vector_001")
    g.link(*a0, "Interpolate", "Vector_002")
    g.node("Saturate Low", "ShaderNodeVectorMath", column + 2, "max(0)",
           {"operation": "MAXIMUM"}, {"Vector_001": [0.0, 0.0, 0.0]})
    g.link("Interpolate", "Vector", "Saturate Low", "Vector")
    g.node("Saturate High", "ShaderNodeVectorMath", column + 3, "min(1)",
           {"operation": "MINIMUM"}, {"Vector_001": [1.0, 1.0, 1.0]})
    g.link("Saturate Low", "Vector", "Saturate High", "Vector")
    g.node("Group Output", "NodeGroupOutput", column + 4)
    g.link("Saturate High", "Vector", "Group Output", "Color")


def bo2_group() -> dict:
    """EnvironmentBRDF of slide "Final approximation" (env_brdf.environment_brdf_bo2)."""
    g = Graph()
    gloss, nov = _inputs(g)
    tx = g.math("t.x", "MULTIPLY", 10, gloss, 1.0 / 0.96, label="t.x = g / 0.96")
    ty = g.math("t.y", "MULTIPLY", 10, gloss, 0.475, label="t.y = 0.475 g")
    tz = g.math("t.z", "MULTIPLY_ADD", 10, gloss, (0.0275 - 0.25 * 0.04) / 0.96,
                (0.015 - 0.75 * 0.04) / 0.96, label="t.z")
    tw = g.math("t.w", "MULTIPLY_ADD", 10, gloss, 0.25, 0.75, label="a1 = t.w = 0.25 g + 0.75")
    x = g.math("-9.28 NoV", "MULTIPLY", 11, nov, -9.28)
    e = g.math("exp2", "POWER", 12, 2.0, x, label="2^(-9.28 NoV)")
    m = g.math("min", "MINIMUM", 13, ty, e, label="min(t.y, 2^(-9.28 NoV))")
    a0 = g.math("a0", "MULTIPLY_ADD", 14, tx, m, tz, label="a0 = t.x min(..) + t.z")
    _finish(g, a0, tw, 15)
    return _spec("BO2 Environment BRDF",
                 "Black Ops II environment BRDF, EnvironmentBRDF(g, NoV, rf0) of slide "
                 "'Final approximation' (Lazarov 2013); env_brdf.environment_brdf_bo2", g)


def bo1_group() -> dict:
    """rf0 + (1 - rf0)(1 - n.v)^5 / (4 - 3g) (env_brdf.bo1_environment_fresnel)."""
    g = Graph()
    gloss, nov = _inputs(g)
    t = g.math("1 - NoV", "SUBTRACT", 10, 1.0, nov)
    t5 = g.math("(1 - NoV)^5", "POWER", 11, t, 5.0)
    denom = g.math("4 - 3g", "MULTIPLY_ADD", 10, gloss, -3.0, 4.0)
    a0 = g.math("a0", "DIVIDE", 12, t5, denom, label="a0 = (1 - NoV)^5 / (4 - 3g)")
    a1 = g.math("a1", "ADD", 12, 1.0, 0.0, label="a1 = 1")
    _finish(g, a0, a1, 15)
    return _spec("BO2 Environment BRDF (BO1)",
                 "Black Ops environment 'Fresnel' rf0 + (1 - rf0)(1 - n.v)^5 / (4 - 3g), slide "
                 "'Black Ops: environment map Fresnel' (Lazarov 2013); "
                 "env_brdf.bo1_environment_fresnel", g)


def fit_group() -> dict:
    """Our fit (env_brdf.fit_parts) with the coefficients of env_brdf.FIT_A0 and FIT_A1."""
    cx, dx, cy, dy, cz, dz, k = env_brdf.FIT_A0
    cw, dw, s = env_brdf.FIT_A1
    g = Graph()
    gloss, nov = _inputs(g)
    tx = g.math("t.x", "MULTIPLY_ADD", 10, gloss, cx, dx, label="t.x = cx g + dx")
    ty = g.math("t.y", "MULTIPLY_ADD", 10, gloss, cy, dy, label="t.y = cy g + dy")
    tz = g.math("t.z", "MULTIPLY_ADD", 10, gloss, cz, dz, label="t.z = cz g + dz")
    tw = g.math("t.w", "MULTIPLY_ADD", 10, gloss, cw, dw, label="t.w = cw g + dw")
    x = g.math("k NoV", "MULTIPLY", 11, nov, k)
    e = g.math("exp2", "POWER", 12, 2.0, x, label="2^(k NoV)")
    m = g.math("m", "MINIMUM", 13, ty, e, label="m = min(t.y, 2^(k NoV))")
    a0 = g.math("a0", "MULTIPLY_ADD", 14, tx, m, tz, label="a0 = t.x m + t.z")
    a1 = g.math("s m + t.w", "MULTIPLY_ADD", 14, m, s, tw)
    a1 = g.math("a1", "MINIMUM", 14, a1, 1.0, label="a1 = min(s m + t.w, 1)")
    _finish(g, a0, a1, 15)
    return _spec("BO2 Environment BRDF (Fit)",
                 "Our fit of the environment BRDF: BO2's curve with fitted coefficients and a "
                 "metal part on the same exponential, two operations more than BO2's, lower "
                 "max, mean and max relative error than BO2's for n.v >= 0.05 "
                 "(docs/env_brdf.md); env_brdf.fit_parts", g)


def _spec(name: str, description: str, g: Graph) -> dict:
    return {"name": name, "description": description, "interface": _interface(description),
            "nodes": g.nodes, "links": g.links}


GROUPS = {"bo2_env_brdf.json": bo2_group, "bo2_env_brdf_bo1.json": bo1_group,
          "bo2_env_brdf_fit.json": fit_group}


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--check", action="store_true",
                        help="compare with the committed specs instead of writing them")
    args = parser.parse_args()
    stale = []
    for file, build in GROUPS.items():
        text = json.dumps(build(), indent=2) + "\n"
        path = OUT / file
        if args.check:
            if not path.exists() or path.read_text(encoding="utf-8") != text:
                stale.append(file)
        else:
            path.write_text(text, encoding="utf-8")
            print(f"wrote node_groups/{file}")
    if stale:
        print(f"out of date: {', '.join(stale)}; run tools/make_env_brdf_groups.py")
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
