"""Memoized demand-driven evaluation of graphs of any depth within a bounded Python stack.

Node graphs are compiled and programs evaluated by functions that call themselves for their
inputs and memoize each result (``blender.materials``, ``core.scene.material``). A chain of
thousands of nodes (generated assets) would exceed Python's recursion limit. ``Bounded`` keeps their
simple recursive form: past ``limit`` nested calls, the innermost call gives up with
``TooDeep(key)``; ``run`` then computes that deeper key first, from an empty stack, and tries
again. Each retry finds the deeper results memoized, so the graph is evaluated deepest first,
in a topological order, with at most ``limit`` nested calls whatever its depth. The recursive
functions must memoize their results and tolerate a call that stops part way (they are called
again from the start); a result they cannot memoize (a fallback that depends on the caller)
is computed again where it is met, with ``limit`` levels of its own, so the retries end.
"""

from __future__ import annotations

from collections.abc import Callable, Hashable, Iterator
from contextlib import contextmanager

__all__ = ["Bounded", "TooDeep"]


class TooDeep(Exception):  # noqa: N818 - not an error: a request to compute ``key`` first
    """Raised by ``Bounded.nested`` past the limit; ``key`` is the call that did not fit."""

    def __init__(self, key: Hashable) -> None:
        super().__init__(key)
        self.key = key


class Bounded:
    """The depth of one recursive evaluation, and the loop that keeps it bounded.

    call:  call(key) -> result, the memoized recursive function, which wraps its work in
           ``with bounded.nested(key):``
    limit: nested calls allowed before ``TooDeep``
    """

    def __init__(self, call: Callable[[Hashable], object], limit: int = 64) -> None:
        self.call, self.limit, self.level = call, int(limit), 0
        self.ceiling = self.limit  # the level past which a call is deferred
        self.done: set = set()  # keys ``run`` computed from an empty stack

    @contextmanager
    def nested(self, key: Hashable) -> Iterator[None]:
        """One nested call of ``key``: TooDeep(key) past the limit, unless ``run`` computed it
        before (a result the call could not memoize, such as a fallback): that one goes on
        with ``limit`` more levels, as it did from the empty stack."""
        ceiling = self.ceiling
        if self.level >= ceiling:
            if key not in self.done:
                raise TooDeep(key)
            self.ceiling = self.level + self.limit
        self.level += 1
        try:
            yield
        finally:
            self.level -= 1
            self.ceiling = ceiling

    def run(self, key: Hashable):
        """``call(key)`` with every call that went too deep computed first (the deepest
        pending one, again and again), from an empty stack; returns its result."""
        if self.level:  # already inside an evaluation: the outer run handles TooDeep
            return self.call(key)
        pending = [key]
        while True:
            try:
                result = self.call(pending[-1])
            except TooDeep as deep:
                pending.append(deep.key)
                continue
            self.done.add(pending.pop())
            if not pending:
                return result
