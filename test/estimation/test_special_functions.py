"""The estimation path's special functions (numpy and the standard library) against scipy."""

import math
import os
import subprocess
import sys

import numpy as np
import pytest
from robot_wear_monitor.estimation.special_functions import (chi2_quantile_one_dof,
                                                             chi2_survival, erf, log_sum_exp)
from scipy import special


def test_erf_equals_scipy_to_a_few_ulp_and_saturates_exactly():
    x = np.concatenate([np.linspace(-8.0, 8.0, 20001), [0.0, -0.0, 5.9, 5.99, 6.0, 40.0,
                                                        np.inf, -np.inf]])
    ours = erf(x)
    np.testing.assert_allclose(ours, special.erf(x), rtol=1e-15, atol=1e-300)  # a few ulp
    assert np.all(np.abs(ours[np.abs(x) >= 6.0]) == 1.0)
    assert np.isnan(erf(np.array([np.nan]))[0])
    assert erf(np.zeros((2, 3))).shape == (2, 3)
    assert erf(0.5) == special.erf(0.5) and erf(np.float64(-7.0)) == -1.0  # 0-d input
    assert erf(np.array([], dtype=int)).shape == (0,)


def test_log_sum_exp_equals_scipy_including_infinite_rows():
    rng = np.random.default_rng(1)
    a = rng.normal(0.0, 300.0, (50, 7))
    a[3] = -np.inf
    a[4, :3] = -np.inf
    a[5, 2] = np.inf
    with np.errstate(invalid='ignore'):
        expected = special.logsumexp(a, axis=-1)
    np.testing.assert_allclose(log_sum_exp(a, axis=-1), expected, rtol=1e-14)
    np.testing.assert_allclose(log_sum_exp(a.T, axis=0), expected, rtol=1e-14)
    assert log_sum_exp(a[3]) == -np.inf
    np.testing.assert_array_equal(log_sum_exp(np.zeros((3, 0))), [-np.inf] * 3)  # empty sums


@pytest.mark.parametrize('dof', list(range(1, 41)) + [57, 100])
def test_chi2_survival_equals_scipy(dof):
    chi2 = np.concatenate([[0.0, 1e-12, 1e-3], np.linspace(0.01, 6.0 * dof + 60.0, 400)])
    expected = special.chdtrc(dof, chi2)
    ours = chi2_survival(chi2, dof)
    np.testing.assert_allclose(ours, expected, rtol=1e-11, atol=1e-300)


@pytest.mark.parametrize('dof', [2, 3, 99, 100, 1500, 1501, 20001])
def test_chi2_survival_far_in_the_tail_and_at_many_dof(dof):
    """Where exp(-chi2/2) underflows, the terms are summed by their logarithms."""
    chi2 = np.array([dof - 3.0 * np.sqrt(2.0 * dof), float(dof), dof + 5.0 * np.sqrt(2.0 * dof),
                     1300.0, 1250.0 + dof])
    chi2 = chi2[chi2 > 0]
    np.testing.assert_allclose(chi2_survival(chi2, dof), special.chdtrc(dof, chi2),
                               rtol=1e-10, atol=1e-300)


def test_chi2_survival_edges_and_bad_dof():
    assert chi2_survival(np.inf, 3) == 0.0
    assert chi2_survival(-1.0, 2) == 1.0
    assert np.isnan(chi2_survival(np.nan, 2))
    np.testing.assert_array_equal(chi2_survival(np.array([1.0, 2.0]), np.array([1, 2])).shape,
                                  (2,))
    for bad in (0, 1.5, -2, np.inf, np.nan, 200_000):
        with pytest.raises(ValueError, match='dof'):
            chi2_survival(1.0, bad)


@pytest.mark.parametrize('level', [0.5, 0.9, 0.95, 0.99, 0.999, 1.0 - 2.0 ** -40])
def test_chi2_quantile_one_dof_equals_scipy(level):
    assert math.isclose(chi2_quantile_one_dof(level), special.chdtri(1, 1.0 - level),
                        rel_tol=1e-12)


def test_chi2_quantile_one_dof_refuses_a_level_outside_zero_one():
    for bad in (0.0, 1.0, 1.5, float('nan')):
        with pytest.raises(ValueError, match='level'):
            chi2_quantile_one_dof(bad)


def test_the_estimation_path_and_the_replay_do_not_import_scipy():
    """
    Importing scipy takes 0.14 s, which the short replay cannot afford (issue 28).

    Nor does it load rosbags' stores of the older distributions (0.04 s).
    """
    code = ('import sys\n'
            'import robot_wear_monitor.cli.replay, robot_wear_monitor.monitoring.replay\n'
            'import robot_wear_monitor.estimation.batch_intervals\n'
            'import robot_wear_monitor.estimation.trend\n'
            'from robot_wear_monitor.blas_threads import use_single_blas_thread\n'
            'use_single_blas_thread()\n'
            'print(sorted(m for m in sys.modules if m == "scipy" or m.startswith("scipy.")'
            ' or ".stores.ros2_" in m))\n')
    env_free = {k: v for k, v in os.environ.items() if k != 'OPENBLAS_NUM_THREADS'}
    out = subprocess.run([sys.executable, '-c', code], capture_output=True, text=True,
                         check=True, env=env_free).stdout.strip()
    assert out == '[]'
