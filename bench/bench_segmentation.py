"""Segmentation throughput: batch samples/s and streaming cost per message (prints only)."""

import time

from robot_wear_monitor.experiment.segmentation import segment_batch, StreamingSegmenter
from robot_wear_monitor.experiment.simulation import (accelerated_wear_scenario,
                                                      segmenter_config_for, simulate_scenario)


def main() -> None:
    """Simulate a 100-experiment wear test and time both segmentation paths."""
    scenario = simulate_scenario(config=accelerated_wear_scenario(n_experiments=100), seed=0)
    config = segmenter_config_for(scenario.config)
    t, q, v, e = scenario.joint_samples()
    start = time.perf_counter()
    result = segment_batch(time_s=t, position_rad=q, velocity_rad_s=v, effort=e, config=config)
    batch = time.perf_counter() - start
    print(f'batch: {t.size} samples, {len(result.levels)} levels in {batch:.3f} s '
          f'= {t.size / batch:,.0f} samples/s')
    segmenter = StreamingSegmenter(config)
    messages = list(scenario.messages())
    start = time.perf_counter()
    for stamp, name, position, velocity, effort in messages:
        segmenter.add_joint_state(stamp_s=stamp, name=name, position=position,
                                  velocity=velocity, effort=effort)
    segmenter.finish()
    streaming = time.perf_counter() - start
    print(f'streaming: {len(messages)} JointState messages in {streaming:.3f} s '
          f'= {1e6 * streaming / len(messages):.2f} us per message')


if __name__ == '__main__':
    main()
