"""
Fleet re-analysis and history writes: workers, Dask against the pool, inserts per second.

    python3 bench/bench_fleet.py [--robots 4] [--bags-per-robot 4] [--experiments 20]
                                 [--writers 8] [--rows 200] [--no-postgresql] [--writes-only]

Simulates ``--robots`` x ``--bags-per-robot`` bags (consecutive recordings per robot, one joint,
``--experiments`` experiments each, 250 Hz), then, in one run:

* the batch replay into a fresh SQLite history with 1 and with 2 pool workers (wall time,
  speed-up), and on a Dask ``LocalCluster`` of 2 worker processes against the pool of 2;
* the peak resident memory of a worker (the largest over its bags);
* the insert rate of the history with ``--writers`` processes writing at once, each its own
  robot, ``--rows`` estimates each (one transaction per estimate, as the monitor writes them),
  into SQLite and into a throw-away PostgreSQL server (``initdb``/``pg_ctl`` from Debian's
  ``postgresql``; skipped with ``--no-postgresql`` or when absent).

``--writes-only`` measures the insert rates alone (no bags, no replay), ``--repeats`` times,
and the time of one estimate's transaction with one writer (the least over batches of 100: a
figure a busy machine disturbs less than the rate of 8 writers on 2 cores).

The per-bag replay time printed here is what ``docs/fleet.md`` plans a fleet with.
"""

import argparse
from dataclasses import replace
import math
import multiprocessing
import os
from pathlib import Path
import sys
import tempfile
import time

from robot_wear_monitor.experiment.simulation import accelerated_wear_scenario, simulate_scenario
from robot_wear_monitor.fleet.batch import collect_bags, replay_one, ReplaySettings, run_batch
from robot_wear_monitor.history import HistoryRecord, WearHistory
from robot_wear_monitor.model.params import load_parameter_set
from robot_wear_monitor.recordings.bags import write_joint_state_bag

HOUR_S = 3600.0
START_S = 1.75e9


def make_fleet(root: Path, *, robots: int, bags: int, experiments: int) -> Path:
    """Write the simulated bags and a manifest; return the manifest."""
    model = load_parameter_set().model
    lines = ['robot,bag']
    for r in range(robots):
        for b in range(bags):
            seed = 100 * r + b
            config = accelerated_wear_scenario(n_experiments=experiments, seed=seed,
                                               wear_final=15.0 + 10.0 * r + 5.0 * b)
            config = replace(config, start_time_s=START_S + b * experiments * HOUR_S)
            scenario = simulate_scenario(config=config, model=model, seed=seed)
            path = root / f'robot_{r}' / f'bag_{b}'
            path.parent.mkdir(parents=True, exist_ok=True)
            write_joint_state_bag(path, stamps_s=scenario.time_s, names=scenario.joint_names,
                                  position=scenario.position_rad,
                                  velocity=scenario.velocity_rad_s, effort=scenario.effort)
            lines.append(f'robot_{r},{path.relative_to(root)}')
    manifest = root / 'fleet.csv'
    manifest.write_text('\n'.join(lines) + '\n')
    return manifest


def timed_batch(manifest: Path, history: Path, **kwargs) -> tuple[float, object]:
    """Return the wall time [s] and the result of one batch into a fresh history."""
    tasks = collect_bags(manifest=manifest)
    started = time.perf_counter()
    result = run_batch(tasks, settings=ReplaySettings(history=str(history)), **kwargs)
    wall = time.perf_counter() - started
    if result.count('done') != len(tasks):
        raise SystemExit(f'bench: bags failed: {[o.reason for o in result.failed]}')
    return wall, result


def _record(robot: str, k: int) -> HistoryRecord:
    return HistoryRecord(joint='joint_2', stamp_s=START_S + k * HOUR_S,
                         speeds_rad_s=(2.1, 28.5, 35.1, 41.7),
                         frictions=(0.14, 0.06, 0.06, 0.06), temperature_degc=40.0,
                         temperature_std_degc=2.0, wear=10.0 + 0.1 * k, wear_std=3.0, chi2=1.0,
                         dof=2, p_value=0.6, temperature_at_bound=False, wear_at_bound=False,
                         alarm_active=False, alarm_evidence=0.0, status_level=0,
                         parameter_set='bench', robot=robot, wear_low=5.0, wear_high=15.0,
                         trend_wear=10.0, trend_low=6.0, trend_high=14.0,
                         crossing_experiments=math.nan)


def _writer(location: str, robot: str, rows: int, start: object) -> None:
    with WearHistory(location) as history:
        start.wait()  # type: ignore[attr-defined]
        for k in range(rows):
            history.append(_record(robot, k))


def insert_rate(location: str, *, writers: int, rows: int) -> float:
    """Return estimates stored per second with ``writers`` processes writing at once."""
    WearHistory(location).close()  # created (and migrated) before the clock starts
    context = multiprocessing.get_context('fork')
    start = context.Event()
    processes = [context.Process(target=_writer, args=(location, f'robot_{w}', rows, start))
                 for w in range(writers)]
    for process in processes:
        process.start()
    time.sleep(1.0)  # every writer has opened the history
    began = time.perf_counter()
    start.set()
    for process in processes:
        process.join()
    elapsed = time.perf_counter() - began
    if any(p.exitcode for p in processes):
        raise SystemExit('bench: a writer failed')
    with WearHistory(location) as history:
        stored = sum(len(history.records(joint='joint_2', robot=f'robot_{w}'))
                     for w in range(writers))
    if stored != writers * rows:
        raise SystemExit(f'bench: {stored} rows stored, expected {writers * rows}')
    return stored / elapsed


