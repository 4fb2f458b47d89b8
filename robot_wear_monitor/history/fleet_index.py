"""
The fleet's ranking keys, kept with each joint's summary row: a page of the fleet is an index read.

Schema version 12 adds to ``joint_summary`` (one row per robot joint) what the fleet view's
order and state of the joint need, kept in the same transaction as every estimate
(:meth:`WearHistory.append`) and every alarm event (raise, acknowledgement, its edit or
withdrawal, reset: :func:`~robot_wear_monitor.history.alarms.insert_event`), and filled for an
older history by the migration (:func:`rebuild`):

* the stable parts (:func:`stored_keys`): the rank of :meth:`FleetRow.rank_key` (``rank_tier``
  0 unacknowledged alarm, 1 acknowledged, 2 invalid, 3 the rest; ``rank_crossing`` the forecast
  crossing [experiments], infinity when none; ``rank_high`` minus the upper bound of w,
  infinity when none) and the state as far as it does not move with the clock
  (``state_base``: 'alarm', 'acknowledged', 'cannot judge', 'new life' or 'judged');
* the times the clock is compared with, indexed: ``stale_since_s`` and ``usual_interval_s``
  (stale when ``now - since > STALE_FACTOR x interval``; ``stale_at_s`` is that moment),
  ``crossing_at_s`` (the forecast crossing's date, a crossing ahead only), and for an
  acknowledged alarm the re-escalation's values (``ack_then``, ``ack_now``: the wear at the
  acknowledgement and now) and its planned date (``planned_date``, ISO);
* what the warning needs: ``warn_fixed`` (the trend past the threshold, or w-hat or the trend
  at the stored warning level), ``wear_top`` (the larger of w-hat and the trend) with the
  estimate's ``warning_level`` (NULL: an older row, the parameter set's level is given to the
  query) and ``parameter_set``.

What moves with the clock is decided in the query (:class:`FleetClock`: now, the margin, the
horizon), comparing the stored times with ``now`` in SQL with the same arithmetic as
:func:`~robot_wear_monitor.fleet.ranking.fleet_view`, so that the rows of a page, their order
and their ``state`` are those of the full ranking.  The order is read from the index
``joint_summary_rank`` in segments: the unacknowledged alarms merged with the re-escalated
acknowledged ones (few), the other acknowledged alarms, then the rest (:meth:`FleetIndex.page`).
"""

from __future__ import annotations

from contextlib import AbstractContextManager
from dataclasses import dataclass, field
import datetime
import heapq
import itertools
import math
from typing import Any, Callable, Iterator, Optional, Sequence

from robot_wear_monitor.history import fleet_counts, fleet_keys
from robot_wear_monitor.history.backends import HistoryBackend
from robot_wear_monitor.history.fleet_rows import read_fleet
from robot_wear_monitor.history.records import FleetRow

#: A joint is stale after this many of its usual experiment intervals without an experiment.
STALE_FACTOR = 3.0
#: The states, worst first (``fleet/states.py`` names them; they are the query's words).
STATE_WORDS = ('alarm', 'acknowledged', 'cannot judge', 'stale', 'warning', 'new life', 'ok')

#: The key columns of ``joint_summary`` (schema version 12), in the order of :func:`stored_keys`.
KEY_COLUMNS = ('rank_tier', 'rank_crossing', 'rank_high', 'state_base', 'stale_since_s',
               'usual_interval_s', 'stale_at_s', 'crossing_at_s', 'warn_fixed', 'wear_top',
               'warning_level', 'parameter_set', 'ack_then', 'ack_now', 'planned_date',
               'ack_rise')

#: Rows read per query when every row is streamed.
CHUNK_ROWS = 1000
_NO_LIMIT = 2 ** 62


def _finite(value: float) -> Optional[float]:
    return float(value) if math.isfinite(value) else None


def _planned_date(text: str) -> str:
    """Return the planned date as 'YYYY-MM-DD' ('' when none or not a date)."""
    if not text:
        return ''
    try:
        return datetime.date.fromisoformat(text).isoformat()
    except ValueError:
        return ''


