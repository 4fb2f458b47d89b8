"""Bag rates: write, rosbags raw iteration, our reader (one joint, all joints), deserialising."""

from pathlib import Path
import tempfile
import time

from robot_wear_monitor.experiment.simulation import accelerated_wear_scenario, simulate_scenario
from robot_wear_monitor.recordings.bags import (iter_joint_chunks, JOINT_STATE_TYPE,
                                                read_joint_samples, TYPESTORE,
                                                write_joint_state_bag)
from rosbags.rosbag2 import Reader


def _rate(count: int, seconds: float) -> str:
    return f'{seconds:.2f} s = {count / seconds:,.0f} msg/s'


def main() -> None:
    """Write a 100-experiment wear test and compare the read paths on the same bag."""
    start = time.perf_counter()
    scenario = simulate_scenario(config=accelerated_wear_scenario(n_experiments=100), seed=0)
    simulated = time.perf_counter() - start
    with tempfile.TemporaryDirectory() as folder:
        bag = Path(folder) / 'bench'
        start = time.perf_counter()
        write_joint_state_bag(bag, stamps_s=scenario.time_s, names=scenario.joint_names,
                              position=scenario.position_rad, velocity=scenario.velocity_rad_s,
                              effort=scenario.effort)
        written = time.perf_counter() - start
        n = scenario.n_samples
        print(f'simulate {n} samples: {simulated:.2f} s; write MCAP: {_rate(n, written)}')
        start = time.perf_counter()
        with Reader(bag) as reader:
            count = sum(1 for _ in reader.messages())
        raw = time.perf_counter() - start
        start = time.perf_counter()
        samples = read_joint_samples(bag, joint=scenario.joint)
        fast = time.perf_counter() - start
        start = time.perf_counter()
        stream = iter_joint_chunks(bag, joints=None)
        samples_all = sum(len(part) for chunk in stream for part in chunk.values())
        every = time.perf_counter() - start
        start = time.perf_counter()
        with Reader(bag) as reader:
            for _, _, data in reader.messages():
                TYPESTORE.deserialize_cdr(data, JOINT_STATE_TYPE)
        plain = time.perf_counter() - start
        print(f'rosbags raw iteration:      {_rate(count, raw)}')
        print(f'read_joint_samples (ours):  {_rate(samples.message_count, fast)} '
              f'({fast / raw:.2f} x raw)')
        print(f'iter_joint_chunks (all {len(stream.joints_seen)} joints): '
              f'{_rate(stream.message_count, every)} ({every / raw:.2f} x raw, '
              f'{samples_all} joint samples)')
        print(f'deserialize_cdr per msg:    {_rate(count, plain)} ({plain / raw:.2f} x raw)')


if __name__ == '__main__':
    main()
