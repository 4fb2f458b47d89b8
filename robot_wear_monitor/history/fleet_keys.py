"""
One joint's state as its fleet ranking keys need it, read cheaply inside a write's transaction.

Every estimate (:meth:`WearHistory.append`) and every alarm event stores the joint's ranking
keys anew (:func:`~robot_wear_monitor.history.fleet_index.refresh`).  The generic
:func:`~robot_wear_monitor.history.fleet_rows.read_fleet` reads them in seven queries (six and
the recent stamps); a write needs one joint only, so :func:`read_joint` reads it in one query
on PostgreSQL (two on SQLite, where a query costs no round trip), by the primary keys and the
joint's indexes:

1. the joint's ``joint_summary`` row (its count, first stamp, the keys stored now), its latest
   estimate, and its last latch (raise or reset), last acknowledgement or edit or withdrawal,
   and last acknowledgement itself (the re-escalation's baseline), with the trend of the
   estimates those are tied to (PostgreSQL: lateral joins, each the joint's first row of the
   kinds read backwards);
2. the stamps of its last experiments (the usual interval, :mod:`recent`; on PostgreSQL an
   array in the same query).

:func:`store_changed` then writes only the keys that changed.

The row is made by the same function as ``read_fleet``'s (:func:`fleet_rows.fleet_row`), so
the keys are those a rebuild stores.  One thing is not read: the count of experiments of a
new life (a range count over the life's estimates); the keys only ask whether the life has an
experiment yet, which the latest estimate's id against the reset's tells, so the row's
``experiments`` is that count only when it is 0 and 1 for any other count (the row stays in
this module and its caller).
"""

from __future__ import annotations

from dataclasses import dataclass, replace
import functools
from typing import Any, Optional, Sequence

from robot_wear_monitor.history.backends import HistoryBackend
from robot_wear_monitor.history.fleet_rows import fleet_row
from robot_wear_monitor.history.recent import RECENT_INTERVALS
from robot_wear_monitor.history.records import ACKNOWLEDGEMENT_EVENTS, FleetRow

#: The latest estimate's columns, in the order :func:`fleet_rows.fleet_row` reads them.
_LATEST = ('e.robot, e.joint, s.experiments, s.first_stamp_s, e.stamp_s, e.wall_time_s, '
           'e.wear, e.wear_std, e.wear_low, e.wear_high, e.trend_wear, e.trend_low, '
           'e.trend_high, e.crossing_experiments, e.crossing_time_s, e.alarm_evidence, '
           'e.status_level, e.parameter_set, e.invalid_reason, e.id, e.threshold, '
           'e.warning_level')
_LATEST_WIDTH = 22
#: The joint's last stamps, newest first (``recent.recent_stamps`` of one joint).
_STAMPS_SQL = ('SELECT stamp_s FROM estimates WHERE robot = ? AND joint = ? ORDER BY id DESC '
               f'LIMIT {RECENT_INTERVALS + 1}')
#: The events read: the latch (the last raise or reset), the last acknowledgement (or its edit
#: or withdrawal), the last acknowledgement itself (the re-escalation's baseline); of each,
#: the columns :func:`fleet_rows.fleet_row` reads, ``t.trend_wear`` that of its estimate.
_EVENT_READS = (
    ('l', ('raised', 'reset'), 'a.event, a.stamp_s, a.id, a.estimate_id, a.user_name, a.note, '
     'a.wall_time_s'),
    ('k', ACKNOWLEDGEMENT_EVENTS, 'a.id, a.user_name, a.wall_time_s, a.planned_maintenance, '
     'a.wear, t.trend_wear, a.event'),
    ('b', ('acknowledged',), 'a.id, a.wall_time_s, a.wear, t.trend_wear, a.user_name'))


def _kinds(kinds: Sequence[str]) -> str:
    return ', '.join(f"'{k}'" for k in kinds)


def _lateral_events() -> tuple[str, str]:
    """
    Return PostgreSQL's select list and joins of the events (a lateral join each).

    Each is the joint's first row by the index ``(robot, joint, id)`` read backwards.
    """
    joins = ''.join(
        f' LEFT JOIN LATERAL (SELECT {columns} FROM alarm_events a LEFT JOIN estimates t ON '
        't.id = a.estimate_id WHERE a.robot = s.robot AND a.joint = s.joint AND '
        f'a.event IN ({_kinds(kinds)}) ORDER BY a.id DESC LIMIT 1) {alias} ON TRUE'
        for alias, kinds, columns in _EVENT_READS)
    return ''.join(f', {alias}.*' for alias, _, _ in _EVENT_READS), joins


