"""
Experiment assembly: friction levels of one joint grouped into friction experiments.

:func:`merge_levels` combines repeated levels at one speed (inverse-variance weights);
:class:`SpeedTally` counts levels per measured speed; :class:`ExperimentAssembler` groups
consecutive levels into experiments, at configured speeds or at the speeds found in the data.
The levels come from the pass finder and pairer of :mod:`robot_wear_monitor.experiment.passes`.
Speeds are motor side [rad/s], times [s].
"""

from __future__ import annotations

from collections import Counter
import math
from typing import Sequence

import numpy as np
from robot_wear_monitor.errors import InputError
from robot_wear_monitor.experiment.levels import FrictionExperiment, FrictionLevel
from robot_wear_monitor.experiment.segmentation_settings import (EXPERIMENT_GAPS_S,
                                                                 ExperimentGrouping)

_GROUPING = ExperimentGrouping()


def merge_levels(levels: Sequence[FrictionLevel]) -> FrictionLevel:
    """
    Combine repeated levels at one speed into one, weighting by inverse variance.

    The friction, forward and backward torques and the speed are inverse-variance weighted
    means; the standard error is 1/sqrt(sum 1/se^2); counts add; windows and times span all.
    """
    if not levels:
        raise InputError('merge_levels: no levels to merge')
    if len(levels) == 1:
        return levels[0]
    se = np.array([lv.friction_std_error for lv in levels], dtype=float)
    if np.all(se > 0):
        weights = 1.0 / se ** 2
        merged_se = float(1.0 / math.sqrt(weights.sum()))
    else:
        weights = np.ones(se.size)
        merged_se = float(math.sqrt(np.sum(se ** 2)) / se.size)
    weights = weights / weights.sum()

    def mean(attribute: str) -> float:
        return float(np.dot(weights, [getattr(lv, attribute) for lv in levels]))

    return FrictionLevel(
        speed_rad_s=mean('speed_rad_s'), friction=mean('friction'),
        friction_std_error=merged_se, tau_forward=mean('tau_forward'),
        tau_backward=mean('tau_backward'), n_forward=sum(lv.n_forward for lv in levels),
        n_backward=sum(lv.n_backward for lv in levels),
        position_min_rad=min(lv.position_min_rad for lv in levels),
        position_max_rad=max(lv.position_max_rad for lv in levels),
        start_time_s=min(lv.start_time_s for lv in levels),
        end_time_s=max(lv.end_time_s for lv in levels))


class SpeedTally:
    """
    Count friction levels per speed, a speed being a cluster of measured speeds.

    A level within ``tolerance_rad_s`` of a speed's mean belongs to it (a measured speed varies
    by a few mrad/s around the commanded one).  ``counts()`` gives mean speed rounded to
    0.1 rad/s -> levels, in increasing speed.
    """

    def __init__(self, tolerance_rad_s: float = 1.0) -> None:
        """Start with no speed."""
        self.tolerance_rad_s = float(tolerance_rad_s)
        self._sums: list[float] = []
        self._counts: list[int] = []

    def add(self, speed_rad_s: float) -> None:
        """Count one level at ``speed_rad_s`` (motor side)."""
        speed = float(speed_rad_s)
        if self._sums:
            # the nearest mean (the first of equals); a NaN anywhere matches none
            distances = [abs(total / count - speed)
                         for total, count in zip(self._sums, self._counts)]
            nearest = distances.index(min(distances))
            if distances[nearest] <= self.tolerance_rad_s and not math.isnan(sum(distances)):
                self._sums[nearest] += speed
                self._counts[nearest] += 1
                return
        self._sums.append(speed)
        self._counts.append(1)

    def counts(self) -> dict[float, int]:
        """Return {mean speed rounded to 0.1 rad/s: levels}, in increasing speed."""
        tally: Counter = Counter()
        for total, count in zip(self._sums, self._counts):
            tally[round(total / count, 1)] += count
        return dict(sorted(tally.items()))

    def __bool__(self) -> bool:
        """Return True when a level was counted."""
        return bool(self._counts)


