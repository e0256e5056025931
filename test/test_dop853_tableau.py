"""The DOP853 tableau stated in physics.dop853_tableau: order conditions, and the match with scipy's copy."""

from __future__ import annotations

import importlib
from functools import cache

import numpy as np

from pendulum_accel.physics import dop853_tableau as tableau
from test.rounding import EPS

Tree = tuple["Tree", ...]  # a rooted tree: the sorted tuple of its root's subtrees


@cache
def forests(order: int) -> frozenset[Tree]:
    """Every multiset (as a sorted tuple) of rooted trees whose orders add up to ``order``."""
    if order == 0:
        return frozenset({()})
    out = set()
    for k in range(1, order + 1):
        for tree in trees(k):
            for rest in forests(order - k):
                out.add(tuple(sorted((tree, *rest))))
    return frozenset(out)


def trees(order: int) -> frozenset[Tree]:
    """Every rooted tree with ``order`` nodes: a root over a forest of order − 1."""
    return forests(order - 1)


def size(tree: Tree) -> int:
    """|t|: the number of nodes."""
    return 1 + sum(size(child) for child in tree)


def density(tree: Tree) -> int:
    """γ(t) = |t| Π γ(children)."""
    return size(tree) * int(np.prod([density(child) for child in tree]))


def stage_weights(tree: Tree) -> np.ndarray:
    """Φ(t) per stage: Π over the children of A Φ(child) (all ones for a single node)."""
    out = np.ones(tableau.STAGES)
    for child in tree:
        out = out * (tableau.A @ stage_weights(child))
    return out


def test_tree_counts_are_the_known_ones() -> None:
    """1, 1, 2, 4, 9, 20, 48, 115 rooted trees of order 1 … 8 (OEIS A000081): the enumeration is complete."""
    assert [len(trees(n)) for n in range(1, 9)] == [1, 1, 2, 4, 9, 20, 48, 115]


def test_every_order_condition_up_to_eight_holds() -> None:
    """bᵀ Φ(t) = 1/γ(t) for all 200 rooted trees of order ≤ 8, to the rounding of the 30-digit constants."""
    worst = max(
        abs(float(tableau.B @ stage_weights(tree)) * density(tree) - 1.0)
        for n in range(1, 9)
        for tree in trees(n)
    )
    assert worst < 1e-12
    # …and not beyond: some ninth-order condition fails, so the check above can tell orders apart.
    assert max(abs(float(tableau.B @ stage_weights(tree)) * density(tree) - 1.0) for tree in trees(9)) > 1e-3


def test_rows_sum_to_the_nodes() -> None:
    """Σ_q A[s, q] = C[s] (each stage evaluates f at its own time), A strictly lower triangular."""
    # ≤ 12 coefficients per row, each an exact rational rounded once, summed in double: within the sum of
    # |terms| times ε (the textbook bound for n ≤ 1/ε terms, each term's own rounding included)
    bound = EPS * (np.abs(tableau.A).sum(axis=1) + np.abs(tableau.C))
    assert np.all(np.abs(tableau.A.sum(axis=1) - tableau.C) <= bound)
    assert not np.any(np.triu(tableau.A))


def test_tableau_is_scipys_digit_for_digit() -> None:
    """A, B, C equal scipy's DOP853 constants exactly, so rk8 runs are bit-identical to scipy-built ones.

    scipy's module is private: should it move, this fails with the place to look, and the order
    conditions above still vouch for the constants.
    """
    name = "scipy.integrate._ivp.dop853_coefficients"
    try:
        scipy_tableau = importlib.import_module(name)
    except ImportError as exc:
        raise AssertionError(
            f"scipy no longer has {name} ({exc}); find its DOP853 tableau and compare"
        ) from None
    n = tableau.STAGES
    assert n == scipy_tableau.N_STAGES
    np.testing.assert_array_equal(tableau.A, scipy_tableau.A[:n, :n])
    np.testing.assert_array_equal(tableau.B, scipy_tableau.B)
    np.testing.assert_array_equal(tableau.C, scipy_tableau.C[:n])
