"""
Diagnostics of the monitoring services: the status type, number text and rejection reports.

:class:`DiagnosticReport` is one DiagnosticStatus (level, message, key-values) as the services
build it; :func:`fmt_number` writes numbers into key-values (JSON takes
:func:`~robot_wear_monitor.json_values.finite_or_none`),
:func:`interval_text`, :func:`forecast_text` and :func:`trend_values` write an estimate's
interval and trend into the estimator's status; :data:`ROUTINE_REJECTIONS` and
:class:`RejectionLog` decide which rejected inputs are defects and say so in the nodes' logs at
a limited rate.
"""

from __future__ import annotations

from collections import Counter
from dataclasses import dataclass
import math
from typing import Mapping, Optional, TYPE_CHECKING

from robot_wear_monitor.text import BEYOND_HORIZON, fmt_number, UNKNOWN

if TYPE_CHECKING:
    from robot_wear_monitor.estimation.intervals import WearInterval
    from robot_wear_monitor.estimation.trend import TrendEstimate


@dataclass(frozen=True)
class DiagnosticReport:
    """One DiagnosticStatus: level (0 OK, 1 WARN, 2 ERROR), message and key-values."""

    level: int
    message: str
    values: tuple[tuple[str, str], ...]

    def value(self, key: str) -> str:
        """Return the value of ``key`` (KeyError when absent)."""
        for k, v in self.values:
            if k == key:
                return v
        raise KeyError(key)


#: Rejections that the friction experiment itself produces (ramps too short to be a pass, a
#: pass without its partner, a pause in the stream, an experiment the runner aborted or a
#: recording cut), and messages without the joint (another publisher on /joint_states, e.g. a
#: gripper): logged as info, not as input defects.
ROUTINE_REJECTIONS = frozenset({'pass_too_short', 'pass_unpaired', 'pass_no_common_window',
                                'time_gap', 'aborted_experiment', 'already_in_history',
                                'joint_missing', 'experiment_cut'})


#: Prefixes a replay or segment summary puts before a rejection reason (where it happened).
_REASON_PREFIXES = ('segmentation_', 'friction_levels_', 'reader_')


def is_routine(reason: str) -> bool:
    """
    Return True for a rejection the experiment itself produces (:data:`ROUTINE_REJECTIONS`).

    ``reason`` may carry a joint (``"<joint>: <reason>"``) or a summary prefix
    (``segmentation_``, ``friction_levels_``, ``reader_``).
    """
    reason = reason.rpartition(': ')[2]
    for prefix in _REASON_PREFIXES:
        if reason.startswith(prefix):
            reason = reason[len(prefix):]
            break
    return reason in ROUTINE_REJECTIONS


def split_rejections(rejections: Mapping[str, int]) -> tuple[dict[str, int], dict[str, int]]:
    """
    Return ``(bad data, routine)``: the rejections that signal bad data and the routine ones.

    Both sorted by reason, zero counts left out; :func:`is_routine` tells them apart.
    """
    ordered = sorted((r, int(n)) for r, n in rejections.items() if n)
    return ({r: n for r, n in ordered if not is_routine(r)},
            {r: n for r, n in ordered if is_routine(r)})


def rejection_text(rejections: Mapping[str, int]) -> str:
    """
    Return the rejections in words: the bad-data ones named, the routine ones only counted.

    '' when nothing was rejected; e.g. ``"rejected as bad data: non_finite 3; routine: 299
    (unpaired passes, gaps between experiments ...)"``.
    """
    defects, routine = split_rejections(rejections)
    parts = []
    if defects:
        parts.append('rejected as bad data: ' + ', '.join(f'{r} {n}' for r, n in defects.items()))
    if routine:
        parts.append(f'routine: {sum(routine.values())} (the pass without a partner at the end '
                     'of a sweep, the pauses between experiments, ramps)')
    return '; '.join(parts)


