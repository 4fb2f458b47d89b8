"""
Estimates made ahead for the experiments a replay has at hand, used as they come one by one.

The estimator service handles one experiment at a time, in order: the trend filter, the alarm
latch and the history need that.  The estimate of an experiment, though, depends on its
friction levels and the parameter set only, so a replay that has completed several experiments
(one read chunk of the bag, or more) estimates them together
(:func:`~robot_wear_monitor.estimation.batch.estimate_wear_rows`, one batched refinement for all)
and the service then takes each one's estimate from here instead of computing it, in the same
order and with the same checks as without.  The results are the same numbers either way (the
batched rows equal the one-by-one ones; tested).

Whatever the batch cannot take (a custom estimator, levels the service would reject, a batch
that fails) is left to the one-by-one path, which then computes or rejects it as before.
"""

from __future__ import annotations

from dataclasses import dataclass
import math
from typing import Any, Optional, Sequence

import numpy as np
from robot_wear_monitor.errors import InputError
from robot_wear_monitor.model.params import ParameterSet
from robot_wear_monitor.recordings.messages import FrictionLevelsMessage

#: (stamp [s], speeds [rad/s], frictions) of one experiment's levels: what an estimate is for.
LevelsKey = tuple[float, tuple[float, ...], tuple[float, ...]]


def levels_key(levels: FrictionLevelsMessage) -> LevelsKey:
    """Return the key of an experiment's levels (exact values)."""
    return (float(levels.stamp_s), tuple(levels.speeds_rad_s), tuple(levels.frictions))


def batchable(levels: FrictionLevelsMessage, *, joint: str) -> bool:
    """Return True for levels the service would estimate (its joint, N >= 2, finite, > 0)."""
    speeds, frictions = levels.speeds_rad_s, levels.frictions
    return bool((not levels.joint or levels.joint == joint) and len(speeds) >= 2
                and len(speeds) == len(frictions)
                and all(math.isfinite(v) for v in (*speeds, *frictions))
                and min(speeds) > 0)


@dataclass(frozen=True)
class Prepared:
    """
    What was computed ahead for one experiment's levels.

    :ivar estimates: the ``estimate_wear`` batch of 1.
    :ivar intervals: the ``wear_intervals`` batch of 1 (None: not prepared).
    :ivar trend_row: the ``profile_log_likelihood`` rows (1, G) on ``trend_grid`` (or None).
    :ivar trend_grid: the wear grid of ``trend_row``.

    """

    estimates: Any
    intervals: Any = None
    trend_row: Optional[np.ndarray] = None
    trend_grid: Optional[np.ndarray] = None

    def trend_row_on(self, grid: np.ndarray) -> Optional[np.ndarray]:
        """Return the trend row if it was computed on ``grid`` (the same values), else None."""
        if self.trend_row is None or self.trend_grid is None or \
                not np.array_equal(self.trend_grid, grid):
            return None
        return self.trend_row


class PreparedEstimates:
    """The estimates made ahead for one estimator service, taken once each."""

    def __init__(self) -> None:
        """Start empty."""
        self._estimates: dict[LevelsKey, Prepared] = {}

    def __len__(self) -> int:
        """Return how many prepared estimates are not taken yet."""
        return len(self._estimates)

    def prepare(self, levels: Sequence[FrictionLevelsMessage], *, joint: str,
                params: ParameterSet, trend_grid: Optional[np.ndarray] = None) -> int:
        """
        Estimate the batchable ``levels`` together; return how many were prepared.

        The estimates, then their intervals and (with ``trend_grid``) their trend rows.
        Replaces what an earlier call prepared and was not taken.  A failure of the batch
        prepares nothing (each experiment is then estimated alone, failing or not as alone);
        a failure of the intervals prepares the estimates only.
        """
        self._estimates.clear()
        rows = [item for item in levels if batchable(item, joint=joint)]
        if len(rows) < 2:
            return 0
        # deferred import: start-up time (estimation: not every importer needs it)
        from robot_wear_monitor.estimation.batch import estimate_wear_rows
        from robot_wear_monitor.estimation.batch_intervals import wear_intervals_rows
        speeds = [np.asarray(r.speeds_rad_s, dtype=float) for r in rows]
        values = [np.asarray(r.frictions, dtype=float)[None, :] for r in rows]
        failures = (InputError, ValueError, FloatingPointError, np.linalg.LinAlgError)
        try:
            estimates = estimate_wear_rows(speeds, values, params=params)
        except failures:
            return 0
        intervals: Sequence[Any] = [None] * len(rows)
        trend_rows: Sequence[Optional[np.ndarray]] = [None] * len(rows)
        try:
            intervals, trend_rows = wear_intervals_rows(speeds, values, estimates,
                                                        params=params, trend_grid=trend_grid)
        except failures:
            pass  # the estimates alone: each interval computed as it comes
        for item, estimate, interval, row in zip(rows, estimates, intervals, trend_rows):
            self._estimates[levels_key(item)] = Prepared(
                estimates=estimate, intervals=interval, trend_row=row,
                trend_grid=None if row is None else trend_grid)
        return len(self._estimates)

    def take(self, levels: FrictionLevelsMessage) -> Optional[Prepared]:
        """Return (and forget) what was prepared for ``levels``, or None."""
        return self._estimates.pop(levels_key(levels), None)