def stored_keys(row: FleetRow) -> tuple[Any, ...]:
    """Return the values of :data:`KEY_COLUMNS` of a joint's fleet row (module text)."""
    tier, crossing, high = row.rank_key()[:3]
    awaiting = row.awaiting_first_experiment
    if row.alarm:
        base = 'acknowledged' if row.acknowledged else 'alarm'
    elif not awaiting and (row.invalid_reason or not math.isfinite(row.wear)):
        base = 'cannot judge'
    else:
        base = 'new life' if awaiting else 'judged'
    interval = row.usual_interval_s
    known = math.isfinite(interval) and interval > 0
    since = row.last_stamp_s
    if math.isfinite(row.life_started_s):
        since = max(since, row.life_started_s)  # a new life: counted from the reset
    crossing_at = None
    if known and math.isfinite(row.crossing_experiments) and row.crossing_experiments > 0:
        crossing_at = row.last_stamp_s + row.crossing_experiments * interval
    tops = [v for v in (row.wear, row.trend_wear) if math.isfinite(v)]
    warn_fixed = (math.isfinite(row.crossing_experiments) and row.crossing_experiments <= 0) \
        or (math.isfinite(row.warning_level) and any(v >= row.warning_level for v in tops))
    then = now = None
    if row.alarm and row.acknowledged:
        trend_known = math.isfinite(row.acknowledged_trend_wear) and math.isfinite(
            row.trend_wear)
        then, now = ((row.acknowledged_trend_wear, row.trend_wear) if trend_known
                     else (row.acknowledged_wear, row.wear))
        then, now = (then, now) if math.isfinite(then) and math.isfinite(now) else (None, None)
    return (tier, crossing, high, base, since if known else None,
            interval if known else None,
            since + STALE_FACTOR * interval if known else None, crossing_at, int(warn_fixed),
            max(tops) if tops else None, _finite(row.warning_level), row.parameter_set,
            then, now, _planned_date(row.planned_maintenance) if row.acknowledged else '',
            None if then is None or now is None else now - then)


#: What a state asks of a row's stable parts beyond the alarms (the index ``joint_summary_state``
#: serves it in the fleet's order); the stale bound is ``now`` + 1 s.
_STABLE_PARTS = {
    'cannot judge': (" AND state_base = 'cannot judge'", ()),
    'stale': (' AND stale_at_s < ?', ()),
    'warning': (" AND state_base = 'judged'", ()),
    'new life': (" AND state_base = 'new life'", ()),
    'ok': (" AND state_base = 'judged' AND warn_fixed = 0", ()),
}


def _guess(base: str, warn_fixed: int) -> str:
    """Return a joint's state as its stable parts tell it (the clock and settings aside)."""
    if base == 'judged':
        return 'warning' if warn_fixed else 'ok'
    return base


def _within_tier(row: tuple[Any, ...]) -> tuple[Any, ...]:
    """Return the order of a row of :meth:`FleetIndex._ordered` within its tier."""
    return row[1:]


_UPDATE = ('UPDATE joint_summary SET ' + ', '.join(f'{c} = ?' for c in KEY_COLUMNS)
           + ' WHERE robot = ? AND joint = ?')


def refresh(backend: HistoryBackend, *, robot: str, joint: str) -> None:
    """
    Store the ranking keys of (robot, joint) anew (in the caller's open transaction).

    The joint is read in one query, two on SQLite (:func:`fleet_keys.read_joint`); only the
    keys that changed are written (:func:`fleet_keys.store_changed`), and the robot is listed
    only with the joint's first estimate (estimates are never deleted, so a joint with more
    was listed by an earlier one or by the migration).
    """
    state = fleet_keys.read_joint(backend, robot=robot, joint=joint,
                                  stored_columns=KEY_COLUMNS)
    if state is None:
        return
    fleet_keys.store_changed(backend, robot=robot, joint=joint, columns=KEY_COLUMNS,
                             values=stored_keys(state.row), stored=state.stored)
    if state.experiments <= 1:
        backend.execute('INSERT INTO fleet_robots (robot) VALUES (?) ON CONFLICT (robot) '
                        'DO NOTHING', (robot,))


