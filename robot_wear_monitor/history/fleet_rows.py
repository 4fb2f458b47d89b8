"""
The fleet's rows read from the history: one :class:`FleetRow` per robot joint.

:func:`read_fleet` reads the latest state of every joint (or of one robot's, or of a list of
joints: a page of the fleet, :mod:`~robot_wear_monitor.history.fleet_index`) in a fixed number
of queries whatever the fleet's size: the latest estimate and the count per (robot, joint)
(``joint_summary``: one row per joint, not a scan of the estimates), the last raise or reset
per (robot, joint) (the latch), the last acknowledgement per (robot, joint) and, for the
joints whose latch is a reset, the estimates of the new life (those after the estimate the
reset is tied to, :func:`~robot_wear_monitor.history.alarms.reset_alarm`): a joint reset after
maintenance shows its new life only (see :class:`FleetRow`).
"""

from __future__ import annotations

from dataclasses import replace
import math
from typing import Any, Optional, Sequence

from robot_wear_monitor.history import recent
from robot_wear_monitor.history.backends import HistoryBackend
from robot_wear_monitor.history.records import ACKNOWLEDGEMENT_SQL, FleetRow, LATCH_EVENTS


#: Joints per query of the new lives' experiments (three values each, under SQLite's limit).
_RESETS_PER_QUERY = 1000


def _nan_if_none(value: Optional[float]) -> float:
    return math.nan if value is None else float(value)


def _last_event(kind_sql: str, *, keyed: bool, event_where: str) -> str:
    """Return the join of each joint's last alarm event of a kind (``a.id = l.last_id``)."""
    if keyed:  # per listed joint: an index lookup of its own events
        return ('(SELECT (SELECT MAX(x.id) FROM alarm_events x WHERE x.robot = k.robot AND '
                f'x.joint = k.joint AND x.{kind_sql}) AS last_id FROM k) l ON a.id = l.last_id')
    return (f'(SELECT MAX(id) AS last_id FROM alarm_events WHERE {kind_sql} {event_where}'
            'GROUP BY robot, joint) l ON a.id = l.last_id')


def read_fleet(backend: HistoryBackend, *, robot: Optional[str] = None,
               joint: Optional[str] = None,
               keys: Optional[Sequence[tuple[str, str]]] = None) -> list[FleetRow]:
    """
    Return the latest state of the chosen joints, worst first (:meth:`FleetRow.rank_key`).

    ``robot`` keeps one robot's joints (all robots when None), with ``joint`` one joint;
    ``keys`` keeps those (robot, joint) pairs (a page: each read by the indexes, whatever the
    fleet's size).  Six queries whatever their number.
    """
    with_sql, source, where, event_where = '', 'joint_summary s', '', ''
    params: tuple = ()
    if keys is not None:
        pairs = list(keys) or [('', '')]
        with_sql = ('WITH k(robot, joint) AS (VALUES '
                    + ', '.join('(?, ?)' for _ in pairs) + ') ')
        source = 'k JOIN joint_summary s ON s.robot = k.robot AND s.joint = k.joint'
        params = tuple(v for pair in pairs for v in pair)
    elif robot is not None:
        where, event_where, params = 'WHERE s.robot = ? ', 'AND robot = ? ', (robot,)
        if joint is not None:
            where += 'AND s.joint = ? '
            event_where += 'AND joint = ? '
            params += (joint,)
    keyed = keys is not None
    last_latch = _last_event(LATCH_EVENTS, keyed=keyed, event_where=event_where)
    latest = backend.execute(
        f'{with_sql}SELECT e.robot, e.joint, s.experiments, s.first_stamp_s, e.stamp_s, '
        'e.wall_time_s, e.wear, e.wear_std, e.wear_low, e.wear_high, e.trend_wear, '
        'e.trend_low, e.trend_high, e.crossing_experiments, e.crossing_time_s, '
        'e.alarm_evidence, e.status_level, e.parameter_set, e.invalid_reason, e.id, '
        'e.threshold, e.warning_level '
        f'FROM {source} JOIN estimates e ON e.id = s.last_id ' + where, params)
    latches = backend.execute(
        f'{with_sql}SELECT a.robot, a.joint, a.event, a.stamp_s, a.id, a.estimate_id, '
        'a.user_name, a.note, a.wall_time_s FROM alarm_events a JOIN ' + last_latch, params)
    acknowledgements = backend.execute(
        f'{with_sql}SELECT a.robot, a.joint, a.id, a.user_name, a.wall_time_s, '
        'a.planned_maintenance, a.wear, t.trend_wear, a.event FROM alarm_events a JOIN '
        + _last_event(ACKNOWLEDGEMENT_SQL, keyed=keyed, event_where=event_where)
        + ' LEFT JOIN estimates t ON t.id = a.estimate_id', params)
    # the acknowledgement itself (not an edit): the baseline of the re-escalation
    baselines = backend.execute(
        f'{with_sql}SELECT a.robot, a.joint, a.id, a.wall_time_s, a.wear, t.trend_wear, '
        'a.user_name FROM alarm_events a JOIN '
        + _last_event("event = 'acknowledged'", keyed=keyed, event_where=event_where)
        + ' LEFT JOIN estimates t ON t.id = a.estimate_id', params)
    # the experiments of each new life: only the joints whose latch is a reset (few), each
    # counted by the index from the estimate its reset is tied to
    resets = [(r[0], r[1], int(r[5] or 0)) for r in latches if r[2] == 'reset']
    lives = []
    for first in range(0, len(resets), _RESETS_PER_QUERY):
        part = resets[first:first + _RESETS_PER_QUERY]
        lives += backend.execute(
            'WITH r(robot, joint, after_id) AS (VALUES '
            + ', '.join('(?, ?, CAST(? AS BIGINT))' for _ in part) + ') '
            'SELECT r.robot, r.joint, COUNT(e.id) FROM r JOIN estimates e ON '
            'e.robot = r.robot AND e.joint = r.joint AND e.id > r.after_id '
            'GROUP BY r.robot, r.joint', tuple(v for reset in part for v in reset))
    stamps = recent.recent_stamps(backend, where=where, params=params, source=source,
                                  with_sql=with_sql)
    last_event = {(r[0], r[1]): r[2:] for r in latches}
    last_ack = {(r[0], r[1]): r[2:] for r in acknowledgements}
    baseline = {(r[0], r[1]): r[2:] for r in baselines}
    life_experiments = {(r[0], r[1]): int(r[2]) for r in lives}
    rows = [replace(fleet_row(r, last_event.get((r[0], r[1])), last_ack.get((r[0], r[1])),
                              life_experiments.get((r[0], r[1]), 0),
                              baseline.get((r[0], r[1]))),
                    recent_stamps=stamps.get((r[0], r[1]), ())) for r in latest]
    return sorted(rows, key=FleetRow.rank_key)


