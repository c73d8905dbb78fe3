"""Bounded recursion (``core.scene.recursion``) over chains deeper than Python's stack allows,
against the values the chains compute by a plain loop."""

import sys

import pytest

from bo2_lighting.addon.core.scene.recursion import Bounded


def chain(length: int, unmemoized=frozenset()):
    """f(k) = f(k - 1) + k, f(0) = 0, memoized except at the indices ``unmemoized`` (as a
    compiler's fallbacks): the value, and how many times each index was computed."""
    memo, counts = {}, {}

    def f(k):
        if k in memo:
            return memo[k]
        if not bounded.level:
            return bounded.run(k)
        return compute(k)

    def compute(k):
        if k in memo:
            return memo[k]
        with bounded.nested(k):
            counts[k] = counts.get(k, 0) + 1
            if counts[k] > 100:  # the retries do not end
                raise RuntimeError(f"index {k} computed {counts[k]} times")
            value = 0 if k == 0 else f(k - 1) + k
        if k not in unmemoized:
            memo[k] = value
        return value

    bounded = Bounded(compute, limit=64)
    return f(length), counts


@pytest.mark.parametrize("unmemoized", [frozenset(), frozenset(range(0, 5000, 7)),
                                        frozenset({64, 128, 4000})])
def test_chains_deeper_than_the_stack_end_with_the_loops_value(unmemoized):
    depth = 5000
    assert depth > sys.getrecursionlimit()
    value, counts = chain(depth, unmemoized)
    assert value == depth * (depth + 1) // 2
    # every memoized index is computed a bounded number of times (retries redo few levels)
    assert max(c for k, c in counts.items() if k not in unmemoized) <= 3