def rebuild(backend: HistoryBackend) -> int:
    """Store the ranking keys of every joint (the migration, a bulk load); return how many."""
    rows = read_fleet(backend)
    fleet_counts.pause(backend)  # counted at once below, not row by row
    backend.executemany(_UPDATE, [(*stored_keys(r), r.robot, r.joint) for r in rows])
    backend.execute('DELETE FROM fleet_robots')
    backend.execute('INSERT INTO fleet_robots (robot) SELECT DISTINCT robot FROM joint_summary')
    fleet_counts.recount(backend)  # the migration's steps come first: the table exists
    fleet_counts.pause(backend, paused=False)
    return len(rows)


@dataclass(frozen=True)
class FleetClock:
    """
    What the query decides at ``now_s``: the parts of a state that move with the clock.

    ``now_s`` [s since the epoch]; ``margin``: the re-escalation margin [wear units];
    ``horizon_s``: a crossing this soon is a warning [s]; ``assumed_warning``: the warning
    level [w] of each parameter set named by rows that store none (an older history), and
    ``default_warning`` for a name not given.
    """

    now_s: float
    margin: float
    horizon_s: float
    assumed_warning: dict[str, float] = field(default_factory=dict)
    default_warning: float = math.nan

    @property
    def today(self) -> str:
        """Return the UTC date of ``now_s`` as 'YYYY-MM-DD' (planned dates before it passed)."""
        return datetime.datetime.fromtimestamp(self.now_s, tz=datetime.timezone.utc).date(
        ).isoformat()

    def reescalated_sql(self) -> tuple[str, tuple]:
        """Return the SQL of an acknowledged alarm re-escalated at ``now_s``, and its values."""
        return ("(ack_now >= ack_then + ? OR (planned_date <> '' AND planned_date < ?))",
                (float(self.margin), self.today))

    def warning_sql(self) -> tuple[str, tuple]:
        """Return the SQL of a judged row's warning at ``now_s`` (stale aside), its values."""
        levels = [(name, level) for name, level in sorted(self.assumed_warning.items())
                  if math.isfinite(level)]
        level_sql = ' '.join('WHEN ? THEN ?' for _ in levels)
        assumed = (f'CASE parameter_set {level_sql} ELSE ? END' if levels else '?')
        default = self.default_warning if math.isfinite(self.default_warning) else None
        return (f'(warn_fixed = 1 OR (warning_level IS NULL AND wear_top >= {assumed}) OR '
                'crossing_at_s - ? <= ?)',
                (*(v for pair in levels for v in pair), default, float(self.now_s),
                 float(self.horizon_s)))

    def state_sql(self) -> tuple[str, tuple]:
        """Return the SQL of a row's ``state`` at ``now_s`` (one of the states), its values."""
        reescalated, reescalated_params = self.reescalated_sql()
        warning, warning_params = self.warning_sql()
        sql = ("CASE WHEN state_base = 'alarm' THEN 'alarm' "
               f"WHEN state_base = 'acknowledged' THEN CASE WHEN {reescalated} THEN 'alarm' "
               "ELSE 'acknowledged' END "
               "WHEN state_base = 'cannot judge' THEN 'cannot judge' "
               'WHEN usual_interval_s > 0 AND ? - stale_since_s > ? * usual_interval_s '
               "THEN 'stale' "
               f"WHEN state_base = 'judged' AND {warning} THEN 'warning' "
               "WHEN state_base = 'new life' THEN 'new life' ELSE 'ok' END")
        params = (*reescalated_params, float(self.now_s), STALE_FACTOR, *warning_params)
        return sql, params


