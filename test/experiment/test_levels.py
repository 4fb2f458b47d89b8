"""
The sign of friction levels from their median (experiment/levels.py).

The rule is shared by raw runs, position-binned runs and the speed model's refusal. Friction
opposes the motion: eq. (3)'s (tau+ - tau-)/2 of a torque recorded along the motion is
positive, so levels whose median is negative were recorded the other way and are read negated.
"""

from dataclasses import replace

import pytest
from robot_wear_monitor.experiment.levels import against_the_motion, FrictionLevel, with_other_sign


def test_the_median_decides_not_the_mean_nor_one_level():
    # most levels negative, one large positive outlier: the mean is positive, the median is not
    assert against_the_motion([-0.2, -0.3, -0.25, 5.0, -0.1]) == (True, -0.2)
    # most levels positive, one large negative outlier
    assert against_the_motion([0.2, 0.3, -9.0]) == (False, 0.2)
    # an even count: numpy's median, the mean of the middle two (-0.1 and 0.3)
    against, median = against_the_motion([-0.5, -0.1, 0.3, 0.4])
    assert not against and median == pytest.approx(0.1)
    against, median = against_the_motion([-0.5, -0.3, 0.1, 0.4])
    assert against and median == pytest.approx(-0.1)
    # a median of exactly 0 is not against the motion (nothing to turn)
    assert against_the_motion([-1.0, 0.0, 1.0]) == (False, 0.0)


def test_the_other_sign_negates_friction_and_both_pass_torques_only():
    level = FrictionLevel(speed_rad_s=20.0, friction=-0.12, friction_std_error=0.004,
                          tau_forward=-0.5, tau_backward=-0.26, n_forward=40, n_backward=38,
                          position_min_rad=-0.3, position_max_rad=0.4, start_time_s=10.0,
                          end_time_s=12.5)
    turned = with_other_sign(level)
    assert (turned.friction, turned.tau_forward, turned.tau_backward) == (0.12, 0.5, 0.26)
    # eq. (3) still holds: (tau+ - tau-)/2 of the turned torques is the turned friction
    assert (turned.tau_forward - turned.tau_backward) / 2 == pytest.approx(turned.friction)
    assert replace(turned, friction=level.friction, tau_forward=level.tau_forward,
                   tau_backward=level.tau_backward) == level  # nothing else changed
    assert with_other_sign(turned) == level
