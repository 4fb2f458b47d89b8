"""
Replay against rosbags merely reading the same messages, whole processes, at two bag lengths.

    python3 bench/bench_replay.py [--experiments 60] [--long 600] [--mid 150] [--repeat 3]
                                  [--keep DIR] [--no-read]

Simulates accelerated wear scenarios of ``--experiments`` and ``--long`` experiments into MCAP
bags of /joint_states (6 joints, 250 Hz), then, in one run, for each bag, every figure a whole
new process (interpreter start-up and imports included), the fastest of ``--repeat`` runs:

* **bytes only**: a process that iterates rosbags' raw messages of the bag (no decoding);
* **read**: a process that iterates and deserialises every JointState (``deserialize_cdr``;
  one run at the long bag, where it takes half a minute; ``--no-read`` skips it);
* **replay**: ``robot-wear-monitor replay BAG --out OUT`` for one joint (reading,
  segmentation, estimation, intervals, trend, alarm, every output topic written);
* the peak resident memory (VmHWM) of each process.

Prints, for each process, the wall seconds, messages per second and CPU seconds (user +
system of the process and its threads and children, from ``getrusage(RUSAGE_CHILDREN)``), and
the replay's wall and CPU time as a fraction of the bytes-only process's.  The verdict is that
of the re-analysis cost issue: at the long bag the replay takes at most **0.5 x** the
bytes-only process's CPU time and at most 0.5 x its wall time; at the short bag at most
1.0 x its CPU time; the replay's peak RSS does not grow with the bag's length.  The replay
estimates 64 experiments at a time: the short bag's one batch runs after its reading, a longer
bag's batches overlap the reading, so memory is compared between a ``--mid`` bag (one run) and
the long one.  The CPU seconds per experiment of the long bag's replay (start-up included) are
the figure of the fleet's re-analysis plan (docs/fleet.md).  The load average before and after
says whether the machine was quiet.
Also prints what start-up alone costs (an empty interpreter, numpy, scipy, the replay's
imports) so that the short bag's ratio can be read against it.

The package's modules are byte-compiled first (as an installed package is), like rosbags' in
site-packages.  ``--all-joints`` adds the replay of all six joints.
"""

import argparse
import compileall
import os
from pathlib import Path
import platform
import resource
import subprocess
import sys
import tempfile
import time
from typing import Optional

from robot_wear_monitor.experiment.simulation import accelerated_wear_scenario, simulate_scenario
from robot_wear_monitor.recordings.bags import write_joint_state_bag

_PEAK = ('peak = [line.split()[1] for line in open("/proc/self/status")'
         ' if line.startswith("VmHWM")][0]\n'
         'print("peak_rss_kb", peak, file=sys.stderr)\n')
#: the replay CLI in a child, its peak RSS (kB, VmHWM of /proc: getrusage's maxrss would carry
#: the parent's peak over the exec) on stderr's last line
_REPLAY = ('import sys\n'
           'from robot_wear_monitor.cli import main\n'
           'code = main(sys.argv[1:])\n' + _PEAK + 'sys.exit(code)\n')
_BYTES_ONLY = ('import sys\n'
               'from rosbags.rosbag2 import Reader\n'
               'with Reader(sys.argv[1]) as reader:\n'
               '    count = sum(1 for _ in reader.messages())\n'
               'print(count)\n' + _PEAK)
_READ = ('import sys\n'
         'from rosbags.rosbag2 import Reader\n'
         'from rosbags.typesys import get_typestore, Stores\n'
         'store = get_typestore(Stores.ROS2_JAZZY)\n'
         'with Reader(sys.argv[1]) as reader:\n'
         '    count = sum(1 for c, _, data in reader.messages()\n'
         '                if store.deserialize_cdr(data, c.msgtype) is not None)\n'
         'print(count)\n' + _PEAK)
_STARTUP = {
    'empty interpreter': 'import sys\n' + _PEAK,
    'import numpy': 'import sys, numpy\n' + _PEAK,
    'import numpy, scipy.linalg, scipy.special': 'import sys, numpy, scipy.linalg, '
                                                 'scipy.special\n' + _PEAK,
    # as the command line: one BLAS thread before numpy loads (blas_threads)
    "the replay's imports": ('import sys\n'
                             'from robot_wear_monitor.blas_threads import '
                             'use_single_blas_thread\n'
                             'use_single_blas_thread()\n'
                             'import robot_wear_monitor.cli, robot_wear_monitor.cli.replay\n'
                             'import robot_wear_monitor.monitoring.replay\n'
                             'import robot_wear_monitor.estimation.batch_intervals\n'
                             'import robot_wear_monitor.estimation.trend\n' + _PEAK),
}


