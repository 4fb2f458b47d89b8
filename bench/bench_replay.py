"""Replay rate against rosbags reading the same bag, and peak memory against the bag's length.

    python3 bench/bench_replay.py [--experiments 60] [--long 600] [--keep DIR]

Simulates an accelerated wear scenario of ``--experiments`` experiments into an MCAP bag of
/joint_states (6 joints, 250 Hz), then, in one run:

* rosbags' raw message iteration (bytes only) and iteration with deserialisation of every
  JointState (``deserialize_cdr``: the plain read of the same message bytes), in this process;
* ``robot-wear-monitor replay`` as a new process, start-up included (imports, reading,
  segmentation, estimation, intervals, trend, writing every output topic), for one joint with
  the speeds found in the data (the default), one joint with the speeds configured (no
  discovery), and all six joints (``--joint all``);
* the peak resident memory of the replay process for this bag and for a ``--long`` bag
  (0: skipped): the replay streams the bag in chunks, so the two should differ little.

Prints messages per second for each and the ratios (replay throughput / read throughput);
each figure is the fastest of three runs.
"""

import argparse
import os
from pathlib import Path
import resource
import subprocess
import sys
import tempfile
import time

from rosbags.rosbag2 import Reader

from robot_wear_monitor.experiment.simulation import accelerated_wear_scenario, simulate_scenario
from robot_wear_monitor.recordings.bags import TYPESTORE, write_joint_state_bag

# runs the CLI's main in a child and prints its peak RSS (kB, VmHWM of /proc: getrusage's
# maxrss would carry the parent's peak over the exec) on stderr's last line
_CHILD = ('import sys\n'
          'from robot_wear_monitor.cli import main\n'
          'code = main(sys.argv[1:])\n'
          'peak = [line.split()[1] for line in open("/proc/self/status")'
          ' if line.startswith("VmHWM")][0]\n'
          'print("peak_rss_kb", peak, file=sys.stderr)\n'
          'sys.exit(code)\n')


def _write_bag(folder: Path, experiments: int) -> tuple[Path, object]:
    scenario = simulate_scenario(
        config=accelerated_wear_scenario(n_experiments=experiments, seed=0), seed=0)
    bag = folder / f'scenario_{experiments}'
    write_joint_state_bag(bag, stamps_s=scenario.time_s, names=scenario.joint_names,
                          position=scenario.position_rad, velocity=scenario.velocity_rad_s,
                          effort=scenario.effort, overwrite=True)
    return bag, scenario


def _write_bag_in_child(folder: Path, experiments: int) -> Path:
    """Write the long bag from a child process (the simulation holds it all in memory)."""
    code = ('import sys; from pathlib import Path; sys.path.insert(0, sys.argv[1]); '
            'import bench_replay; bench_replay._write_bag(Path(sys.argv[2]), int(sys.argv[3]))')
    subprocess.run([sys.executable, '-c', code, str(Path(__file__).parent), str(folder),
                    str(experiments)], check=True)
    return folder / f'scenario_{experiments}'


def _replay(bag: Path, out: Path, *extra: str, repeat: int = 3) -> tuple[float, int, str]:
    """Run the replay CLI in new processes; return the fastest (wall s, peak RSS kB, stdout).

    The fastest of ``repeat`` runs: the figure least disturbed by other work on the machine.
    """
    return min(_replay_once(bag, out, *extra) for _ in range(repeat))


def _replay_once(bag: Path, out: Path, *extra: str) -> tuple[float, int, str]:
    """Run the replay CLI in a new process; return (wall s, peak RSS kB, stdout)."""
    command = [sys.executable, '-c', _CHILD, 'replay', str(bag), '--out', str(out),
               '--overwrite', '--no-progress', *extra]
    start = time.perf_counter()
    done = subprocess.run(command, capture_output=True, text=True, env=dict(os.environ))
    elapsed = time.perf_counter() - start
    if done.returncode != 0:
        raise SystemExit(f'replay failed ({done.returncode}): {done.stderr.strip()}')
    rss = int(done.stderr.strip().splitlines()[-1].split()[-1])
    return elapsed, rss, done.stdout.strip().splitlines()[0]


