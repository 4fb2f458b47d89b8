"""
The fleet page of a 6,000-joint fleet: paged on the server, median and p95 of each request.

    python3 bench/bench_fleet_page.py [--joints 6000] [--experiments 5] [--robots 100]
                                      [--repeats 21] [--no-postgresql] [--keep DIR]

Writes a history of ``--joints`` joints (``--robots`` robots, ``--experiments`` estimates each,
alarms raised past w = 35, some acknowledged: the rows of ``bench_dashboard.fill``, written in
batches of ``executemany``, then ``joint_summary`` and its ranking keys made at once as the
migration makes them) into SQLite and into a throw-away PostgreSQL server
(``initdb``/``pg_ctl`` from Debian's ``postgresql``, started as the tests start it; skipped
with ``--no-postgresql`` or when absent).  A page reads the index of the ranking keys and its
own rows only (schema version 12), so neither the joints nor the experiments per joint make
it read more.  Then, with FastAPI's TestClient (in process, no network), ``--repeats`` requests of:
the fleet page (``/``, its first 100 rows) with nothing cached (the fleet read from the
history, the page's rows made anew), after one new experiment and with the history unchanged
(the polling case); a deep page, a robot's page and a state's page; ``/api/fleet`` paged and
whole (its default: every row).  Prints the median and the 95th percentile of the wall time
and the median CPU time (client and server in one process) against the target: the fleet
page < 300 ms.
"""

import argparse
import json
import os
import statistics
import sys
import time

from bench_dashboard import _new_experiment, fleet_joints, PASSWORD
from fastapi.testclient import TestClient
from robot_wear_monitor.dashboard.app import create_app, DashboardSettings
from robot_wear_monitor.dashboard.views import FleetCache
from robot_wear_monitor.history import fleet_counts, fleet_index
from robot_wear_monitor.history import INTERVAL_COLUMNS, open_history
from robot_wear_monitor.history.migrations import JOINT_SUMMARY_REBUILD

#: The targets [ms] of the median and the 95th percentile.
TARGETS_MS = {'fleet page': 300.0}


#: The levels every estimate stores (schema 8 on; those of the packaged set the rows name) [w].
THRESHOLD, WARNING_LEVEL = 35.0, 28.0
#: Rows per ``executemany`` batch of the fill.
BATCH_ROWS = 20000
_ESTIMATE_COLUMNS = ('id', 'robot', 'joint', 'stamp_s', 'wall_time_s', 'speeds_rad_s',
                     'frictions', 'temperature_degc', 'temperature_std_degc', 'wear',
                     'wear_std', 'chi2', 'dof', 'p_value', 'temperature_at_bound',
                     'wear_at_bound', 'alarm_active', 'alarm_evidence', 'status_level',
                     'parameter_set', *INTERVAL_COLUMNS, 'invalid_reason', 'threshold',
                     'warning_level')
_EVENT_COLUMNS = ('id', 'robot', 'joint', 'stamp_s', 'wall_time_s', 'event', 'wear',
                  'estimate_id', 'note', 'user_name', 'owner')


def _none_if_nan(value: float):
    return None if value != value else value


def fill(location: str, *, joints: int, experiments: int, robots: int, seed: int = 0) -> float:
    """
    Write the fleet of ``bench_dashboard.fill`` in ``executemany`` batches; return the seconds.

    The same rows (estimates, raises, 30 % of the alarms acknowledged) with explicit ids,
    each estimate with the threshold and warning level it was judged by (as the estimator
    stores them since schema version 8: 35 and 28, the packaged set's); then
    ``joint_summary`` and its ranking keys made at once (what appends keep, as the migration
    makes them).
    """
    started = time.monotonic()
    now = time.time()
    with open_history(location) as history:
        backend = history._backend
        if history.backend == 'sqlite':  # a bench file: no fsync per batch
            backend.conn.execute('PRAGMA synchronous=OFF')
        history.add_user(name='bench', role='maintainer', password=PASSWORD)
        overriding = 'OVERRIDING SYSTEM VALUE ' if history.backend == 'postgresql' else ''
        insert_estimates = (f'INSERT INTO estimates ({", ".join(_ESTIMATE_COLUMNS)}) '
                            f'{overriding}VALUES ({", ".join("?" * len(_ESTIMATE_COLUMNS))})')
        insert_events = (f'INSERT INTO alarm_events ({", ".join(_EVENT_COLUMNS)}) '
                         f'{overriding}VALUES ({", ".join("?" * len(_EVENT_COLUMNS))})')
        estimates: list[tuple] = []
        events: list[tuple] = []
        ids = {'estimate': 0, 'event': 0}

        def flush() -> None:
            with backend.transaction():
                backend.executemany(insert_estimates, estimates)
                backend.executemany(insert_events, events)
            estimates.clear()
            events.clear()

        for records, raise_at, acknowledged in fleet_joints(
                joints=joints, experiments=experiments, robots=robots, now_s=now, seed=seed):
            robot, joint = records[-1].robot, records[-1].joint
            for k, rec in enumerate(records):
                ids['estimate'] += 1
                estimates.append((
                    ids['estimate'], robot, joint, rec.stamp_s, now,
                    json.dumps(list(rec.speeds_rad_s)), json.dumps(list(rec.frictions)),
                    rec.temperature_degc, rec.temperature_std_degc, rec.wear, rec.wear_std,
                    rec.chi2, rec.dof, rec.p_value, 0, 0, int(rec.alarm_active),
                    rec.alarm_evidence, rec.status_level, rec.parameter_set,
                    *(_none_if_nan(getattr(rec, c)) for c in INTERVAL_COLUMNS), '',
                    THRESHOLD, WARNING_LEVEL))
                if k == raise_at:
                    ids['event'] += 1
                    events.append((ids['event'], robot, joint, rec.stamp_s, now, 'raised',
                                   rec.wear, ids['estimate'], 'w-hat >= 35', '', ''))
            if acknowledged:
                ids['event'] += 1
                events.append((ids['event'], robot, joint, now, now, 'acknowledged',
                               estimates[-1][9], ids['estimate'], 'ordered', 'bench',
                               'team A'))
            if len(estimates) >= BATCH_ROWS:
                flush()
        flush()
        with backend.transaction():
            fleet_counts.pause(backend)  # the counts made at once by rebuild, not row by row
            for step in JOINT_SUMMARY_REBUILD:  # what appends keep, made at once
                backend.execute(step)
            fleet_index.rebuild(backend)
            if history.backend == 'postgresql':
                for table in ('estimates', 'alarm_events'):
                    backend.execute(f"SELECT setval(pg_get_serial_sequence('{table}', 'id'), "
                                    f'(SELECT MAX(id) FROM {table}))')
        if history.backend == 'postgresql':
            backend.execute('ANALYZE')
    return time.monotonic() - started