def _write_bag(folder: Path, experiments: int) -> Path:
    scenario = simulate_scenario(
        config=accelerated_wear_scenario(n_experiments=experiments, seed=0), seed=0)
    bag = folder / f'scenario_{experiments}'
    write_joint_state_bag(bag, stamps_s=scenario.time_s, names=scenario.joint_names,
                          position=scenario.position_rad, velocity=scenario.velocity_rad_s,
                          effort=scenario.effort, overwrite=True)
    return bag


def _write_bag_in_child(folder: Path, experiments: int) -> Path:
    """Write a bag from a child process (the simulation holds it all in memory)."""
    bag = folder / f'scenario_{experiments}'
    if (bag / 'metadata.yaml').is_file():
        return bag  # --keep: made by an earlier run
    code = ('import sys; from pathlib import Path; sys.path.insert(0, sys.argv[1]); '
            'import bench_replay; bench_replay._write_bag(Path(sys.argv[2]), int(sys.argv[3]))')
    subprocess.run([sys.executable, '-c', code, str(Path(__file__).parent), str(folder),
                    str(experiments)], check=True)
    return bag


def _cpu_s() -> float:
    usage = resource.getrusage(resource.RUSAGE_CHILDREN)
    return usage.ru_utime + usage.ru_stime


def _run_once(code: str, *args: str) -> tuple[float, int, str, float]:
    """Run ``code`` in a new interpreter; return (wall s, peak RSS kB, stdout line, CPU s)."""
    start, cpu = time.perf_counter(), _cpu_s()
    done = subprocess.run([sys.executable, '-c', code, *args], capture_output=True, text=True,
                          env=dict(os.environ))
    elapsed = time.perf_counter() - start
    cpu = _cpu_s() - cpu
    if done.returncode != 0:
        raise SystemExit(f'{args[:1]} failed ({done.returncode}): {done.stderr.strip()}')
    rss = int(done.stderr.strip().splitlines()[-1].split()[-1])
    lines = done.stdout.strip().splitlines()
    return elapsed, rss, lines[0] if lines else '', cpu


def _fastest(code: str, *args: str, repeat: int) -> tuple[float, int, str, float]:
    """
    Return the fastest of ``repeat`` runs (the one least disturbed by other work).

    The CPU seconds are the least of the runs too (user + system of the process).
    """
    runs = [_run_once(code, *args) for _ in range(repeat)]
    best = min(runs)
    return best[0], best[1], best[2], min(run[3] for run in runs)


def _replay_args(bag: Path, out: Path, *extra: str) -> list[str]:
    return ['replay', str(bag), '--out', str(out), '--overwrite', '--no-progress', *extra]


def _measure(bag: Path, folder: Path, joint: list[str], repeat: int, read_repeat: int,
             all_joints: bool) -> dict:
    """Return label -> (seconds, peak RSS kB, line, CPU s) of every process for one bag."""
    figures = {'bytes only': _fastest(_BYTES_ONLY, str(bag), repeat=repeat)}
    if read_repeat:
        figures['read'] = _fastest(_READ, str(bag), repeat=read_repeat)
    figures['replay'] = _fastest(_REPLAY, *_replay_args(bag, folder / f'out_{bag.name}', *joint),
                                 repeat=repeat)
    if all_joints:
        figures['replay, all 6 joints'] = _fastest(
            _REPLAY, *_replay_args(bag, folder / f'out6_{bag.name}', '--joint', 'all',
                                   *joint[2:]), repeat=repeat)
    return figures


#: the targets (replay / bytes-only process, at most): (CPU time, wall time or None)
_TARGETS = {'short': (1.0, None), 'long': (0.5, 0.5)}


def _verdict(n: int, figures: dict, targets: tuple[float, Optional[float]]) -> str:
    """Return the verdict line of one bag: replay time / bytes-only time, CPU and wall."""
    raw_wall, _, _, raw_cpu = figures['bytes only']
    wall, _, _, cpu = figures['replay']
    cpu_target, wall_target = targets
    met = cpu / raw_cpu <= cpu_target and (wall_target is None or wall / raw_wall <= wall_target)
    text = (f'{n:5d} experiments: replay CPU {cpu / raw_cpu:4.2f} x the bytes-only process '
            f'(target <= {cpu_target:.1f} x), wall {wall / raw_wall:4.2f} x')
    if wall_target is not None:
        text += f' (target <= {wall_target:.1f} x)'
    return text + f': {"MET" if met else "NOT MET"}'


def _load() -> str:
    return ', '.join(f'{v:.2f}' for v in os.getloadavg())