def append_time(location: str, *, batches: int = 7, rows: int = 100) -> float:
    """Return the least time [us] of one estimate's transaction over ``batches`` of ``rows``."""
    with WearHistory(location) as history:
        k = 0
        for k in range(30):  # the statements prepared, the joint with its recent stamps
            history.append(_record('robot_0', k))
        best = math.inf
        for _ in range(batches):
            began = time.perf_counter()
            for _ in range(rows):
                k += 1
                history.append(_record('robot_0', k))
            best = min(best, (time.perf_counter() - began) / rows)
    return best * 1e6


def postgresql_rate(*, writers: int, rows: int, single: bool = False) -> float | None:
    """
    Return the insert rate into a throw-away PostgreSQL server, or None without one.

    ``single``: return :func:`append_time` [us] instead.
    """
    sys.path.insert(0, str(Path(__file__).resolve().parents[1] / 'test'))
    from wear_testing.postgres_server import find_postgresql_binaries, PostgresServer
    binaries = find_postgresql_binaries()
    if binaries is None:
        return None
    server = PostgresServer(binaries)
    server.start()
    try:
        if single:
            return append_time(server.create_database('bench'))
        return insert_rate(server.create_database('bench'), writers=writers, rows=rows)
    finally:
        server.stop()


def writes(args: argparse.Namespace) -> None:
    """Print the insert rates alone, ``args.repeats`` times, with the load average."""
    for _ in range(args.repeats):
        with tempfile.TemporaryDirectory(prefix='bench_fleet_') as folder:
            load = os.getloadavg()[0]
            rate = insert_rate(str(Path(folder) / 'writes.sqlite3'), writers=args.writers,
                               rows=args.rows)
            print(f'  SQLite: {rate:7.0f} estimates/s with {args.writers} writers at once '
                  f'(load {load:.2f})', flush=True)
            single = append_time(str(Path(folder) / 'single.sqlite3'))
            print(f'  SQLite: {single:5.0f} us an estimate, one writer', flush=True)
        if not args.no_postgresql:
            load = os.getloadavg()[0]
            pg = postgresql_rate(writers=args.writers, rows=args.rows)
            print('  PostgreSQL: ' + ('no server (install postgresql)' if pg is None else
                                      f'{pg:7.0f} estimates/s with {args.writers} writers '
                                      f'at once (load {load:.2f})'), flush=True)
            single_pg = postgresql_rate(writers=1, rows=1, single=True)
            if single_pg is not None:
                print(f'  PostgreSQL: {single_pg:5.0f} us an estimate, one writer', flush=True)


def main() -> None:
    """Run the benchmark and print its figures."""
    parser = argparse.ArgumentParser(description=__doc__.strip().splitlines()[0])
    parser.add_argument('--robots', type=int, default=4)
    parser.add_argument('--bags-per-robot', type=int, default=4)
    parser.add_argument('--experiments', type=int, default=20)
    parser.add_argument('--writers', type=int, default=8)
    parser.add_argument('--rows', type=int, default=200)
    parser.add_argument('--no-postgresql', action='store_true')
    parser.add_argument('--writes-only', action='store_true')
    parser.add_argument('--repeats', type=int, default=1)
    args = parser.parse_args()
    if args.writes_only:
        writes(args)
        return
    with tempfile.TemporaryDirectory(prefix='bench_fleet_') as folder:
        root = Path(folder)
        manifest = make_fleet(root / 'bags', robots=args.robots, bags=args.bags_per_robot,
                              experiments=args.experiments)
        bags = args.robots * args.bags_per_robot
        print(f'fleet: {args.robots} robots x {args.bags_per_robot} bags, '
              f'{args.experiments} experiments per bag ({bags} bags); {os.cpu_count()} cores')
        one, first = timed_batch(manifest, root / 'h1.sqlite3', workers=1)
        two, second = timed_batch(manifest, root / 'h2.sqlite3', workers=2)
        per_bag = sum(o.elapsed_s for o in first.outcomes) / bags
        print(f'  1 worker (in-process)  {one:7.2f} s   {per_bag:.2f} s per bag')
        print(f'  2 workers (pool)       {two:7.2f} s   speed-up {one / two:.2f}x')
        import distributed
        with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                                      dashboard_address=None) as cluster, \
                distributed.Client(cluster) as client:
            # workers warm before the clock starts: one replay each (imports, the estimator's
            # problem and interval calibration of the design), as the pool's workers, forked
            # from this process after its in-process run, start warm
            first = collect_bags(manifest=manifest)[0]
            client.run(replay_one, first, ReplaySettings())
            dask_wall, dask = timed_batch(manifest, root / 'h3.sqlite3', dask_client=client)
        print(f'  Dask LocalCluster (2)  {dask_wall:7.2f} s   {two / dask_wall:.2f}x the pool')
        peak = max(o.peak_rss_mb for o in second.outcomes + dask.outcomes)
        print(f'  peak memory of a worker: {peak:.0f} MB')
        sqlite_rate = insert_rate(str(root / 'writes.sqlite3'), writers=args.writers,
                                  rows=args.rows)
        print(f'  SQLite: {sqlite_rate:7.0f} estimates/s with {args.writers} writers at once')
        if not args.no_postgresql:
            rate = postgresql_rate(writers=args.writers, rows=args.rows)
            print('  PostgreSQL: ' + ('no server (install postgresql)' if rate is None else
                                      f'{rate:7.0f} estimates/s with {args.writers} writers '
                                      'at once'))


if __name__ == '__main__':
    main()
