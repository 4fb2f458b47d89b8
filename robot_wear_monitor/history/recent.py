"""
The recent experiment stamps of every joint, for an interval an outage does not stretch.

The usual interval of a joint (:attr:`FleetRow.usual_interval_s`) is the median of its last
:data:`RECENT_INTERVALS` intervals: a nine-day outage in an hourly rhythm is one interval among
twenty and leaves the median at an hour, where the mean of every interval grew to hours (the
stale limit and the forecast crossing's date with it).  One query for the fleet, each joint's
rows found by the (robot, joint, id) index.
"""

from __future__ import annotations

from robot_wear_monitor.history.backends import HistoryBackend

#: The intervals the usual interval is the median of (the last ones of the joint, all lives).
RECENT_INTERVALS = 20


def recent_stamps(backend: HistoryBackend, *, where: str = '', params: tuple = (),
                  source: str = 'joint_summary s', with_sql: str = ''
                  ) -> dict[tuple[str, str], tuple[float, ...]]:
    """
    Return per (robot, joint) the stamps [s] of its last experiments, oldest first.

    ``where``: '' (every joint) or 'WHERE ...' on ``joint_summary s`` with its ``params``;
    ``source``: the joints read (``joint_summary s``, or a list ``k`` joined to it, given by
    ``with_sql``: ``WITH k(robot, joint) AS (VALUES ...)``).
    """
    if backend.kind == 'postgresql':  # each joint's last rows by the index (a lateral join)
        rows = backend.execute(
            f'{with_sql} SELECT s.robot, s.joint, e.stamp_s FROM {source} CROSS JOIN LATERAL '
            '(SELECT x.stamp_s FROM estimates x WHERE x.robot = s.robot AND x.joint = s.joint '
            f'ORDER BY x.id DESC LIMIT {RECENT_INTERVALS + 1}) e ' + where, params)
    else:
        rows = backend.execute(
            f'{with_sql} SELECT s.robot, s.joint, e.stamp_s FROM {source} JOIN estimates e ON '
            'e.id IN (SELECT x.id FROM estimates x WHERE x.robot = s.robot AND '
            f'x.joint = s.joint ORDER BY x.id DESC LIMIT {RECENT_INTERVALS + 1}) ' + where,
            params)
    found: dict[tuple[str, str], list[float]] = {}
    for r in rows:
        found.setdefault((r[0], r[1]), []).append(float(r[2]))
    return {key: tuple(sorted(stamps)) for key, stamps in found.items()}
