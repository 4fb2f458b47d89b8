"""
Duration of the planned friction experiment (experiment/planning.py), against the paper.

Run as ``python3 bench/bench_plan.py``.  Prints, for the Table V N = 4 design (2.1, 28.5, 35.1,
41.7 rad/s, motor side) at the simulated IRB 6620 joint 2 settings of this package (gear ratio
150, 10 rad/s^2, window 0.2 +- 0.5 rad, 250 Hz, torque noise 0.01 per sample), the plan's
duration per speed and in total, for trapezoidal and jerk-limited ramps and three accuracy
targets, and the time to plan.  The paper's reference: one speed optimised down to 2.5 s of
robot time (Sec. IV-D).  Figures of one run, no assertions.
"""

from __future__ import annotations

from pathlib import Path
import sys
import time

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from robot_wear_monitor.experiment.planning import (plan_experiment, plan_summary,  # noqa: E402
                                                    PlanConfig)

SPEEDS = (2.1, 28.5, 35.1, 41.7)
SETTINGS = {'joint': 'joint_2', 'speeds_rad_s': SPEEDS, 'center_rad': 0.2, 'half_range_rad': 0.5,
            'gear_ratio': 150.0, 'max_acceleration_rad_s2': 10.0, 'rate_hz': 250.0,
            'noise_std': 0.01}


def main() -> None:
    """Print the durations."""
    print('Table V N = 4 at gear ratio 150, 10 rad/s^2, 250 Hz, noise 0.01 (paper: 2.5 s per '
          'speed)')
    print(f'{"ramps":<22}{"target E":>9}{"plateau [s]":>13}{"per speed [s]":>28}'
          f'{"total [s]":>11}{"plan [ms]":>11}')
    for ramps, jerk in (('trapezoidal', None), ('jerk 100 rad/s^3', 100.0)):
        for target in (2e-3, 1e-3, 5e-4):
            start = time.perf_counter()
            plan = plan_experiment(config=PlanConfig(**SETTINGS, max_jerk_rad_s3=jerk,
                                                     target_std_error=target))
            elapsed = 1e3 * (time.perf_counter() - start)
            summary = plan_summary(plan)
            per_speed = ', '.join(f'{row["duration_s"]:.2f}' for row in summary['per_speed'])
            print(f'{ramps:<22}{target:>9g}{summary["plateau_s"]:>13.3f}{per_speed:>28}'
                  f'{plan.total_s:>11.2f}{elapsed:>11.2f}')


if __name__ == '__main__':
    main()