def fleet_row(r: Sequence[Any], latch: Optional[Sequence[Any]], ack: Optional[Sequence[Any]],
              life_experiments: int, baseline: Optional[Sequence[Any]] = None) -> FleetRow:
    """
    Return the :class:`FleetRow` of a joint's latest estimate, latch and acknowledgement.

    Who acknowledged, the planned date and the work order are the latest acknowledgement's or
    edit's; the time, the wear and the trend at acknowledgement (the re-escalation's baseline)
    are the acknowledgement's own (``baseline``): an edit does not move them.
    """
    event = latch[0] if latch is not None else ''
    raised = event == 'raised'
    # the last acknowledgement (or its edit) after the raise, unless it was withdrawn
    acknowledged = raised and latch is not None and ack is not None and \
        int(ack[0]) > latch[2] and ack[6] != 'acknowledgement_withdrawn'
    if acknowledged and ack is not None and baseline is not None and latch is not None and \
            int(ack[0]) >= int(baseline[0]) > latch[2]:
        # who acknowledged first and when; the last editor apart (``edited_by``)
        edited_by = ack[1] if ack[6] == 'acknowledgement_edited' else ''
        ack = (ack[0], baseline[4], baseline[1], ack[3], baseline[2], baseline[3], ack[6],
               edited_by)
    row = FleetRow(
        robot=r[0], joint=r[1], experiments=int(r[2]), first_stamp_s=float(r[3]),
        last_stamp_s=float(r[4]), last_wall_time_s=float(r[5]), wear=float(r[6]),
        wear_std=_nan_if_none(r[7]), wear_low=_nan_if_none(r[8]),
        wear_high=_nan_if_none(r[9]), trend_wear=_nan_if_none(r[10]),
        trend_low=_nan_if_none(r[11]), trend_high=_nan_if_none(r[12]),
        crossing_experiments=_nan_if_none(r[13]), crossing_time_s=_nan_if_none(r[14]),
        alarm=raised, alarm_since_stamp_s=float(latch[1]) if raised and latch else math.nan,
        alarm_evidence=float(r[15]), status_level=int(r[16]), parameter_set=r[17],
        invalid_reason=r[18] or '', acknowledged=acknowledged,
        acknowledged_by=ack[1] if acknowledged and ack else '',
        acknowledged_wall_time_s=float(ack[2]) if acknowledged and ack else math.nan,
        planned_maintenance=ack[3] if acknowledged and ack else '',
        acknowledged_wear=_nan_if_none(ack[4]) if acknowledged and ack else math.nan,
        acknowledged_trend_wear=_nan_if_none(ack[5]) if acknowledged and ack else math.nan,
        edited_by=ack[7] if acknowledged and ack and len(ack) > 7 else '',
        threshold=_nan_if_none(r[20]), warning_level=_nan_if_none(r[21]))
    if event != 'reset' or latch is None:
        return row
    # a reset: the joint's new life, from the estimate after the one the reset is tied to
    row = replace(row, life_started_s=float(latch[1]), reset_by=latch[4] or '',
                  reset_reason=latch[5] or '', total_experiments=int(r[2]),
                  experiments=life_experiments)
    if latch[3] is not None and int(r[19]) <= int(latch[3]):  # no experiment since the reset
        row = replace(row, wear=math.nan, wear_std=math.nan, wear_low=math.nan,
                      wear_high=math.nan, trend_wear=math.nan, trend_low=math.nan,
                      trend_high=math.nan, crossing_experiments=math.nan,
                      crossing_time_s=math.nan, alarm_evidence=0.0, status_level=0,
                      invalid_reason='', experiments=0)
    return row