def _p95(values: list[float]) -> float:
    ordered = sorted(values)
    return ordered[min(len(ordered) - 1, int(round(0.95 * (len(ordered) - 1))))]


def measure(location: str, *, repeats: int) -> dict[str, dict[str, float]]:
    """Return per request: the median and p95 wall time [ms], the median CPU [ms], size."""
    app = create_app(DashboardSettings(history=location))
    added = [0]
    out = {}
    with TestClient(app) as client:
        token = client.get('/login').text.split('name="csrf_token" value="')[1].split('"')[0]
        client.post('/login', data={'username': 'bench', 'password': PASSWORD,
                                    'csrf_token': token})
        first = client.get('/api/fleet', params={'limit': 1}).json()
        other = first['rows'][0]
        # a robot in the middle of the fleet, found by the robot search
        middle = f'robot_{first["robot_count"] // 2:03d}'  # named as fleet_joints names them
        robot = client.get('/api/robots', params={'search': middle,
                                                  'limit': 1}).json()['robots'][0]
        client.get('/')  # the templates compiled
        routes = {
            'fleet page': ('/', 'cold'),
            'fleet page, 1 new experiment': ('/', 'new'),
            'fleet page, unchanged': ('/', ''),
            'fleet page 30 (rows 2901-3000)': ('/?page=30', 'cold'),
            "fleet page, one robot's joints": (f'/?robot={robot}', 'cold'),
            'fleet page, state ok, page 2': ('/?state=ok&page=2', 'cold'),
            '/api/fleet?page=1&limit=100': ('/api/fleet?page=1&limit=100', 'cold'),
            '/api/fleet (every row)': ('/api/fleet', 'cold'),
        }
        for name, (path, kind) in routes.items():
            times, cpu = [], []
            for _ in range(repeats):
                if kind == 'cold':  # nothing cached: the fleet read and its rows made anew
                    app.state.fleet_cache = FleetCache()
                elif kind == 'new':
                    _new_experiment(location, other['robot'], other['joint'], added)
                begin, begin_cpu = time.perf_counter(), time.process_time()
                response = client.get(path)
                times.append(1000.0 * (time.perf_counter() - begin))
                cpu.append(1000.0 * (time.process_time() - begin_cpu))
                assert response.status_code == 200, (path, response.status_code)
            out[name] = {'median': statistics.median(times), 'p95': _p95(times),
                         'cpu': statistics.median(cpu), 'bytes': len(response.content)}
    return out


def report(kind: str, figures: dict[str, dict[str, float]], fill_s: float,
           args: argparse.Namespace) -> None:
    """Print the figures of one backend against the target."""
    print(f'\n{kind}: {args.joints} joints x {args.experiments} experiments, written in '
          f'{fill_s:.0f} s; load average {os.getloadavg()[0]:.1f} on {os.cpu_count()} cores; '
          f'{args.repeats} requests each: wall time median, p95; CPU time median')
    for name, value in figures.items():
        target = TARGETS_MS['fleet page'] if name.startswith('fleet page') else None
        verdict = '' if target is None else (
            f'  target < {target:.0f} ms: '
            f'{"met" if value["median"] < target and value["p95"] < target else "MISSED"}')
        print(f'  {name:<32} {value["median"]:7.1f} ms  p95 {value["p95"]:7.1f} ms  '
              f'CPU {value["cpu"]:6.1f} ms  {value["bytes"] / 1024:6.0f} KiB' + verdict)


def main() -> int:
    """Run the bench on SQLite (and PostgreSQL)."""
    from bench_dashboard import run_on_sqlite_and_postgresql
    return run_on_sqlite_and_postgresql(
        description=__doc__.strip().splitlines()[0], name='fleet_page', fill=fill,
        measure=measure, report=report,
        defaults={'joints': 6000, 'experiments': 5, 'robots': 100,
                  'repeats': 21})


if __name__ == '__main__':
    sys.exit(main())