def main(argv=None):
    """Run the benchmark and print one line per measurement and the verdict."""
    parser = argparse.ArgumentParser(description=__doc__.strip().splitlines()[0])
    parser.add_argument('--experiments', type=int, default=60, help='the short bag')
    parser.add_argument('--long', type=int, default=600, help='the long bag (0: skip)')
    parser.add_argument('--mid', type=int, default=150,
                        help='a bag of more than 64 experiments for the memory check (0: skip)')
    parser.add_argument('--repeat', type=int, default=3, help='runs per figure (the fastest)')
    parser.add_argument('--all-joints', action='store_true', help='add --joint all replays')
    parser.add_argument('--no-read', action='store_true',
                        help='skip the iterate + deserialise reference process')
    parser.add_argument('--keep', metavar='DIR', help='keep the bags in DIR (and reuse them)')
    args = parser.parse_args(argv)
    folder = Path(args.keep) if args.keep else Path(tempfile.mkdtemp(prefix='bench_replay_'))
    folder.mkdir(parents=True, exist_ok=True)
    package = Path(__file__).resolve().parents[1] / 'robot_wear_monitor'
    compileall.compile_dir(str(package), quiet=1)
    config = accelerated_wear_scenario(n_experiments=args.experiments, seed=0)
    joint = ['--joint', config.joint.joint, '--gear-ratio', str(config.joint.gear_ratio),
             '--torque-scale', str(config.joint.torque_scale)]
    sizes = [args.experiments] + ([args.long] if args.long else [])
    bags = {n: _write_bag_in_child(folder, n) for n in sizes}
    _run_once(_REPLAY, *_replay_args(bags[sizes[0]], folder / 'warm', *joint))  # calibration
    print(f'{time.strftime("%Y-%m-%d %H:%M UTC", time.gmtime())}, {platform.node()}: '
          f'{os.cpu_count()} cores, Python {sys.version.split()[0]}, fastest of {args.repeat}; '
          f'load average before: {_load()}; bags in {folder}')
    for label, code in _STARTUP.items():
        seconds, rss, _, cpu = _fastest(code, repeat=args.repeat)
        print(f'start-up, {label:42s}: {seconds:6.2f} s (CPU {cpu:5.2f} s), peak RSS '
              f'{rss / 1024:5.0f} MB')
    results = {}
    for n in sizes:
        bag = bags[n]
        # the read of the long bag (a reference, no target) once: it takes half a minute
        read_repeat = 0 if args.no_read else args.repeat if n == sizes[0] else 1
        figures = results[n] = _measure(bag, folder, joint, args.repeat, read_repeat,
                                        args.all_joints)
        count = int(figures['bytes only'][2])
        print(f'--- {n} experiments: {count} JointState messages (6 joints, 250 Hz)')
        raw_s, raw_cpu = figures['bytes only'][0], figures['bytes only'][3]
        for label, (seconds, rss, line, cpu) in figures.items():
            text = (f'{label:22s}: {seconds:6.2f} s {count / seconds:10,.0f} msg/s (CPU '
                    f'{cpu:5.2f} s), peak RSS {rss / 1024:5.0f} MB')
            if label.startswith('replay'):
                text += (f'; {seconds / raw_s:4.2f} x the bytes-only wall time, '
                         f'{cpu / raw_cpu:4.2f} x its CPU time, {cpu / n * 1000:5.2f} ms CPU '
                         f'per experiment')
                if 'read' in figures:
                    text += f', {figures["read"][0] / seconds:4.2f} x faster than the read'
                text += f'  [{line}]'
            print(text)
    print('--- verdict (replay time / bytes-only process time; fastest of '
          f'{args.repeat} each)')
    print(_verdict(args.experiments, results[args.experiments], _TARGETS['short']))
    if args.long:
        print(_verdict(args.long, results[args.long], _TARGETS['long']))
        short_rss = results[args.experiments]['replay'][1]
        long_rss = results[args.long]['replay'][1]
        text = (f'replay peak RSS: {short_rss / 1024:.0f} MB at {args.experiments} experiments, '
                f'{long_rss / 1024:.0f} MB at {args.long}')
        if args.mid:
            mid_bag = _write_bag_in_child(folder, args.mid)
            mid_rss = _run_once(_REPLAY, *_replay_args(mid_bag, folder / 'out_mid', *joint))[1]
            grows = long_rss - mid_rss > 0.1 * mid_rss
            text += (f', {mid_rss / 1024:.0f} MB at {args.mid} '
                     f'({(long_rss - mid_rss) / 1024:+.0f} MB from {args.mid} to {args.long}): '
                     + ('GROWS' if grows else 'flat'))
        print(text)
    print(f'load average after: {_load()}')
    return 0


if __name__ == '__main__':
    sys.exit(main())
