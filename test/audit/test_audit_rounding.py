"""
The audit's fits and scans do not follow rounding (the BLAS summation order).

A Stribeck speed that the data do not determine (a joint without a Stribeck rise) leaves the sum
of squares flat to rounding; a period scan with two equal peaks is a tie.  Without care the
result then depends on the order of summation, i.e. on the number of BLAS threads, and the
CLI (one thread) and the library (default threads) disagreed on the KUKA audit.  Here the
data are perturbed at the rounding level (1e-14 relative) instead: the fit must not move.
The KUKA audit itself is compared under one and under several threads in test_audit_kuka.py.
"""

import numpy as np
import pytest
from robot_wear_monitor.audit.fitting import AuditTable, fit_model, speed_base
from robot_wear_monitor.audit.significance import periodic_scan

SPEEDS = np.geomspace(0.05, 1.0, 9)  # rad/s
# per joint: F_c, F_s, phi_s [rad/s], F_v; joint j1 has no Stribeck rise, j2 almost none
JOINTS = ((1.0, 0.8, 0.15, 0.5), (0.6, 0.0, 0.2, 0.9), (0.8, 0.02, 0.5, 0.3))


def speed_table(seed):
    rng = np.random.default_rng(seed)
    joint, speed, friction = [], [], []
    for j, (f_c, f_s, phi, f_v) in enumerate(JOINTS):
        for v in np.repeat(SPEEDS, 4):
            joint.append(f'j{j}')
            speed.append(v)
            friction.append(f_c + f_s * np.exp(-(v / phi) ** 1.4) + f_v * v
                            + 0.02 * rng.standard_normal())
    return AuditTable({'speed': np.array(speed), 'friction': np.array(friction)},
                      {'joint': np.array(joint)})


@pytest.mark.parametrize('seed', [1, 2, 3])
def test_a_rounding_perturbation_does_not_move_the_fitted_stribeck_parameters(seed):
    table = speed_table(seed)
    base = speed_base(table, 'joint')
    fit = fit_model(base, table, [], base.theta0)
    y = table.numeric['friction']
    for k in range(4):
        noise = np.random.default_rng(100 + k).standard_normal(len(y)) * 1e-14 * np.abs(y)
        perturbed = AuditTable({'speed': table.numeric['speed'], 'friction': y + noise},
                               table.text)
        again = fit_model(base, perturbed, [], base.theta0)
        # (log phi_s, alpha) per joint: the flat directions of j1 and j2 included
        np.testing.assert_allclose(again.theta, fit.theta, rtol=0, atol=2e-5)
    # the joint with a clear Stribeck rise is still identified (phi_s = 0.15 rad/s)
    assert abs(np.exp(fit.theta[0]) / 0.15 - 1) < 0.3


def _two_peaks(f_low, f_high, excess):
    """Return a test of log p with peaks at f_low and f_high (deeper by ``excess``, relative)."""
    def test(basis):
        f = float(basis[0, 0])
        log_p = -50.0 * (np.exp(-((f - f_low) / 0.05) ** 2)
                         + (1.0 + excess) * np.exp(-((f - f_high) / 0.05) ** 2))
        return float(log_p), 2
    return test


def test_a_period_scan_with_two_equal_peaks_takes_the_longest_period():
    frequencies = np.arange(1.0, 10.01, 0.25) / 10.0  # 1/N.m, the peaks on the grid
    basis_of = lambda f: np.full((3, 2), f)  # noqa: E731
    # a tie to rounding: the deeper peak by 1e-13 does not win, the lower frequency does
    _, period = periodic_scan(basis_of, frequencies, _two_peaks(0.3, 0.7, 1e-13))
    assert period == pytest.approx(1 / 0.3, rel=1e-3)
    # a real difference decides
    _, period = periodic_scan(basis_of, frequencies, _two_peaks(0.3, 0.7, 1e-3))
    assert period == pytest.approx(1 / 0.7, rel=1e-3)
