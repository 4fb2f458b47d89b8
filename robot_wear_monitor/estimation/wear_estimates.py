"""
The estimates of (T, w) as the estimator returns them, and the checks of its inputs.

:class:`WearEstimates` is a batch of B estimates at the same N speeds (``estimates[i]`` is a
:class:`WearEstimate`); :func:`validate_speeds`, :func:`validate_friction` and
:func:`validate_levels` check the inputs of the estimator and the intervals
(:func:`~robot_wear_monitor.estimation.estimator.estimate_wear`,
:mod:`~robot_wear_monitor.estimation.intervals`); :func:`fit_p_value` is the model check's
p-value of a fit.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Iterator

import numpy as np
from numpy.typing import ArrayLike, NDArray
from robot_wear_monitor.array_types import FloatArray
from robot_wear_monitor.errors import InputError
from robot_wear_monitor.estimation.special_functions import chi2_survival

#: The most friction levels one experiment may have (the designs use 1-20; the cost of an
#: estimate grows with N^2 and its interval's calibration with N).
MAX_LEVELS = 100


@dataclass(frozen=True)
class WearEstimate:
    """
    One estimate of (T, w) with its uncertainty and goodness of fit.

    :ivar temperature_degc: estimated joint temperature [degC] (N = 1: posterior mean of T under
        the uniform prior at the estimated w).
    :ivar wear: estimated wear level w [-].
    :ivar covariance: 2x2 covariance of (T, w), inverse Fisher information at the estimate
        (N = 1: w from the marginal Fisher information, T from the posterior).
    :ivar temperature_at_bound: the estimate of T lies on a temperature bound.
    :ivar wear_at_bound: the estimate of w lies on w = 0.
    :ivar chi2: weighted residual sum of squares r^T Sigma^-1 r at the estimate.
    :ivar dof: degrees of freedom of chi2 (N minus the parameters estimated in the interior).
    :ivar p_value: P(chi2_dof >= chi2); NaN when dof = 0 (no redundancy to test the fit).
    :ivar n_levels: number N of friction levels used.
    :ivar speeds_rad_s: the motor-side speeds [rad/s] of the levels, shape (N,).

    """

    temperature_degc: float
    wear: float
    covariance: np.ndarray
    temperature_at_bound: bool
    wear_at_bound: bool
    chi2: float
    dof: int
    p_value: float
    n_levels: int
    speeds_rad_s: np.ndarray

    @property
    def wear_std(self) -> float:
        """Return the standard deviation of the wear estimate [-]."""
        return float(np.sqrt(self.covariance[1, 1]))

    @property
    def temperature_std_degc(self) -> float:
        """Return the standard deviation of the temperature estimate [degC]."""
        return float(np.sqrt(self.covariance[0, 0]))


@dataclass(frozen=True)
class WearEstimates:
    """
    A batch of B estimates at the same N speeds; ``estimates[i]`` is a :class:`WearEstimate`.

    :ivar temperature_degc: shape (B,) [degC].
    :ivar wear: shape (B,) [-].
    :ivar covariance: shape (B, 2, 2), covariance of (T, w).
    :ivar temperature_at_bound: shape (B,), bool.
    :ivar wear_at_bound: shape (B,), bool.
    :ivar chi2: shape (B,).
    :ivar dof: shape (B,), int.
    :ivar p_value: shape (B,), NaN where dof = 0.
    :ivar n_levels: N.
    :ivar speeds_rad_s: shape (N,) [rad/s].

    """

    temperature_degc: FloatArray
    wear: FloatArray
    covariance: FloatArray
    temperature_at_bound: NDArray[np.bool_]
    wear_at_bound: NDArray[np.bool_]
    chi2: FloatArray
    dof: NDArray[np.int64]
    p_value: FloatArray
    n_levels: int
    speeds_rad_s: FloatArray

    def __len__(self) -> int:
        """Return the batch size B."""
        return int(self.wear.shape[0])

    def __getitem__(self, index: int) -> WearEstimate:
        """Return estimate ``index`` (negative indices count from the end)."""
        i = range(len(self))[index]
        return WearEstimate(
            temperature_degc=float(self.temperature_degc[i]), wear=float(self.wear[i]),
            covariance=self.covariance[i].copy(),
            temperature_at_bound=bool(self.temperature_at_bound[i]),
            wear_at_bound=bool(self.wear_at_bound[i]), chi2=float(self.chi2[i]),
            dof=int(self.dof[i]), p_value=float(self.p_value[i]), n_levels=self.n_levels,
            speeds_rad_s=self.speeds_rad_s.copy())

    def __iter__(self) -> Iterator[WearEstimate]:
        """Iterate over the estimates of the batch."""
        return (self[i] for i in range(len(self)))

    @property
    def wear_std(self) -> FloatArray:
        """Return the standard deviations of the wear estimates, shape (B,)."""
        return np.sqrt(self.covariance[:, 1, 1])

    @property
    def temperature_std_degc(self) -> FloatArray:
        """Return the standard deviations of the temperature estimates [degC], shape (B,)."""
        return np.sqrt(self.covariance[:, 0, 0])


# --------------------------------------------------------------------------- input validation

def validate_speeds(speeds_rad_s: ArrayLike) -> FloatArray:
    """Return the speeds as a 1-D float array; raise InputError unless finite, > 0, N >= 1."""
    try:
        speeds = np.asarray(speeds_rad_s, dtype=float)
    except (TypeError, ValueError):
        raise InputError(f'speeds: not numbers: {speeds_rad_s!r}') from None
    if speeds.ndim != 1:
        raise InputError(f'speeds: expected a 1-D list of speeds, got shape {speeds.shape}')
    if speeds.size == 0:
        raise InputError('speeds: no speed levels given (N = 0)')
    if speeds.size > MAX_LEVELS:
        raise InputError(f'speeds: {speeds.size} levels, more than the {MAX_LEVELS} one '
                         'experiment may have')
    if not np.all(np.isfinite(speeds)):
        raise InputError(f'speeds: must be finite, got {str(speeds.tolist())[:80]}')
    if np.any(speeds <= 0):
        raise InputError(f'speeds: must be > 0 rad/s (motor side), got '
                         f'{str(speeds.tolist())[:80]}')
    return speeds


def validate_friction(friction: ArrayLike, n_levels: int) -> FloatArray:
    try:
        values = np.asarray(friction, dtype=float)
    except (TypeError, ValueError):
        raise InputError('friction: not numbers') from None
    if values.ndim == 1:
        values = values[None, :]
    if values.ndim != 2 or values.shape[1] != n_levels:
        raise InputError(f'friction: expected shape ({n_levels},) or (B, {n_levels}) to match '
                         f'{n_levels} speed(s), got shape {np.shape(friction)}')
    if not np.all(np.isfinite(values)):
        raise InputError('friction: contains NaN or infinite values')
    return values


def validate_levels(speeds_rad_s: ArrayLike,
                    friction: ArrayLike) -> tuple[FloatArray, FloatArray]:
    """
    Return the checked speed levels (M,) [rad/s] and friction levels (B, M) of one experiment.

    :func:`validate_speeds` and :func:`validate_friction` with M the number of speeds.
    """
    speeds = validate_speeds(speeds_rad_s)
    return speeds, validate_friction(friction, speeds.size)


def fit_p_value(chi2: FloatArray, dof: NDArray[np.int64]) -> FloatArray:
    """Return the chi-square tail P(X >= chi2) of ``dof`` degrees; NaN where dof = 0."""
    with np.errstate(invalid='ignore'):
        return np.where(dof > 0, chi2_survival(chi2, np.maximum(dof, 1)), np.nan)
