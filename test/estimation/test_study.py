"""Tests of the Monte Carlo study of Sec. IV-C (Fig. 8)."""

import numpy as np
import pytest
from robot_wear_monitor.errors import InputError
from robot_wear_monitor.estimation.study import (cramer_rao_bound, plot_study, run_study,
                                                 simulate_friction)
from robot_wear_monitor.model.params import load_parameter_set

PARAMS = load_parameter_set()


def _study(n_speeds, seed=3, runs=150):
    speeds = {1: [38.63], 2: [35.84, 40.84]}[n_speeds]
    return run_study(speeds_rad_s=speeds, temperatures_degc=[32.0, 40.0, 48.0], wear=35.0,
                     runs=runs, seed=seed, params=PARAMS, progress=False)


def test_study_is_reproducible_and_its_statistics_are_consistent():
    a, b, c = _study(2), _study(2), _study(2, seed=4)
    np.testing.assert_array_equal(a.mean, b.mean)
    assert not np.allclose(a.mean, c.mean)
    np.testing.assert_allclose(a.bias, a.mean - 35.0)
    # MSE = (R-1)/R variance + bias^2
    np.testing.assert_allclose(a.mse, a.variance * (a.runs - 1) / a.runs + a.bias ** 2)
    assert a.crb[1] == pytest.approx(26.057, rel=1e-3)  # Table IV cost at T = 40
    assert np.all((a.temperature_at_bound >= 0) & (a.temperature_at_bound <= 1))
    payload = a.to_dict()
    assert payload['n'] == 2 and len(payload['bias']) == 3 and payload['seed'] == 3


def test_single_level_study_uses_the_marginal_bound():
    result = _study(1, runs=100)
    assert np.all(result.crb == result.crb[0])
    assert result.crb[0] == pytest.approx(47.43, rel=2e-3)


def test_simulated_friction_shares_one_load_per_run():
    # with sigma -> 0 the spread of a run's levels comes only from the shared load
    params = PARAMS.with_overrides(sigma=2e-7)  # near the smallest with load std 0.1 (1e6 x)
    y = simulate_friction(speeds_rad_s=[35.0, 35.0], temperature_degc=40.0, wear=35.0,
                          runs=50, rng=np.random.default_rng(0), params=params)
    np.testing.assert_allclose(y[:, 0], y[:, 1], atol=1e-6)
    assert np.std(y[:, 0]) > 1e-4


def test_cramer_rao_bound_grows_away_from_the_design_temperature():
    crb = cramer_rao_bound(speeds_rad_s=[35.84, 40.84], temperatures_degc=[30.0, 40.0, 50.0],
                           wear=35.0, params=PARAMS)
    assert crb[1] < crb[0] and crb[1] < crb[2]


def test_plot_writes_a_png(tmp_path):
    path = tmp_path / 'fig8.png'
    plot_study([_study(1, runs=50), _study(2, runs=50)], path=str(path))
    assert path.read_bytes()[:8] == b'\x89PNG\r\n\x1a\n'


@pytest.mark.parametrize('kwargs, fragment', [
    ({'runs': 1}, 'runs'),
    ({'temperatures_degc': []}, 'temperatures'),
    ({'wear': -1.0}, 'wear'),
    ({'speeds_rad_s': [0.0, 3.0]}, '> 0'),
])
def test_study_input_errors(kwargs, fragment):
    arguments = {'speeds_rad_s': [35.0, 40.0], 'temperatures_degc': [40.0], 'wear': 35.0,
                 'runs': 10, 'seed': 0, 'params': PARAMS}
    arguments.update(kwargs)
    with pytest.raises(InputError) as info:
        run_study(**arguments)
    assert fragment in str(info.value)
