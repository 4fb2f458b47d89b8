"""
Dashboard server time on a real fleet: the fleet page, a joint page and ``/api/fleet``.

    python3 bench/bench_dashboard.py [--joints 1000] [--experiments 100] [--robots 100]
                                     [--repeats 7] [--no-postgresql] [--keep DIR]

Writes a history of ``--joints`` joints (``--robots`` robots) with ``--experiments`` estimates
each (1,000 x 100 = 100,000 by default) through the history's own API (``append``, alarm events
for the joints past w = 35, some acknowledged), into SQLite and into a throw-away PostgreSQL
server (``initdb``/``pg_ctl`` from Debian's ``postgresql``, as the tests start it; skipped with
``--no-postgresql`` or when absent).  Then, with FastAPI's TestClient (in process, no network),
the median server time of ``--repeats`` requests of: the fleet page (``/``, every joint's row
rendered), one joint's page (the worst joint, its ``--experiments`` estimates), ``/api/fleet``
and the joint's ``/api/...`` route, each as after a new experiment (the fleet rows read from
the history and every row made anew); the fleet page and ``/api/fleet`` also after one new
experiment since the last request (the app's cache makes only that joint's row anew) and with
the history unchanged (the polling case).  Prints each
against the targets (fleet page < 300 ms, joint page < 200 ms); beside the wall time, the
process's CPU time per request (client and server: on a shared machine the wall time counts
the other jobs too).
"""

import argparse
from dataclasses import replace
import os
from pathlib import Path
import random
import statistics
import sys
import tempfile
import time
from typing import Iterator, Optional

from fastapi.testclient import TestClient
from robot_wear_monitor.dashboard.app import create_app, DashboardSettings
from robot_wear_monitor.dashboard.views import FleetCache, joint_url
from robot_wear_monitor.history import AlarmEvent, HistoryRecord, open_history

HOUR_S = 3600.0
TARGETS_MS = {'fleet page': 300.0, 'joint page': 200.0}
PASSWORD = 'bench-password-1'


def _record(robot: str, joint: str, k: int, *, wear: float, last_s: float,
            experiments: int, crossing: float) -> HistoryRecord:
    return HistoryRecord(
        joint=joint, robot=robot, stamp_s=last_s - (experiments - 1 - k) * HOUR_S,
        speeds_rad_s=(2.1, 28.5, 35.1, 41.7), frictions=(0.15, 0.08, 0.08, 0.09),
        temperature_degc=40.0, temperature_std_degc=3.0, wear=wear, wear_std=5.0, chi2=1.0,
        dof=2, p_value=0.5, temperature_at_bound=False, wear_at_bound=False,
        alarm_active=wear >= 35.0, alarm_evidence=0.0, status_level=0,
        parameter_set='abb_irb6620_joint2', wear_low=max(0.0, wear - 9.0), wear_high=wear + 9.0,
        trend_wear=wear, trend_low=max(0.0, wear - 7.0), trend_high=wear + 7.0,
        crossing_experiments=crossing)


def fleet_joints(*, joints: int, experiments: int, robots: int, now_s: float,
                 seed: int = 0) -> Iterator[tuple[list[HistoryRecord], Optional[int], bool]]:
    """
    Yield each joint of the bench's fleet: its estimates (oldest first), raise, acknowledgement.

    Per joint: the estimates of ``experiments`` experiments an hour apart, the last at
    ``now_s`` [s] (5 % a day earlier: stale), the wear rising to a random final value with
    noise; the index of the estimate that raises its alarm (the first at w >= 35; None when
    none) and whether the alarm is acknowledged (30 % of them).  Seeded: the same fleet each
    time.
    """
    rng = random.Random(seed)
    for index in range(joints):
        robot, joint = f'robot_{index % robots:03d}', f'joint_{index // robots}'
        final = rng.uniform(0.0, 60.0)
        last_s = now_s - (0.0 if rng.random() > 0.05 else 24 * HOUR_S)  # 5 % stale
        records: list[HistoryRecord] = []
        raise_at: Optional[int] = None
        for k in range(experiments):
            wear = final * (k + 1) / experiments + rng.gauss(0.0, 3.0)
            last = k == experiments - 1
            crossing = (max(0.0, (35.0 - wear) / (final / experiments)) if last and
                        final > 20.0 else float('nan'))
            records.append(_record(robot, joint, k, wear=wear, last_s=last_s,
                                   experiments=experiments, crossing=crossing))
            if wear >= 35.0 and raise_at is None:
                raise_at = k
        yield records, raise_at, raise_at is not None and rng.random() < 0.3