class FleetIndex:
    """
    The fleet read through its stored keys: a page, a filter, one robot, the counts.

    Made by :meth:`WearHistory.fleet_index`; ``guard`` turns the backend's errors into
    :class:`~robot_wear_monitor.history.records.HistoryError`.
    """

    def __init__(self, backend: HistoryBackend,
                 guard: Callable[[str], AbstractContextManager[None]]) -> None:
        """Read through ``backend``."""
        self._backend = backend
        self._guard = guard
        collate = ' COLLATE "C"' if backend.kind == 'postgresql' else ''
        #: the order within a tier, as in :meth:`FleetRow.rank_key` (names by code point)
        self._order = f'rank_crossing, rank_high, robot{collate}, joint{collate}'

    def _execute(self, sql: str, params: Sequence[Any] = ()) -> list[tuple[Any, ...]]:
        with self._guard('cannot read the fleet'):
            return self._backend.execute(sql, tuple(params))

    # ------------------------------------------------------------------ the order

    def _segments(self, clock: FleetClock, *, robot: Optional[str], state: Optional[str]
                  ) -> list[tuple[str, tuple]]:
        """
        Return the conditions of the order's segments (the first two merged), worst first.

        With a ``state``, the segments that cannot hold it read nothing (``1 = 0``); the
        alarms' segments hold only their own state (an unacknowledged or a re-escalated alarm
        is 'alarm', an acknowledged one not re-escalated 'acknowledged'), so only the rest is
        judged by the query's ``state``, after keeping the rows whose stable parts allow it
        (an index's prefix).
        """
        reescalated, rp = clock.reescalated_sql()
        where, params = '', ()  # type: tuple[str, tuple[Any, ...]]
        if robot is not None:
            where, params = ' AND robot = ?', (robot,)
        rest, rest_params = where, params
        if state is not None:
            state_sql, sp = clock.state_sql()
            stable, stable_params = _STABLE_PARTS.get(state, ('', ()))  # type: str, tuple
            if stable == ' AND stale_at_s < ?':
                stable_params = (clock.now_s + 1.0,)
            rest = f'{stable}{where} AND ({state_sql}) = ?'
            rest_params = (*stable_params, *params, *sp, state)
        top = '' if state in (None, 'alarm') else ' AND 1 = 0'
        middle = '' if state in (None, 'acknowledged') else ' AND 1 = 0'
        last = ' AND 1 = 0' if state in ('alarm', 'acknowledged') else ''
        return [(f'rank_tier = 0{top}{where}', params), (f'{top}{where}', params),
                (f'rank_tier = 1{middle} AND NOT {reescalated}{where}', (*rp, *params)),
                (f'rank_tier >= 2{last}{rest}', rest_params)]

    def _reescalated_rows(self, clock: FleetClock, where: str,
                          params: tuple) -> list[tuple[Any, ...]]:
        """
        Return the re-escalated acknowledged alarms (that pass ``where``), in order.

        Found by the indexes of the wear's rise since the acknowledgement (``ack_rise``, a
        margin a hair lower: the exact test follows) and of the planned dates.
        """
        reescalated, rp = clock.reescalated_sql()
        margin = float(clock.margin)
        select = ('SELECT rank_tier, rank_crossing, rank_high, robot, joint FROM joint_summary '
                  'WHERE ')
        rows = self._execute(
            f'{select}ack_rise >= ? AND {reescalated}{where} UNION '
            f"{select}planned_date > '' AND planned_date < ? AND {reescalated}{where}",
            (margin - 1e-9 * max(1.0, abs(margin)), *rp, *params, clock.today, *rp, *params))
        return sorted(rows, key=_within_tier)

    def _ordered(self, condition: str, params: tuple, *, offset: int = 0,
                 limit: Optional[int] = None,
                 after: Optional[tuple[Any, ...]] = None) -> list[tuple[Any, ...]]:
        """Return (tier, crossing, high, robot, joint) of the rows in order (after ``after``)."""
        if after is not None:
            condition += f' AND (rank_tier, {self._order}) > (?, ?, ?, ?, ?)'
            params = (*params, *after)
        return self._execute(
            f'SELECT rank_tier, rank_crossing, rank_high, robot, joint FROM joint_summary '
            f'WHERE {condition} ORDER BY rank_tier, {self._order} LIMIT ? OFFSET ?',
            (*params, _NO_LIMIT if limit is None else int(limit), int(offset)))

    def _count(self, condition: str, params: tuple) -> int:
        return int(self._execute(f'SELECT COUNT(*) FROM joint_summary WHERE {condition}',
                                 params)[0][0])

    def page(self, clock: FleetClock, *, robot: Optional[str] = None,
             state: Optional[str] = None, offset: int = 0,
             limit: Optional[int] = None) -> list[tuple[str, str]]:
        """
        Return (robot, joint) of the rows ``offset`` to ``offset + limit`` in the fleet's order.

        ``robot``: that robot's joints; ``state``: the joints in that state at ``clock``;
        ``limit`` None: every row from ``offset``.
        """
        segments = self._segments(clock, robot=robot, state=state)
        wanted = _NO_LIMIT if limit is None else int(limit)
        out: list[tuple[str, str]] = []
        # the unacknowledged alarms merged with the re-escalated acknowledged ones (few)
        top = self._ordered(*segments[0], limit=offset + wanted)
        back = self._reescalated_rows(clock, *segments[1])
        merged = list(heapq.merge(top, back, key=_within_tier))[offset:offset + wanted]
        out += [(r[3], r[4]) for r in merged]
        skip = max(0, offset - len(top) - len(back))
        if len(top) < offset + wanted:  # all of the first segment read
            for condition, params in segments[2:]:
                if len(out) >= wanted:
                    break
                rows = self._ordered(condition, params, offset=skip, limit=wanted - len(out))
                out += [(r[3], r[4]) for r in rows]
                if rows:  # the skipped rows were this segment's
                    skip = 0
                elif skip:  # all of this segment skipped: its rows counted (a deep page)
                    skip = max(0, skip - self._count(condition, params))
        return out

    def iterate(self, clock: FleetClock, *, robot: Optional[str] = None,
                state: Optional[str] = None,
                chunk: int = CHUNK_ROWS) -> Iterator[list[tuple[str, str]]]:
        """
        Yield (robot, joint) of every chosen row in the fleet's order, ``chunk`` at a time.

        Each segment is read by its index from where the last chunk ended (keyset), so that
        streaming the whole fleet reads each row once.
        """
        segments = self._segments(clock, robot=robot, state=state)

        def stream(condition: str, params: tuple) -> Iterator[tuple[Any, ...]]:
            after = None
            while True:
                rows = self._ordered(condition, params, limit=chunk, after=after)
                yield from rows
                if len(rows) < chunk:
                    return
                after = rows[-1]

        ordered = itertools.chain(
            heapq.merge(stream(*segments[0]), self._reescalated_rows(clock, *segments[1]),
                        key=_within_tier),
            stream(*segments[2]), stream(*segments[3]))
        while True:
            keys = [(r[3], r[4]) for r in itertools.islice(ordered, chunk)]
            if not keys:
                return
            yield keys

    def total(self, clock: FleetClock, *, robot: Optional[str] = None,
              state: Optional[str] = None) -> int:
        """Return how many rows pass the filters (one query)."""
        where, params = ['1 = 1'], ()  # type: list[str], tuple[Any, ...]
        if robot is not None:
            where, params = where + ['robot = ?'], (robot,)
        if state is not None:
            state_sql, sp = clock.state_sql()
            where, params = where + [f'({state_sql}) = ?'], (*params, *sp, state)
        return self._count(' AND '.join(where), params)

    def counts(self, clock: FleetClock) -> dict[str, int]:
        """
        Return the joints per state at ``clock`` (every state, 0 when none).

        The stable guess of every joint read from the counts kept on write
        (``fleet_state_counts``, :mod:`~robot_wear_monitor.history.fleet_counts`), then the
        joints the clock or the settings move, by index ranges: the re-escalated acknowledged
        alarms; the stale joints (counted per stable state where the moment is more than a
        second past, judged exactly within a second of ``now``); the calm judged joints
        warned by a forecast crossing within the horizon (counted likewise, judged exactly
        within a second of the horizon's end) or by an older row's assumed level (judged
        exactly).  The ranges the exact judgments read are disjoint, and none holds a joint
        counted by the others.
        """
        counts = dict.fromkeys(STATE_WORDS, 0)
        for base, fixed, count in fleet_counts.stable_counts(self._backend):
            counts[_guess(base, fixed)] += count
        moved = len(self._reescalated_rows(clock, '', ()))
        counts['acknowledged'] -= moved
        counts['alarm'] += moved
        past, soon = clock.now_s - 1.0, clock.now_s + 1.0  # [s] surely past; surely not yet
        near_in, near_out = past + clock.horizon_s, soon + clock.horizon_s
        # surely stale: a count per stable state (the index joint_summary_stale_state), in
        # one statement of an index range each
        groups = (('judged', 0), ('judged', 1), ('new life', 0), ('new life', 1))
        stale = self._execute(' UNION ALL '.join(
            f'SELECT {number}, COUNT(*) FROM joint_summary WHERE state_base = ? AND '
            'warn_fixed = ? AND stale_at_s < ?' for number in range(len(groups))),
            tuple(v for base, fixed in groups for v in (base, fixed, past)))
        for number, count in stale:
            counts[_guess(*groups[int(number)])] -= int(count)
            counts['stale'] += int(count)
        # surely warned by a crossing within the horizon, surely not stale
        calm = "state_base = 'judged' AND warn_fixed = 0 AND (stale_at_s IS NULL OR " \
               'stale_at_s >= ?)'
        count = self._count(f'{calm} AND crossing_at_s < ?', (soon, near_in))
        counts['ok'] -= count
        counts['warning'] += count
        # judged exactly: near the stale moment; near the horizon's end; an assumed level
        state_sql, sp = clock.state_sql()
        guess = ("CASE WHEN state_base = 'judged' THEN CASE WHEN warn_fixed = 1 THEN 'warning' "
                 "ELSE 'ok' END ELSE state_base END")
        unsure = (("state_base || '' IN ('judged', 'new life') AND stale_at_s >= ? AND "
                   'stale_at_s < ?', (past, soon)),
                  (f'{calm} AND crossing_at_s >= ? AND crossing_at_s <= ?',
                   (soon, near_in, near_out)),
                  (f'{calm} AND (crossing_at_s IS NULL OR crossing_at_s > ?) AND '
                   'warning_level IS NULL', (soon, near_out)))
        for condition, params in unsure:
            for was, now, count in self._execute(
                    f'SELECT {guess} AS g, {state_sql} AS s, COUNT(*) FROM joint_summary '
                    f'WHERE {condition} GROUP BY g, s', (*sp, *params)):
                counts[was] -= int(count)
                counts[now] += int(count)
        return counts

    def next_times(self, clock: FleetClock) -> tuple[Any, ...]:
        """
        Return the next stored times ``clock`` will pass (index lookups; an ETag's part).

        The first stale moment, crossing date (and crossing date past the horizon) and
        planned date not yet passed: with the history's rows unchanged, the fleet at two
        moments is the same while these are (none lies between them).
        """
        out: list[Any] = []
        for column, condition, bound in (
                ('stale_at_s', 'stale_at_s >= ?', clock.now_s),
                ('crossing_at_s', 'crossing_at_s >= ?', clock.now_s),
                ('crossing_at_s', 'crossing_at_s > ?', clock.now_s + clock.horizon_s),
                ('planned_date', 'planned_date >= ?', clock.today)):
            out.append(self._execute(f'SELECT MIN({column}) FROM joint_summary WHERE '
                                     f'{condition}', (bound,))[0][0])
        return tuple(out)

    # ------------------------------------------------------------------ robots, levels

    def reescalated(self, clock: FleetClock) -> list[tuple[str, str]]:
        """Return the acknowledged alarms re-escalated at ``clock`` (few; for their log)."""
        return [(r[3], r[4]) for r in self._reescalated_rows(clock, '', ())]

    def assumed_sets(self) -> list[str]:
        """Return the parameter sets of the rows that store no warning level (older rows)."""
        return [r[0] for r in self._execute(
            'SELECT DISTINCT parameter_set FROM joint_summary WHERE warning_level IS NULL')]

    def robots(self, *, search: str = '', limit: Optional[int] = None) -> list[str]:
        """
        Return the robots whose name holds ``search`` (case-insensitive), sorted; prefix first.

        At most ``limit``: the robots that start with it (an index range), then those that
        hold it elsewhere.
        """
        text = search.lower()
        limit_value = _NO_LIMIT if limit is None else int(limit)
        if not text:
            return [r[0] for r in self._execute(
                'SELECT robot FROM fleet_robots ORDER BY robot LIMIT ?', (limit_value,))]
        pattern = text.replace('\\', '\\\\').replace('%', '\\%').replace('_', '\\_')
        found = [r[0] for r in self._execute(
            "SELECT robot FROM fleet_robots WHERE LOWER(robot) LIKE ? ESCAPE '\\' "
            'ORDER BY robot', (f'%{pattern}%',))]
        found.sort(key=lambda name: (not name.lower().startswith(text), name))
        return found[:limit_value]

    def robot_count(self) -> int:
        """Return how many robots the fleet holds."""
        return int(self._execute('SELECT COUNT(*) FROM fleet_robots')[0][0])

    def has_robot(self, robot: str) -> bool:
        """Return whether the history holds estimates of ``robot`` (the primary key)."""
        return bool(self._execute('SELECT 1 FROM joint_summary WHERE robot = ? LIMIT 1',
                                  (robot,)))

    def joint_count(self) -> int:
        """Return how many joints the fleet holds."""
        return int(self._execute('SELECT COUNT(*) FROM joint_summary')[0][0])

    def rows(self, keys: Sequence[tuple[str, str]]) -> list[FleetRow]:
        """Return the fleet rows of ``keys`` (a page), worst first."""
        if not keys:
            return []
        with self._guard('cannot read the fleet'):
            return read_fleet(self._backend, keys=keys)

    # ------------------------------------------------------------------ what changed

    def marks(self) -> tuple[int, int]:
        """Return the ids of the newest estimate and alarm event (0 when none)."""
        rows = self._execute('SELECT (SELECT MAX(id) FROM estimates), '
                             '(SELECT MAX(id) FROM alarm_events)')
        return int(rows[0][0] or 0), int(rows[0][1] or 0)

    def changed(self, *, estimate_mark: int, event_mark: int) -> set[tuple[str, str]]:
        """Return the joints with an estimate or an alarm event stored after the marks (ids)."""
        rows = self._execute('SELECT robot, joint FROM joint_summary WHERE last_id > ?',
                             (int(estimate_mark),))
        rows += self._execute('SELECT DISTINCT robot, joint FROM alarm_events WHERE id > ?',
                              (int(event_mark),))
        return {(r[0], r[1]) for r in rows}

    def clock_moved(self, *, since_s: float, now_s: float,
                    horizon_s: float) -> set[tuple[str, str]]:
        """
        Return the joints whose state the clock may have moved between ``since_s`` and now.

        Those that went stale, whose forecast crossing came within ``horizon_s`` [s] or
        passed, whose planned maintenance date passed: index ranges of the stored times.
        """
        def day(stamp: float) -> str:
            return datetime.datetime.fromtimestamp(stamp, tz=datetime.timezone.utc).date(
            ).isoformat()

        slack = 1.0  # [s]: the query's own comparisons are exact; these only choose the joints
        ranges = (('stale_at_s', since_s, now_s), ('crossing_at_s', since_s, now_s),
                  ('crossing_at_s', since_s + horizon_s, now_s + horizon_s))
        rows = []
        for column, begin, end in ranges:
            rows += self._execute(f'SELECT robot, joint FROM joint_summary WHERE {column} > ? '
                                  f'AND {column} <= ?', (begin - slack, end + slack))
        rows += self._execute("SELECT robot, joint FROM joint_summary WHERE planned_date <> '' "
                              'AND planned_date >= ? AND planned_date < ?',
                              (day(since_s), day(now_s)))
        return {(r[0], r[1]) for r in rows}