class RejectionLog:
    """
    Rate-limited log text of the inputs rejected since the last report, by reason.

    A node calls :meth:`report` whenever its rejection count grows and from its periodic
    diagnostics timer; the text says how many inputs of each reason were rejected since the
    last report, at most once per ``period_s``, so a flood of bad messages gives one line per
    period and none is left unreported.
    """

    def __init__(self, *, what: str, period_s: float = 10.0) -> None:
        """Name the rejected inputs ``what`` (e.g. ``joint_states``) in the text."""
        self.what = what
        self.period_s = float(period_s)
        self._reported: Counter[str] = Counter()
        self._last_s = -math.inf

    def report(self, counts: Mapping[str, int], *, now_s: float, detail: str = ''
               ) -> Optional[tuple[str, bool]]:
        """
        Return (text, defective) of the rejections not yet reported, or None.

        None when nothing is new or the last report is less than ``period_s`` old;
        ``defective`` is True when a reason other than :data:`ROUTINE_REJECTIONS` is new
        (a reason may be prefixed by its joint, ``"<joint>: <reason>"``).
        """
        if now_s - self._last_s < self.period_s:
            return None
        new = Counter(counts)
        new.subtract(self._reported)
        new = +new
        if not new:
            return None
        self._last_s = now_s
        self._reported = Counter(counts)
        by_reason = ', '.join(f'{reason} {count}' for reason, count in sorted(new.items()))
        text = (f'rejected {sum(new.values())} {self.what} ({by_reason}); '
                f'{sum(counts.values())} since start')
        # a node of several joints names each reason "<joint>: <reason>"
        defective = any(reason.rpartition(': ')[2] not in ROUTINE_REJECTIONS for reason in new)
        return (f'{text}; last: {detail}' if detail and defective else text), defective


def interval_text(interval: Optional[WearInterval]) -> str:
    """Return `` (95 %: low-high)`` of the wear interval (``+``: open above), '' when None."""
    if interval is None:
        return ''
    above = '+' if interval.wear_high_at_grid_end else ''
    return (f' (95 %: {fmt_number(interval.wear_low, 3)}-{fmt_number(interval.wear_high, 3)}'
            f'{above})')


def forecast_text(trend: TrendEstimate) -> str:
    """Return ``, crossing in n experiments (low-high)``; '' when likely crossed or unknown."""
    remaining = float(trend.remaining_experiments)
    if trend.probability_above_threshold >= 0.5 or not math.isfinite(remaining):
        return ''
    low = fmt_number(trend.remaining_experiments_low, 3)
    high = float(trend.remaining_experiments_high)
    if not math.isfinite(high):
        return f', crossing in {remaining:.0f} experiments (95 %: {low} to {BEYOND_HORIZON})'
    return f', crossing in {remaining:.0f} experiments (95 %: {low}-{fmt_number(high, 3)})'


#: Diagnostics key-values of the trend (trend attribute names, with their keys).
TREND_KEYS = (('trend_wear', 'wear'), ('trend_low', 'wear_low'), ('trend_high', 'wear_high'),
              ('trend_rate_per_experiment', 'rate'),
              ('probability_above_threshold', 'probability_above_threshold'),
              ('remaining_experiments', 'remaining_experiments'),
              ('remaining_experiments_low', 'remaining_experiments_low'),
              ('remaining_experiments_high', 'remaining_experiments_high'),
              ('crossing_time_s', 'crossing_time_s'),
              ('crossing_time_low_s', 'crossing_time_low_s'),
              ('crossing_time_high_s', 'crossing_time_high_s'))


def trend_values(trend: Optional[TrendEstimate]) -> list[tuple[str, str]]:
    """Return the trend's diagnostics key-values (:data:`TREND_KEYS`), none when None."""
    if trend is None:
        return []
    return [(key, fmt_number(getattr(trend, name), 15 if 'time' in key else 6,
                             missing=BEYOND_HORIZON if key.startswith(('remaining', 'crossing'))
                             else UNKNOWN))
            for key, name in TREND_KEYS]
