"""
The fleet page of a 6,000-joint fleet: paged on the server, median and p95 of each request.

    python3 bench/bench_fleet_page.py [--joints 6000] [--experiments 5] [--robots 100]
                                      [--repeats 21] [--no-postgresql] [--keep DIR]

Writes a history of ``--joints`` joints (``--robots`` robots, ``--experiments`` estimates each,
alarms raised past w = 35, some acknowledged: ``bench_dashboard.fill``) into SQLite and into a
throw-away PostgreSQL server (``initdb``/``pg_ctl`` from Debian's ``postgresql``, started as the
tests start it; skipped with ``--no-postgresql`` or when absent).  The fleet query reads one
row per joint (``joint_summary``), so the number of experiments per joint does not change its
cost.  Then, with FastAPI's TestClient (in process, no network), ``--repeats`` requests of:
the fleet page (``/``, its first 100 rows) with nothing cached (the fleet read from the
history, the page's rows made anew), after one new experiment and with the history unchanged
(the polling case); a deep page, a robot's page and a state's page; ``/api/fleet`` paged and
whole (its default: every row).  Prints the median and the 95th percentile of the wall time
and the median CPU time (client and server in one process) against the target: the fleet
page < 300 ms.
"""

import argparse
import os
import statistics
import sys
import time

from bench_dashboard import _new_experiment, fill, PASSWORD
from fastapi.testclient import TestClient
from robot_wear_monitor.dashboard.app import create_app, DashboardSettings
from robot_wear_monitor.dashboard.views import FleetCache

#: The targets [ms] of the median and the 95th percentile.
TARGETS_MS = {'fleet page': 300.0}


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
        robot = first['robots'][len(first['robots']) // 2]
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
