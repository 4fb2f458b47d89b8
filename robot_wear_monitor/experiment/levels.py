"""
Data types passed between segmentation, estimation and the service: friction levels.

These are the contract between the friction experiment (eq. (3)) and the estimator (16)-(19):
a :class:`FrictionLevel` is one constant-speed friction level from a forward/backward pair, and a
:class:`FrictionExperiment` is the set of levels of one run of the experiment.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np
from numpy.typing import ArrayLike


@dataclass(frozen=True)
class FrictionLevel:
    """
    One friction level tau_f = (tau+ - tau-)/2 of eq. (3) from a forward/backward pass pair.

    :ivar speed_rad_s: motor-side speed level (positive), mean |speed| of the two passes.
    :ivar friction: tau_f, normalised torque (effort / torque_scale).
    :ivar friction_std_error: standard error of tau_f from the within-pass scatter, normalised.
    :ivar tau_forward: mean normalised torque of the forward (positive-speed) pass.
    :ivar tau_backward: mean normalised torque of the backward (negative-speed) pass.
    :ivar n_forward: samples averaged in the forward pass.
    :ivar n_backward: samples averaged in the backward pass.
    :ivar position_min_rad: lower end of the joint-side position window both passes cover.
    :ivar position_max_rad: upper end of that window.
    :ivar start_time_s: time of the first sample used [s].
    :ivar end_time_s: time of the last sample used [s].

    """

    speed_rad_s: float
    friction: float
    friction_std_error: float
    tau_forward: float
    tau_backward: float
    n_forward: int
    n_backward: int
    position_min_rad: float
    position_max_rad: float
    start_time_s: float
    end_time_s: float


@dataclass(frozen=True)
class FrictionExperiment:
    """The friction levels of one completed experiment, in the order they were measured."""

    levels: tuple[FrictionLevel, ...]

    @property
    def speeds_rad_s(self) -> np.ndarray:
        """Motor-side speed levels [rad/s], shape (N,)."""
        return np.array([level.speed_rad_s for level in self.levels], dtype=float)

    @property
    def frictions(self) -> np.ndarray:
        """Friction levels (normalised), shape (N,)."""
        return np.array([level.friction for level in self.levels], dtype=float)

    @property
    def start_time_s(self) -> float:
        """Time of the first sample of the experiment [s]."""
        return min(level.start_time_s for level in self.levels)

    @property
    def end_time_s(self) -> float:
        """Time of the last sample of the experiment [s]."""
        return max(level.end_time_s for level in self.levels)


def against_the_motion(friction: ArrayLike) -> tuple[bool, float]:
    """
    Return whether friction levels were recorded against the motion, and their median.

    Friction opposes the motion, so eq. (3)'s (tau+ - tau-)/2 is positive when the torque is
    recorded positive along the motion: levels whose median (numpy's: the mean of the middle
    two of an even count) is negative have the torque recorded the other way (the KUKA files).
    ``friction``: the levels' friction, shape (N,), N >= 1, in any one unit (normalised, N.m).
    """
    median = float(np.median(np.asarray(friction, dtype=float)))
    return median < 0, median


def with_other_sign(level: FrictionLevel) -> FrictionLevel:
    """Return ``level`` read with the other torque sign: friction, tau+ and tau- negated."""
    return replace(level, friction=-level.friction, tau_forward=-level.tau_forward,
                   tau_backward=-level.tau_backward)
