"""Shared by the fleet and design-study tests: the share cells of a row, a row as a plain mapping, and the
check that no worker process outlives a test (autouse in each module that imports it)."""

from __future__ import annotations

from collections.abc import Iterator, Mapping
from typing import Any

import pytest

SHARE_CELLS = tuple(
    f"{name}_{window}{end}"
    for window in ("steady", "after_change")
    for name, end in (
        ("share_2sigma", ""),
        ("trials", ""),
        ("share_2sigma", "_low"),
        ("share_2sigma", "_high"),
        ("share_3sigma", ""),
    )
)
"""The fleet and design tables' share cells: each share beyond 2σ, its trials and its 95 % interval, and the
share beyond 3σ beside it."""


def cells(row: Mapping[str, object]) -> dict[str, Any]:
    """A fleet or design row as a plain mapping, for the checks that name its cells by computed keys
    (share_2sigma_{window}): Any, as a table cell is a str, bool, int or float, or None."""
    return dict(row)


@pytest.fixture(autouse=True)
def _no_leftover_workers() -> Iterator[None]:
    """No worker process of this test outlives it (a LocalCluster's children included)."""
    yield
    import multiprocessing

    assert not multiprocessing.active_children()
