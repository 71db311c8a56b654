"""Sizes checked before any work: a run's pose-cell grid, stream length and goal count against a
stated budget, refused with the number unless the user says ``--yes`` (never a prompt).

The budget (what a run on one core of a small machine does in minutes and a few hundred MB):

* :data:`MAX_POSE_CELLS` x'y'θ' cells: the recording and the report build the dense activity
  grid (8 bytes a cell); the defaults are 60 x 60 x 36 = 129,600 cells.
* :data:`MAX_TICKS` ticks per stream: 40 h at the simulator's 7 Hz; RatSLAM steps 2,000-5,000
  ticks a second (README, Speed), so a few minutes per system at the limit.
* :data:`MAX_GOALS` navigation goals per map.

A sweep's run count is its spec's ``max_runs`` (:mod:`harness.sweeps.spec`).
"""

from __future__ import annotations

import math

from worlds.errors import InputError

MAX_POSE_CELLS = 10_000_000
MAX_TICKS = 1_000_000
MAX_GOALS = 1_000


class BudgetError(InputError):
    """A run larger than the stated budget, asked for without ``--yes`` (one line: the number)."""


def check_grid(where: str, shape, yes: bool = False) -> None:
    """Refuse a pose-cell grid ``shape`` (nx, ny, nθ) of more than :data:`MAX_POSE_CELLS` cells."""
    cells = math.prod(int(n) for n in shape)
    if cells > MAX_POSE_CELLS and not yes:
        dims = " x ".join(str(int(n)) for n in shape)
        raise BudgetError(
            f"{where}: pose-cell grid {dims} = {cells:,} cells, more than the budget of {MAX_POSE_CELLS:,} "
            f"({8 * cells / 1e9:,.3g} GB for one dense copy of the activity); pass --yes to run it anyway"
        )


def check_ticks(where: str, ticks: float, yes: bool = False) -> None:
    """Refuse a stream of more than :data:`MAX_TICKS` ticks."""
    if ticks > MAX_TICKS and not yes:
        raise BudgetError(
            f"{where}: {ticks:,.0f} ticks, more than the budget of {MAX_TICKS:,} per stream; "
            "pass --yes to run it anyway"
        )


def check_goals(where: str, goals: int, yes: bool = False) -> None:
    """Refuse more than :data:`MAX_GOALS` navigation goals."""
    if goals > MAX_GOALS and not yes:
        raise BudgetError(
            f"{where}: {goals:,} goals, more than the budget of {MAX_GOALS:,}; pass --yes to run them all"
        )
