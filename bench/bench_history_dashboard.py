"""
The history queries of the dashboard on a large fleet: fleet(), one joint's rows, alarm log.

    python3 bench/bench_history_dashboard.py [--joints 1000] [--experiments 100000]
                                             [--long-joint 5000] [--repeat 7]
                                             [--no-postgresql]

Builds a history of ``--joints`` joints (10 robots) and ``--experiments`` estimates, the
joints' experiments interleaved in time as a fleet writes them (so one joint's rows are spread
over the whole table), one joint with ``--long-joint`` extra estimates, and alarm events on
one joint in ten (raised; some acknowledged, some reset and raised again).  The rows go in
with ``executemany`` in one transaction (through the history's layout, made by opening it;
``joint_summary``, which appends keep, is filled as the migration fills it).
Then prints the median time [ms] over ``--repeat`` runs (after one warm-up) of:

* ``fleet()``: the latest state of every joint, ranked;
* ``records(joint, limit=500)``: the last 500 estimates of the long joint, and of a usual one;
* ``alarm_log(limit=100)``: the fleet's newest 100 alarm events (and the next page).

Into SQLite (a file in a temporary folder) and a throw-away PostgreSQL server (``initdb`` /
``pg_ctl``; skipped with ``--no-postgresql`` or when absent).  Target: each < 100 ms on SQLite.
"""

import argparse
import json
from pathlib import Path
import statistics
import sys
import tempfile
import time
from typing import Any, Callable

from robot_wear_monitor.history import INTERVAL_COLUMNS, WearHistory
from robot_wear_monitor.history.migrations import JOINT_SUMMARY_REBUILD

HOUR_S = 3600.0
START_S = 1.75e9
ROBOTS = 10
_COLUMNS = ('robot', 'joint', 'stamp_s', 'wall_time_s', 'speeds_rad_s', 'frictions',
            'temperature_degc', 'temperature_std_degc', 'wear', 'wear_std', 'chi2', 'dof',
            'p_value', 'temperature_at_bound', 'wear_at_bound', 'alarm_active',
            'alarm_evidence', 'status_level', 'parameter_set', *INTERVAL_COLUMNS,
            'invalid_reason')


def _estimate(robot: str, joint: str, k: int, wear: float) -> tuple:
    speeds = json.dumps([2.1, 28.5, 35.1, 41.7])
    frictions = json.dumps([0.1 + wear / 500.0, 0.05, 0.06, 0.07])
    return (robot, joint, START_S + HOUR_S * k, START_S + HOUR_S * k, speeds, frictions,
            40.0, 2.0, wear, 2.5, 1.0, 2, 0.5, 0, 0, int(wear >= 35.0), 0.0, 0, 'kuka',
            wear - 5.0, wear + 5.0, 35.0, 45.0, wear, wear - 3.0, wear + 3.0,
            max(0.0, (35.0 - wear) / 0.3), 3600.0 * max(0.0, (35.0 - wear) / 0.3), '')


def fleet_rows(*, joints: int, experiments: int, long_joint: int):
    """Yield the estimates, interleaved in time, then the long joint's extra ones."""
    names = [(f'robot_{j % ROBOTS}', f'joint_{j // ROBOTS}') for j in range(joints)]
    per_joint = experiments // joints
    for k in range(per_joint):
        for j, (robot, joint) in enumerate(names):
            yield _estimate(robot, joint, k, wear=(j % 50) * k / per_joint)
    for k in range(per_joint, per_joint + long_joint):
        yield _estimate(*names[0], k, wear=20.0)