def fill(location: str, *, joints: int, experiments: int, robots: int, seed: int = 0) -> float:
    """Write the fleet into the history at ``location``; return the seconds it took."""
    started = time.monotonic()
    with open_history(location) as history:
        if history.backend == 'sqlite':  # a bench file: no fsync per estimate
            history._backend.conn.execute('PRAGMA synchronous=OFF')
        history.add_user(name='bench', role='maintainer', password=PASSWORD)
        for records, raise_at, acknowledged in fleet_joints(
                joints=joints, experiments=experiments, robots=robots, now_s=time.time(),
                seed=seed):
            for k, rec in enumerate(records):
                events = ()
                if k == raise_at:
                    events = (AlarmEvent(joint=rec.joint, robot=rec.robot, stamp_s=rec.stamp_s,
                                         event='raised', wear=rec.wear, note='w-hat >= 35'),)
                history.append(rec, events=events)
            if acknowledged:
                history.acknowledge_alarm(joint=records[-1].joint, robot=records[-1].robot,
                                          user='bench', owner='team A', comment='ordered')
    return time.monotonic() - started


def _new_experiment(location: str, robot: str, joint: str, count: list[int]) -> None:
    """Append one more estimate to a joint (as a monitor would between two polls)."""
    with open_history(location) as history:
        last = history.records(joint=joint, robot=robot, limit=1)[-1]
        count[0] += 1
        history.append(replace(last, id=None, stamp_s=last.stamp_s + count[0]))


def measure(location: str, *, repeats: int) -> dict[str, float]:
    """Return the median server time [ms] of each page and route."""
    app = create_app(DashboardSettings(history=location))
    added = [0]
    out = {}
    with TestClient(app) as client:
        token = client.get('/login').text.split('name="csrf_token" value="')[1].split('"')[0]
        client.post('/login', data={'username': 'bench', 'password': PASSWORD,
                                    'csrf_token': token})
        worst = client.get('/api/fleet').json()['rows'][0]
        url = joint_url(worst['robot'], worst['joint'])
        client.get('/')  # the templates compiled
        other = client.get('/api/fleet').json()['rows'][-1]
        routes = {'fleet page': ('/', 'cold'), 'fleet page, 1 new experiment': ('/', 'new'),
                  'fleet page, unchanged': ('/', ''), 'joint page': (url, 'cold'),
                  '/api/fleet': ('/api/fleet', 'cold'),
                  '/api/fleet, 1 new experiment': ('/api/fleet', 'new'),
                  '/api/fleet, unchanged': ('/api/fleet', ''),
                  'joint API': ('/api' + url, 'cold'), 'alarm log page': ('/alarms', 'cold')}
        for name, (path, kind) in routes.items():
            times, cpu = [], []
            for _ in range(repeats):
                if kind == 'cold':  # nothing cached: every fleet row read and made anew
                    app.state.fleet_cache = FleetCache()
                elif kind == 'new':
                    _new_experiment(location, other['robot'], other['joint'], added)
                begin, begin_cpu = time.perf_counter(), time.process_time()
                response = client.get(path)
                times.append(time.perf_counter() - begin)
                cpu.append(time.process_time() - begin_cpu)
                assert response.status_code == 200, (path, response.status_code)
            out[name] = 1000.0 * statistics.median(times)
            out[name + ' min'] = 1000.0 * min(times)
            out[name + ' cpu'] = 1000.0 * statistics.median(cpu)
            out[name + ' bytes'] = len(response.content)
    return out