def _seconds(function) -> float:
    start = time.perf_counter()
    function()
    return time.perf_counter() - start


def main(argv=None):
    """Run the benchmark and print one line per measurement."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument('--experiments', type=int, default=60)
    parser.add_argument('--long', type=int, default=600,
                        help='experiments of the bag for the memory comparison (0: skip)')
    parser.add_argument('--keep', metavar='DIR', help='keep the bags in DIR')
    args = parser.parse_args(argv)
    folder = Path(args.keep) if args.keep else Path(tempfile.mkdtemp(prefix='bench_replay_'))
    folder.mkdir(parents=True, exist_ok=True)
    bag, scenario = _write_bag(folder, args.experiments)
    config = folder / 'speeds.yaml'
    speeds = ', '.join(f'{v:.1f}' for v in scenario.truth[0].speeds_rad_s)
    config.write_text(f'friction_experiment_node:\n  ros__parameters:\n'
                      f'    experiment_speeds_rad_s: [{speeds}]\n')
    joint = ['--joint', scenario.joint, '--gear-ratio', str(scenario.config.gear_ratio),
             '--torque-scale', str(scenario.config.torque_scale)]

    def raw():
        with Reader(bag) as reader:
            return sum(1 for _ in reader.messages())

    def deserialised():
        with Reader(bag) as reader:
            return sum(1 for c, _, data in reader.messages()
                       if TYPESTORE.deserialize_cdr(data, c.msgtype) is not None)

    count = raw()
    raw_s = min(_seconds(raw) for _ in range(3))
    read_s = min(_seconds(deserialised) for _ in range(3))
    _replay_once(bag, folder / 'warm', *joint)  # a design's first run may store its calibration
    runs = {
        'replay, 1 joint, speeds found': _replay(bag, folder / 'out1', *joint),
        'replay, 1 joint, speeds set': _replay(bag, folder / 'out2', *joint, '--config',
                                               str(config)),
        'replay, all 6 joints': _replay(bag, folder / 'out6', '--joint', 'all',
                                        '--gear-ratio', str(scenario.config.gear_ratio),
                                        '--torque-scale', str(scenario.config.torque_scale)),
    }
    print(f'bag: {count} JointState messages (6 joints), {args.experiments} experiments, '
          f'{bag}')
    print(f'rosbags raw iteration (bytes)       : {raw_s:6.2f} s {count / raw_s:10,.0f} msg/s')
    print(f'rosbags iterate + deserialise (read): {read_s:6.2f} s {count / read_s:10,.0f} msg/s')
    for label, (seconds, rss, line) in runs.items():
        print(f'{label:36s}: {seconds:6.2f} s {count / seconds:10,.0f} msg/s, '
              f'{read_s / seconds:4.2f} of the read rate, {raw_s / seconds:4.2f} of the raw '
              f'iteration; peak RSS {rss / 1024:5.0f} MB  [{line}]')
    found = runs['replay, 1 joint, speeds found'][0]
    configured = runs['replay, 1 joint, speeds set'][0]
    print(f'discovery costs {100 * (found / configured - 1):+.1f} % of the replay time '
          f'(speeds found vs set)')
    if args.long:
        long_bag = _write_bag_in_child(folder, args.long)
        with Reader(long_bag) as reader:
            long_count = sum(1 for _ in reader.messages())
        seconds, rss, line = _replay(long_bag, folder / 'out_long', *joint, repeat=1)
        short_rss = runs['replay, 1 joint, speeds found'][1]
        print(f'replay, 1 joint, {args.long} experiments: {seconds:6.2f} s '
              f'{long_count / seconds:10,.0f} msg/s; peak RSS {rss / 1024:5.0f} MB against '
              f'{short_rss / 1024:5.0f} MB for {args.experiments} experiments '
              f'({(rss - short_rss) / 1024:+.0f} MB)  [{line}]')
    print(f'this process: peak RSS '
          f'{resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024:.0f} MB')
    return 0


if __name__ == '__main__':
    sys.exit(main())