class ExperimentAssembler:
    """
    Group consecutive friction levels into experiments (one run of the friction experiment).

    With ``speeds_rad_s`` (motor side) every level is matched to the nearest configured speed
    within ``speed_tolerance_rad_s`` (levels at other speeds are ignored and counted in
    ``ignored``); repeated levels at a speed within one experiment are merged with
    :func:`merge_levels`; the experiment is complete when every configured speed has a level
    and is returned with one level per speed, in the configured order.  A pause longer than
    ``idle_gap_s`` between levels abandons an incomplete experiment (counted in ``abandoned``).

    Without speeds (discovery), the speeds are those of the levels themselves: an experiment
    ends when the joint idles for more than ``idle_gap_s`` between levels or when a speed
    already in the experiment comes again after another speed (the speed set starts to
    repeat); a level at the same speed as the one just before (within the tolerance) is merged
    with it.  Its levels are returned in the order they were measured.

    :ivar ignored: levels at no configured speed.
    :ivar ignored_speeds: a :class:`SpeedTally` of their speeds (reported, never silently
        dropped).
    :ivar abandoned: incomplete experiments dropped.

    """

    def __init__(self, *, speeds_rad_s: Sequence[float] | None = None,
                 speed_tolerance_rad_s: float = _GROUPING.experiment_speed_tolerance_rad_s,
                 idle_gap_s: float = EXPERIMENT_GAPS_S['raw_run']) -> None:
        """
        Configure the grouping; see the class docstring.

        The defaults are :class:`~robot_wear_monitor.experiment.segmentation_settings.
        ExperimentGrouping`'s tolerance and the raw-run context's gap
        (:data:`~robot_wear_monitor.experiment.segmentation_settings.EXPERIMENT_GAPS_S`);
        the services pass the node's ``idle_gap_s``.
        """
        if not math.isfinite(speed_tolerance_rad_s) or speed_tolerance_rad_s <= 0:
            raise InputError(f'ExperimentAssembler.speed_tolerance_rad_s: must be > 0, '
                             f'got {speed_tolerance_rad_s}')
        if not math.isfinite(idle_gap_s) or idle_gap_s <= 0:
            raise InputError(f'ExperimentAssembler.idle_gap_s: must be > 0, got {idle_gap_s}')
        self._speeds = None
        if speeds_rad_s is not None:
            speeds = np.asarray(list(speeds_rad_s), dtype=float)
            if speeds.ndim != 1 or speeds.size == 0 or not np.all(np.isfinite(speeds)) \
                    or np.any(speeds <= 0):
                raise InputError('ExperimentAssembler.speeds_rad_s: expected positive finite '
                                 f'speeds, got {list(speeds_rad_s)!r}')
            if speeds.size > 1 and np.min(np.diff(np.sort(speeds))) <= 2 * speed_tolerance_rad_s:
                raise InputError('ExperimentAssembler.speeds_rad_s: speeds closer than twice '
                                 'speed_tolerance_rad_s cannot be told apart')
            self._speeds = speeds
        self._tolerance = float(speed_tolerance_rad_s)
        self._idle_gap = float(idle_gap_s)
        self._current: list[list[FrictionLevel]] = []
        self._slots: list[int] = []
        self._last_end = -math.inf
        self.ignored = 0
        self.ignored_speeds = SpeedTally(speed_tolerance_rad_s)
        self.abandoned = 0

    def add(self, level: FrictionLevel) -> list[FrictionExperiment]:
        """Add one level; return the experiments it completes (zero or one)."""
        done: list[FrictionExperiment] = []
        if self._current and level.start_time_s - self._last_end > self._idle_gap:
            done += self._close(idle=True)
        if self._speeds is not None:
            distance = np.abs(self._speeds - level.speed_rad_s)
            slot = int(np.argmin(distance))
            if distance[slot] > self._tolerance:
                self.ignored += 1
                self.ignored_speeds.add(level.speed_rad_s)
                return done
        else:
            speeds = [group[0].speed_rad_s for group in self._current]
            repeat = [i for i, s in enumerate(speeds)
                      if abs(s - level.speed_rad_s) <= self._tolerance]
            if repeat and repeat[-1] == len(speeds) - 1 and self._slots:
                slot = self._slots[-1]  # the same speed again at once: more of that level
            else:
                if repeat:
                    done += self._close(idle=False)
                slot = len(self._current)
        self._last_end = max(self._last_end, level.end_time_s)
        if slot in self._slots:
            self._current[self._slots.index(slot)].append(level)
        else:
            self._slots.append(slot)
            self._current.append([level])
        if self._speeds is not None and len(self._slots) == self._speeds.size:
            done += self._close(idle=False)
        return done

    def idle(self, *, now_s: float) -> list[FrictionExperiment]:
        """Close the experiment in progress if nothing came for ``idle_gap_s`` before now_s."""
        if self._current and now_s - self._last_end > self._idle_gap:
            return self._close(idle=True)
        return []

    def flush(self) -> list[FrictionExperiment]:
        """End of data: return the experiment in progress if it is complete (or speeds unset)."""
        return self._close(idle=True) if self._current else []

    @property
    def last_level_end_s(self) -> float:
        """Return the end [s] of the last level of the experiment in progress (-inf: none)."""
        return self._last_end

    def current_speeds(self) -> list[float]:
        """Return the speeds of the experiment in progress (motor side, in measured order)."""
        return [float(group[0].speed_rad_s) for group in self._current]

    def discard(self) -> int:
        """Drop the experiment in progress (a recording cut in it); return its level count."""
        count = sum(len(group) for group in self._current)
        self._current, self._slots = [], []
        self._last_end = -math.inf
        return count

    def _close(self, *, idle: bool) -> list[FrictionExperiment]:
        groups, slots = self._current, self._slots
        self._current, self._slots = [], []
        self._last_end = -math.inf
        if not groups:
            return []
        if self._speeds is not None:
            if len(slots) < self._speeds.size:
                self.abandoned += 1
                return []
            order = np.argsort(slots)
            groups = [groups[i] for i in order]
        return [FrictionExperiment(levels=tuple(merge_levels(g) for g in groups))]