def alarm_events(*, joints: int) -> list[tuple]:
    """Return alarm events of one joint in ten: raised; every 3rd acknowledged, 5th reset."""
    events = []
    for i in range(0, joints, 10):
        j = i + (i // 10) % 10  # every robot has some
        robot, joint = f'robot_{j % ROBOTS}', f'joint_{j // ROBOTS}'
        stamp = START_S + HOUR_S * (j % 97)
        events.append((robot, joint, stamp, stamp, 'raised', 40.0, 'w above the threshold',
                       '', '', ''))
        if i % 30 == 0:
            events.append((robot, joint, stamp + 60, stamp + 60, 'acknowledged', 40.0,
                           'ordered', 'ana', 'ben', '2026-12-01'))
        if i % 50 == 0:
            events.append((robot, joint, stamp + 120, stamp + 120, 'reset', None,
                           'replaced', 'cy', '', ''))
            events.append((robot, joint, stamp + 180, stamp + 180, 'raised', 41.0,
                           'w above the threshold', '', '', ''))
    return events


def build(location: str, *, joints: int, experiments: int, long_joint: int) -> float:
    """Write the fleet into a new history at ``location``; return the seconds it took."""
    WearHistory(location).close()  # the layout, migrated to the current version
    start = time.perf_counter()
    insert = (f'INSERT INTO estimates ({", ".join(_COLUMNS)}) VALUES '
              f'({", ".join("?" * len(_COLUMNS))})')
    insert_event = ('INSERT INTO alarm_events (robot, joint, stamp_s, wall_time_s, event, '
                    'wear, note, user_name, owner, planned_maintenance) VALUES '
                    '(?, ?, ?, ?, ?, ?, ?, ?, ?, ?)')
    rows = fleet_rows(joints=joints, experiments=experiments, long_joint=long_joint)
    if location.startswith('postgresql'):
        import psycopg
        with psycopg.connect(location) as conn, conn.cursor() as cursor:
            cursor.executemany(insert.replace('?', '%s'), list(rows))
            cursor.executemany(insert_event.replace('?', '%s'), alarm_events(joints=joints))
            for step in JOINT_SUMMARY_REBUILD:  # what appends keep, made at once
                conn.execute(step)
        with psycopg.connect(location, autocommit=True) as conn:
            conn.execute('VACUUM ANALYZE')
    else:
        import sqlite3
        conn = sqlite3.connect(location)
        with conn:
            conn.executemany(insert, rows)
            conn.executemany(insert_event, alarm_events(joints=joints))
            for step in JOINT_SUMMARY_REBUILD:  # what appends keep, made at once
                conn.execute(step)
        conn.execute('ANALYZE')
        conn.close()
    return time.perf_counter() - start


def timed(call: Callable[[], Any], *, repeat: int) -> tuple[float, Any]:
    """Return (median time [ms] over ``repeat`` runs after one warm-up, the last result)."""
    result = call()
    times = []
    for _ in range(repeat):
        start = time.perf_counter()
        result = call()
        times.append(1e3 * (time.perf_counter() - start))
    return statistics.median(times), result


def measure(location: str, *, name: str, args: argparse.Namespace) -> None:
    """Build the history at ``location`` and print the query times."""
    seconds = build(location, joints=args.joints, experiments=args.experiments,
                    long_joint=args.long_joint)
    with WearHistory(location, init=False) as history:
        fleet_ms, fleet = timed(history.fleet, repeat=args.repeat)
        long_ms, long_rows = timed(lambda: history.records(joint='joint_0', robot='robot_0',
                                                           limit=500), repeat=args.repeat)
        usual_ms, usual_rows = timed(lambda: history.records(joint='joint_50', robot='robot_5',
                                                             limit=500), repeat=args.repeat)
        log_ms, log = timed(lambda: history.alarm_log(limit=100), repeat=args.repeat)
        page_ms, _ = timed(lambda: history.alarm_log(limit=100, before_id=log[-1].id),
                           repeat=args.repeat)
        robot_log_ms, _ = timed(lambda: history.alarm_log(robot='robot_3', limit=100),
                                repeat=args.repeat)
    if len(fleet) != args.joints or len(long_rows) != 500 or not log:
        raise SystemExit(f'bench: {len(fleet)} fleet rows, {len(long_rows)} long-joint rows')
    latched = sum(1 for row in fleet if row.alarm)
    acknowledged = sum(1 for row in fleet if row.acknowledged)
    print(f'{name}: {args.joints} joints, {args.experiments + args.long_joint} estimates '
          f'(built in {seconds:.1f} s); {latched} alarms latched, {acknowledged} acknowledged')
    print(f'  fleet()                               {fleet_ms:8.1f} ms')
    print(f'  records(long joint, limit=500)        {long_ms:8.1f} ms')
    print(f'  records(usual joint, limit=500)       {usual_ms:8.1f} ms  '
          f'({len(usual_rows)} rows)')
    print(f'  alarm_log(limit=100)                  {log_ms:8.1f} ms')
    print(f'  alarm_log(limit=100, before_id=...)   {page_ms:8.1f} ms')
    print(f'  alarm_log(robot=..., limit=100)       {robot_log_ms:8.1f} ms')


def main() -> None:
    """Run the benchmark and print its figures."""
    parser = argparse.ArgumentParser(description=__doc__.strip().splitlines()[0])
    parser.add_argument('--joints', type=int, default=1000)
    parser.add_argument('--experiments', type=int, default=100_000)
    parser.add_argument('--long-joint', type=int, default=5000)
    parser.add_argument('--repeat', type=int, default=7)
    parser.add_argument('--no-postgresql', action='store_true')
    args = parser.parse_args()
    with tempfile.TemporaryDirectory(prefix='bench_history_dashboard_') as folder:
        measure(str(Path(folder) / 'fleet.sqlite3'), name='SQLite', args=args)
    if args.no_postgresql:
        return
    sys.path.insert(0, str(Path(__file__).resolve().parents[1] / 'test'))
    from wear_testing.postgres_server import find_postgresql_binaries, PostgresServer
    binaries = find_postgresql_binaries()
    if binaries is None:
        print('PostgreSQL: no server (install postgresql)')
        return
    server = PostgresServer(binaries)
    server.start()
    try:
        measure(server.create_database('bench'), name='PostgreSQL', args=args)
    finally:
        server.stop()


if __name__ == '__main__':
    main()