def _max_id_events() -> tuple[str, str]:
    """Return SQLite's select list and joins of the events (each the joint's largest id)."""
    select, joins = '', ''
    for alias, kinds, columns in _EVENT_READS:
        select += ', ' + columns.replace('a.', f'{alias}.').replace('t.', f'{alias}t.')
        joins += (f' LEFT JOIN alarm_events {alias} ON {alias}.id = (SELECT MAX(x.id) FROM '
                  'alarm_events x WHERE x.robot = s.robot AND x.joint = s.joint AND '
                  f'x.event IN ({_kinds(kinds)})) LEFT JOIN estimates {alias}t ON '
                  f'{alias}t.id = {alias}.estimate_id')
    return select, joins


@functools.lru_cache(maxsize=8)
def _state_sql(kind: str, stored_columns: tuple[str, ...]) -> str:
    """
    Return the query of a joint's state (made once: a write runs it every time).

    On PostgreSQL the last stamps come with it as an array (one round trip to the server);
    SQLite reads them apart (:data:`_STAMPS_SQL`, in-process).
    """
    select, joins = _lateral_events() if kind == 'postgresql' else _max_id_events()
    if kind == 'postgresql':
        select += (', ARRAY(SELECT x.stamp_s FROM estimates x WHERE x.robot = s.robot AND '
                   f'x.joint = s.joint ORDER BY x.id DESC LIMIT {RECENT_INTERVALS + 1})')
    stored_sql = ''.join(f', s.{c}' for c in stored_columns)
    return (f'SELECT {_LATEST}{select}{stored_sql} FROM joint_summary s '
            f'JOIN estimates e ON e.id = s.last_id{joins} WHERE s.robot = ? AND s.joint = ?')


@dataclass(frozen=True)
class JointState:
    """
    One joint's fleet row (as far as its keys need it) and the keys stored with it now.

    ``stored``: the values of the asked ``joint_summary`` columns, in their order;
    ``experiments``: the joint's stored estimates, all lives (``joint_summary.experiments``).
    """

    row: FleetRow
    stored: tuple[Any, ...]
    experiments: int


def read_joint(backend: HistoryBackend, *, robot: str, joint: str,
               stored_columns: Sequence[str] = ()) -> Optional[JointState]:
    """
    Return the state of (robot, joint) in one query (two on SQLite); None when it has no estimate.

    ``stored_columns``: the columns of its ``joint_summary`` row to return as they are now.
    """
    rows = backend.execute(_state_sql(backend.kind, tuple(stored_columns)), (robot, joint))
    if not rows:
        return None
    r = rows[0]
    latest = r[:_LATEST_WIDTH]
    latch, ack, baseline = r[22:29], r[29:36], r[36:41]
    if backend.kind == 'postgresql':
        stamps, stored = r[41], r[42:]
    else:
        stamps, stored = [s[0] for s in backend.execute(_STAMPS_SQL, (robot, joint))], r[41:]
    row = fleet_row(latest, latch if latch[2] is not None else None,
                    ack if ack[0] is not None else None, 1,
                    baseline if baseline[0] is not None else None)
    row = replace(row, recent_stamps=tuple(sorted(float(s) for s in stamps)))
    return JointState(row=row, stored=tuple(stored), experiments=int(latest[2]))


def store_changed(backend: HistoryBackend, *, robot: str, joint: str,
                  columns: Sequence[str], values: Sequence[Any],
                  stored: Sequence[Any]) -> int:
    """
    Set those of the joint's ``joint_summary`` ``columns`` that changed; return how many.

    ``values`` the new, ``stored`` the present ones, in the order of ``columns``.  Only the
    indexes of the changed columns are written (SQLite skips an index none of whose columns
    is set): an estimate of a joint in a steady state moves its stale time and top wear, not
    its rank.
    """
    changed = [(c, v) for c, v, old in zip(columns, values, stored) if v != old]
    if changed:
        backend.execute('UPDATE joint_summary SET ' + ', '.join(f'{c} = ?' for c, _ in changed)
                        + ' WHERE robot = ? AND joint = ?',
                        (*(v for _, v in changed), robot, joint))
    return len(changed)
