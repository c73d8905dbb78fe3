"""Material programs: a material's node tree as a list of operations (``nodes.NODES``), each
reading earlier results ("registers") by index, built by ``ProgramBuilder``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .nodes import NODES

__all__ = ["Op", "Program", "ProgramBuilder", "talk_program"]


@dataclass(frozen=True)
class Op:
    """One operation. kind: a key of ``nodes.NODES``; args: registers read (its declared
    inputs, in order); param: static data (its declared parameters)."""

    kind: str
    args: tuple = ()
    param: tuple = ()


@dataclass
class Program:
    """A compiled material: ``ops`` in dependency order; ``surface`` the register of the final
    closure; ``occlusion`` an optional float register (the glTF importer's occlusion);
    ``aovs`` the shader AOVs it writes (AOV Output nodes), (name, colour register, value
    register) each."""

    ops: list[Op]
    surface: int
    occlusion: int | None = None
    aovs: tuple[tuple[str, int, int], ...] = ()

    def __post_init__(self) -> None:
        varying = []
        for op in self.ops:
            varying.append(NODES[op.kind].reads_points or op.kind == "image" and not op.args
                           or any(varying[a] for a in op.args if a is not None))
        self._varying = varying

    @property
    def constant(self) -> bool:
        """True when the result does not depend on the point: evaluated once per material."""
        outs = [self.surface] + ([self.occlusion] if self.occlusion is not None else [])
        return not any(self._varying[r] for r in outs)

    @property
    def holdout(self) -> bool:
        """True when the surface is a Holdout node: the object cuts a hole, as a holdout
        object does (a Holdout mixed with other shaders renders black instead)."""
        return self.ops[self.surface].kind == "holdout"

    @property
    def fades(self) -> bool:
        """True when the surface may be less than opaque somewhere: a Transparent BSDF, a
        transmission seen through or a Holdout, or an Alpha input that is not the constant 1."""
        if self.holdout:
            return False
        for op in self.ops:
            if op.kind in ("transparent", "see_through", "holdout"):
                return True
            if op.kind in ("principled", "bo2"):
                alpha = self.ops[op.args[NODES[op.kind].index("alpha")]]
                if not (alpha.kind == "const" and alpha.param[0] >= 1.0):
                    return True
        return False

    def requires(self) -> set[tuple[str, str]]:
        """Corner attributes the program reads: ("uv", map), ("attribute", name),
        ("tangent", map); "" names the active render UV map or colour attribute."""
        need = set()
        for op in self.ops:
            if op.kind == "uv" or op.kind == "image" and not op.args:
                need.add(("uv", op.param[0] if op.kind == "uv" else ""))
            elif op.kind == "attribute":
                need.add(("attribute", op.param[0]))
            elif op.kind == "normal_map" and op.param[0] == "TANGENT":
                need.add(("tangent", op.param[1]))
        return need


class ProgramBuilder:
    """Appends operations and returns their registers (constants are shared)."""

    def __init__(self) -> None:
        self.ops: list[Op] = []
        self._consts: dict[tuple, int] = {}

    def add(self, kind: str, *args, param: tuple = ()) -> int:
        """Append operation ``kind`` reading registers ``args`` (its declared inputs, in order;
        an image may read none: the active UV map) with static ``param``; its register."""
        node = NODES[kind]
        if len(args) != len(node.inputs) and not (kind == "image" and not args):
            raise ValueError(f"operation {kind!r} reads {len(node.inputs)} inputs "
                             f"({', '.join(node.inputs)}), not {len(args)}")
        if "values*" not in node.params and len(param) != len(node.params):
            raise ValueError(f"operation {kind!r} takes the parameters "
                             f"({', '.join(node.params)}), not {len(param)}")
        self.ops.append(Op(kind, tuple(args), tuple(param)))
        return len(self.ops) - 1

    def const(self, *values: float) -> int:
        key = tuple(float(v) for v in values)
        if key not in self._consts:
            self._consts[key] = self.add("const", param=key)
        return self._consts[key]

    def build(self, surface: int, occlusion: int | None = None,
              aovs: tuple[tuple[str, int, int], ...] = ()) -> Program:
        """The program of the operations ``surface``, ``occlusion`` and ``aovs`` (as
        ``Program``'s) read, in dependency order, renumbered (the others, such as those of a
        compile of a node that stopped part way, ``core.scene.recursion``, are dropped)."""
        live = [False] * len(self.ops)
        stack = [r for r in (surface, occlusion) if r is not None]
        stack += [r for _, color, value in aovs for r in (color, value)]
        while stack:
            reg = stack.pop()
            if not live[reg]:
                live[reg] = True
                stack.extend(a for a in self.ops[reg].args if a is not None)
        new: dict[int, int] = {}
        ops = []
        for reg, op in enumerate(self.ops):
            if live[reg]:
                new[reg] = len(ops)
                ops.append(Op(op.kind, tuple(None if a is None else new[a] for a in op.args),
                              op.param))
        return Program(ops, new[surface], None if occlusion is None else new[occlusion],
                       tuple((name, new[color], new[value]) for name, color, value in aovs))


def talk_program(albedo=(0.8, 0.8, 0.8), rf0=(0.04, 0.04, 0.04), gloss=0.5,
                 emission=(0.0, 0.0, 0.0), emission_strength=1.0) -> Program:
    """A constant material in the talk's parameters (the BO2 Material's inputs)."""
    b = ProgramBuilder()

    def col(v):
        v = np.broadcast_to(np.asarray(v, np.float32).reshape(-1), (3,))
        return b.const(*v)

    surface = b.add("bo2", col(albedo), col(rf0), b.const(gloss), None, col(emission),
                    b.const(emission_strength), b.const(1.0))
    return b.build(surface)
