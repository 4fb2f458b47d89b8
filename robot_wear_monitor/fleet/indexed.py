"""
The fleet view read through the history's ranking keys: a page, a filter, a stream.

The same rows, order and ``state`` as :func:`~robot_wear_monitor.fleet.ranking.fleet_view` of
the whole fleet, without reading the whole fleet: the history keeps each joint's ranking key
and the stable parts of its state (schema version 12,
:mod:`~robot_wear_monitor.history.fleet_index`), the query decides what moves with the clock
(stale, crossing dates, planned dates) at ``now_s``, and only the rows shown are read in full
and made into :class:`FleetView` here.
"""

from __future__ import annotations

from typing import Any, Iterator, Optional

from robot_wear_monitor.fleet.ranking import DEFAULT_REESCALATION_MARGIN, fleet_view, FleetView
from robot_wear_monitor.fleet.states import DAY_S, DEFAULT_FORECAST_HORIZON_DAYS
from robot_wear_monitor.fleet.thresholds import packaged_parameter_sets, ParameterSets
from robot_wear_monitor.history.fleet_index import CHUNK_ROWS, FleetClock, FleetIndex


def fleet_clock(index: FleetIndex, *, now_s: float,
                reescalation_margin: float = DEFAULT_REESCALATION_MARGIN,
                forecast_horizon_s: float = DEFAULT_FORECAST_HORIZON_DAYS * DAY_S,
                parameter_sets: Optional[ParameterSets] = None) -> FleetClock:
    """
    Return what the index's queries decide at ``now_s`` [s], as :func:`fleet_view` would.

    ``reescalation_margin`` [wear units] and ``forecast_horizon_s`` [s] as for
    :func:`fleet_view`; ``parameter_sets``: the warning level of the rows that store none
    (None: the packaged sets).
    """
    sets = parameter_sets or packaged_parameter_sets()
    assumed = {name: sets.resolve(name)[0].wear_warning for name in index.assumed_sets()}
    return FleetClock(now_s=float(now_s), margin=float(reescalation_margin),
                      horizon_s=float(forecast_horizon_s), assumed_warning=assumed,
                      default_warning=sets.default.wear_warning)


def _views(index: FleetIndex, keys: list[tuple[str, str]], clock: FleetClock,
           parameter_sets: Optional[ParameterSets]) -> list[FleetView]:
    return fleet_view(index.rows(keys), now_s=clock.now_s,
                      reescalation_margin=clock.margin, forecast_horizon_s=clock.horizon_s,
                      parameter_sets=parameter_sets)


def page_views(index: FleetIndex, clock: FleetClock, *, robot: Optional[str] = None,
               state: Optional[str] = None, offset: int = 0, limit: Optional[int] = None,
               parameter_sets: Optional[ParameterSets] = None) -> list[FleetView]:
    """
    Return the rows ``offset`` to ``offset + limit`` of the fleet view, worst first.

    ``robot``: that robot's joints; ``state``: the joints in that state (at ``clock``).
    """
    keys = index.page(clock, robot=robot, state=state, offset=offset, limit=limit)
    return _views(index, keys, clock, parameter_sets)


def stream_views(index: FleetIndex, clock: FleetClock, *, robot: Optional[str] = None,
                 state: Optional[str] = None, parameter_sets: Optional[ParameterSets] = None,
                 chunk: int = CHUNK_ROWS) -> Iterator[FleetView]:
    """Yield every chosen row of the fleet view, worst first, read ``chunk`` rows at a time."""
    for keys in index.iterate(clock, robot=robot, state=state, chunk=chunk):
        yield from _views(index, keys, clock, parameter_sets)


def reescalated_views(index: FleetIndex, clock: FleetClock, *,
                      parameter_sets: Optional[ParameterSets] = None) -> list[FleetView]:
    """Return the re-escalated acknowledged alarms at ``clock`` (to log them once)."""
    return [v for v in _views(index, index.reescalated(clock), clock, parameter_sets)
            if v.reescalated]


def has_index(history: Any) -> bool:
    """Return whether ``history`` reads its fleet through stored keys (a :class:`WearHistory`)."""
    return callable(getattr(history, 'fleet_index', None))
