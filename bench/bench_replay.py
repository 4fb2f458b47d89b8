"""
Replay against rosbags merely reading the same messages, whole processes, at two bag lengths.

    python3 bench/bench_replay.py [--experiments 60] [--long 600] [--mid 150] [--repeat 3]
                                  [--keep DIR]

Simulates accelerated wear scenarios of ``--experiments`` and ``--long`` experiments into MCAP
bags of /joint_states (6 joints, 250 Hz), then, in one run, for each bag, every figure a whole
new process (interpreter start-up and imports included), the fastest of ``--repeat`` runs:

* **bytes only**: a process that iterates rosbags' raw messages of the bag (no decoding);
* **read**: a process that iterates and deserialises every JointState (``deserialize_cdr``;
  one run at the long bag, where it takes minutes);
* **replay**: ``robot-wear-monitor replay BAG --out OUT`` for one joint (reading,
  segmentation, estimation, intervals, trend, alarm, every output topic written);
* the peak resident memory (VmHWM) of each process.

Prints the seconds and messages per second of each, the ratios replay throughput / bytes-only
throughput and replay / read, and the verdict against the targets of the replay speed issue:
replay >= 1.0 x the bytes-only process at the long bag (aim 2 x) and >= 0.7 x at the short one;
the replay's peak RSS should not grow with the bag's length.  The replay estimates 64
experiments at a time: the short bag's one batch runs after its reading, a longer bag's batches
overlap the reading, so memory is compared between a ``--mid`` bag (one run) and the long one.
Also prints what start-up alone costs (an empty interpreter, numpy, scipy, the replay's
imports) so that the short bag's ratio can be read against it.

The package's modules are byte-compiled first (as an installed package is), like rosbags' in
site-packages.  ``--all-joints`` adds the replay of all six joints.
"""

import argparse
import compileall
import os
from pathlib import Path
import resource
import subprocess
import sys
import tempfile
import time

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
    "the replay's imports": ('import sys\n'
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
    figures = {
        'bytes only': _fastest(_BYTES_ONLY, str(bag), repeat=repeat),
        'read': _fastest(_READ, str(bag), repeat=read_repeat),
        'replay': _fastest(_REPLAY, *_replay_args(bag, folder / f'out_{bag.name}', *joint),
                           repeat=repeat),
    }
    if all_joints:
        figures['replay, all 6 joints'] = _fastest(
            _REPLAY, *_replay_args(bag, folder / f'out6_{bag.name}', '--joint', 'all',
                                   *joint[2:]), repeat=repeat)
    return figures


def main(argv=None):
    """Run the benchmark and print one line per measurement and the verdict."""
    parser = argparse.ArgumentParser(description=__doc__.strip().splitlines()[0])
    parser.add_argument('--experiments', type=int, default=60, help='the short bag')
    parser.add_argument('--long', type=int, default=600, help='the long bag (0: skip)')
    parser.add_argument('--mid', type=int, default=150,
                        help='a bag of more than 64 experiments for the memory check (0: skip)')
    parser.add_argument('--repeat', type=int, default=3, help='runs per figure (the fastest)')
    parser.add_argument('--all-joints', action='store_true', help='add --joint all replays')
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
    print(f'{os.cpu_count()} cores, Python {sys.version.split()[0]}, fastest of {args.repeat}; '
          f'bags in {folder}')
    for label, code in _STARTUP.items():
        seconds, rss, _, cpu = _fastest(code, repeat=args.repeat)
        print(f'start-up, {label:42s}: {seconds:6.2f} s (CPU {cpu:5.2f} s), peak RSS '
              f'{rss / 1024:5.0f} MB')
    results = {}
    for n in sizes:
        bag = bags[n]
        # the read of the long bag (a reference, no target) once: it takes minutes
        figures = results[n] = _measure(bag, folder, joint, args.repeat,
                                        args.repeat if n == sizes[0] else 1, args.all_joints)
        count = int(figures['bytes only'][2])
        print(f'--- {n} experiments: {count} JointState messages (6 joints, 250 Hz)')
        raw_s, read_s = figures['bytes only'][0], figures['read'][0]
        raw_cpu = figures['bytes only'][3]
        for label, (seconds, rss, line, cpu) in figures.items():
            text = (f'{label:22s}: {seconds:6.2f} s {count / seconds:10,.0f} msg/s (CPU '
                    f'{cpu:5.2f} s), peak RSS {rss / 1024:5.0f} MB')
            if label.startswith('replay'):
                text += (f'; {raw_s / seconds:4.2f} x the bytes-only process '
                         f'(CPU: {raw_cpu / cpu:4.2f} x), {read_s / seconds:4.2f} x the read  '
                         f'[{line}]')
            print(text)
    print('--- verdict (replay throughput / bytes-only process throughput)')
    targets = {args.experiments: (0.7, None)}
    if args.long:
        targets[args.long] = (1.0, 2.0)
    for n, (target, aim) in targets.items():
        ratio = results[n]['bytes only'][0] / results[n]['replay'][0]
        cpu_ratio = results[n]['bytes only'][3] / results[n]['replay'][3]
        verdict = 'MET' if ratio >= target else 'NOT MET'
        print(f'{n:5d} experiments: {ratio:4.2f} x (target >= {target:.1f} x'
              + (f', aim {aim:.0f} x' if aim else '') + f'): {verdict}  (CPU seconds: '
              f'{cpu_ratio:4.2f} x)')
    if args.long:
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
    return 0


if __name__ == '__main__':
    sys.exit(main())
