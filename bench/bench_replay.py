"""End-to-end replay rate against rosbags' raw message iteration of the same bag, in one run.

    python3 bench/bench_replay.py [--experiments 100] [--keep DIR]

Simulates an accelerated wear scenario into an MCAP bag, then times (1) rosbags iterating the
raw messages, (2) rosbags iterating and deserialising every JointState, (3) the full replay
(read + segmentation + estimation + alarm + writing every output topic), and prints messages
per second for each.
"""

import argparse
from pathlib import Path
import sys
import tempfile
import time

from rosbags.rosbag2 import Reader

from robot_wear_monitor.recordings.bags import TYPESTORE, write_joint_state_bag
from robot_wear_monitor.monitoring.replay import replay_bag, replay_parameters
from robot_wear_monitor.experiment.simulation import accelerated_wear_scenario, simulate_scenario


def _time(function):
    start = time.perf_counter()
    value = function()
    return time.perf_counter() - start, value


def main(argv=None):
    """Run the benchmark and print one line per measurement."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument('--experiments', type=int, default=100)
    parser.add_argument('--keep', metavar='DIR', help='keep the bags in DIR')
    args = parser.parse_args(argv)
    folder = Path(args.keep) if args.keep else Path(tempfile.mkdtemp(prefix='bench_replay_'))
    folder.mkdir(parents=True, exist_ok=True)
    scenario = simulate_scenario(
        config=accelerated_wear_scenario(n_experiments=args.experiments, seed=0), seed=0)
    bag = folder / 'scenario'
    write_joint_state_bag(bag, stamps_s=scenario.time_s, names=scenario.joint_names,
                          position=scenario.position_rad, velocity=scenario.velocity_rad_s,
                          effort=scenario.effort, overwrite=True)

    def raw():
        with Reader(bag) as reader:
            return sum(1 for _ in reader.messages())

    def deserialised():
        with Reader(bag) as reader:
            return sum(1 for c, _, data in reader.messages()
                       if TYPESTORE.deserialize_cdr(data, c.msgtype) is not None)

    experiment, estimator = replay_parameters(joint=scenario.joint,
                                              gear_ratio=scenario.config.gear_ratio,
                                              torque_scale=scenario.config.torque_scale)
    raw_s, count = _time(raw)
    deser_s, _ = _time(deserialised)
    replay_s, result = _time(lambda: replay_bag(
        bag, out_bag=folder / 'out', experiment_parameters=experiment,
        estimator_parameters=estimator, overwrite=True))
    print(f'bag: {count} JointState messages, {len(result.updates)} experiments '
          f'({args.experiments} simulated), {folder}')
    print(f'rosbags raw iteration        : {raw_s:7.2f} s  {count / raw_s:12,.0f} msg/s')
    print(f'rosbags iterate + deserialise: {deser_s:7.2f} s  {count / deser_s:12,.0f} msg/s')
    print(f'replay end to end            : {replay_s:7.2f} s  {count / replay_s:12,.0f} msg/s '
          f'({replay_s / raw_s:.1f}x raw iteration, {replay_s / deser_s:.2f}x deserialise)')
    return 0


if __name__ == '__main__':
    sys.exit(main())
