"""Maximum-likelihood estimation of temperature T and wear w from friction levels.

N >= 2 levels: the weighted nonlinear least squares (16), the load marginalised into the
covariance (11)-(14), T bounded, w >= 0, started from a coarse grid.  N = 1: the marginal
likelihood (17) with T integrated out by deterministic quadrature, maximised in w (19).
Vectorised: one call estimates a batch of friction vectors measured at the same speeds.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .params import ParameterSet


@dataclass(frozen=True)
class WearEstimate:
    """One estimate of (T, w) with its uncertainty and goodness of fit.

    Attributes:
        temperature_degc: estimated joint temperature [degC] (N = 1: posterior mean of T under
            the uniform prior at the estimated w).
        wear: estimated wear level w [-].
        covariance: 2x2 covariance of (T, w), inverse Fisher information at the estimate
            (N = 1: w from the marginal Fisher information, T from the posterior).
        temperature_at_bound: the estimate of T lies on a temperature bound.
        wear_at_bound: the estimate of w lies on w = 0.
        chi2: weighted residual sum of squares r^T Sigma^-1 r at the estimate.
        dof: degrees of freedom of chi2 (N minus the parameters estimated in the interior).
        p_value: P(chi2_dof >= chi2); NaN when dof = 0 (no redundancy to test the fit).
        n_levels: number N of friction levels used.
        speeds_rad_s: the motor-side speeds [rad/s] of the levels, shape (N,).

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
        """Standard deviation of the wear estimate [-]."""
        return float(np.sqrt(self.covariance[1, 1]))

    @property
    def temperature_std_degc(self) -> float:
        """Standard deviation of the temperature estimate [degC]."""
        return float(np.sqrt(self.covariance[0, 0]))


def estimate_wear(speeds_rad_s, friction, *, params: ParameterSet):
    """Estimate (T, w) for a batch of friction vectors measured at the same speeds.

    Args:
        speeds_rad_s: motor-side speeds [rad/s], shape (N,), all > 0.
        friction: friction levels (normalised), shape (N,) or (B, N).
        params: the parameter set (model, sigma, load mean/std, temperature bounds).

    Returns:
        A :class:`WearEstimates` batch (arrays of length B); ``estimates[i]`` is a
        :class:`WearEstimate`.

    """
    raise NotImplementedError