def report(kind: str, figures: dict[str, float], fill_s: float, args: argparse.Namespace) -> None:
    """Print the figures of one backend against the targets."""
    print(f'\n{kind}: {args.joints} joints x {args.experiments} experiments '
          f'({args.joints * args.experiments} estimates), written in {fill_s:.0f} s; load '
          f'average {os.getloadavg()[0]:.1f} on {os.cpu_count()} cores; wall time median '
          '(fastest), CPU time median')
    for name, value in figures.items():
        if name.endswith((' bytes', ' min', ' cpu')):
            continue
        target = TARGETS_MS.get(name)
        verdict = '' if target is None else (
            f'  target < {target:.0f} ms: {"met" if value < target else "MISSED"}')
        print(f'  {name:<30} {value:7.1f} ms ({figures[name + " min"]:6.1f}) '
              f'CPU {figures[name + " cpu"]:6.1f} ms  '
              f'{figures[name + " bytes"] / 1024:5.0f} KiB'
              + verdict)


def run_on_sqlite_and_postgresql(*, description: str, name: str, defaults: dict,
                                 fill, measure, report) -> int:
    """
    Parse the bench's options, fill a history and measure it on SQLite, then on PostgreSQL.

    :param description: the command line's description.
    :param name: the history's file and database name.
    :param defaults: the defaults of ``--joints``, ``--experiments``, ``--robots``,
        ``--repeats``.
    :param fill: ``fill(location, joints=, experiments=, robots=)`` -> seconds.
    :param measure: ``measure(location, repeats=)`` -> results.
    :param report: ``report(store, results, fill_s, args)`` prints them.
    :return: the exit code.
    """
    parser = argparse.ArgumentParser(description=description)
    for option in ('joints', 'experiments', 'robots', 'repeats'):
        parser.add_argument(f'--{option}', type=int, default=defaults[option])
    parser.add_argument('--no-postgresql', action='store_true')
    parser.add_argument('--no-sqlite', action='store_true', help='measure PostgreSQL only')
    parser.add_argument('--keep', type=Path, help='keep the SQLite history here')
    args = parser.parse_args()
    if not args.no_sqlite:
        with tempfile.TemporaryDirectory() as scratch:
            folder = args.keep or Path(scratch)
            folder.mkdir(parents=True, exist_ok=True)
            location = str(folder / f'{name}.sqlite3')
            if Path(location).exists():
                fill_s = 0.0  # a kept history: measured again as it is
            else:
                fill_s = fill(location, joints=args.joints, experiments=args.experiments,
                              robots=args.robots)
            report('SQLite', measure(location, repeats=args.repeats), fill_s, args)
    if args.no_postgresql:
        return 0
    sys.path.insert(0, str(Path(__file__).resolve().parents[1] / 'test'))
    from wear_testing.postgres_server import find_postgresql_binaries, PostgresServer
    binaries = find_postgresql_binaries()
    if binaries is None:
        print('\nPostgreSQL: skipped (no initdb/pg_ctl; apt-get install postgresql)')
        return 0
    server = PostgresServer(binaries)
    try:
        server.start()
        url = server.create_database(name)
        fill_s = fill(url, joints=args.joints, experiments=args.experiments,
                      robots=args.robots)
        report('PostgreSQL', measure(url, repeats=args.repeats), fill_s, args)
    finally:
        server.stop()
    return 0


def main() -> int:
    """Run the bench on SQLite (and PostgreSQL)."""
    return run_on_sqlite_and_postgresql(
        description=__doc__.strip().splitlines()[0], name='dashboard', fill=fill,
        measure=measure, report=report,
        defaults={'joints': 1000, 'experiments': 100, 'robots': 100,
                  'repeats': 7})


if __name__ == '__main__':
    sys.exit(main())
