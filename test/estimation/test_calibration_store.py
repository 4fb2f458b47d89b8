"""Stored interval calibrations: the shipped table is current, the cache is exact and safe."""

import json
import subprocess
import sys

import numpy as np
import pytest
from robot_wear_monitor.estimation import intervals
from robot_wear_monitor.estimation.intervals import (calibrate_cutoffs, calibration_key,
                                                     simulate_cutoffs)
from robot_wear_monitor.model.params import load_parameter_set


def test_the_shipped_calibrations_equal_a_fresh_calibration():
    """A stale table (changed calibration or parameter set) fails here; rebuild it then."""
    table = json.loads(intervals.SHIPPED_CALIBRATIONS.read_text())
    params = load_parameter_set(None)
    assert len(table) == len(intervals.SHIPPED_DESIGNS)
    for design in intervals.SHIPPED_DESIGNS:
        rounded = intervals._rounded_speeds(np.asarray(design, dtype=float))
        key = calibration_key(rounded, params, 0.95, intervals.CALIBRATION_RUNS,
                              intervals.CALIBRATION_SEED)
        assert key in table, ('the shipped calibrations are stale: run write_shipped_'
                              'calibrations() (see its docstring)')
        fresh = simulate_cutoffs(rounded, params=params, level=0.95,
                                 runs=intervals.CALIBRATION_RUNS,
                                 seed=intervals.CALIBRATION_SEED)
        np.testing.assert_allclose(table[key]['cutoff'], fresh.cutoff, rtol=0, atol=1e-12)
        np.testing.assert_array_equal(table[key]['wear'], fresh.wear)


def test_the_key_follows_the_values_not_the_name_or_file():
    params = load_parameter_set(None)
    speeds = (2.1, 28.5)
    base = calibration_key(speeds, params, 0.95, 1500, 1)
    renamed = params.__class__(**{**params.__dict__, 'name': 'copy', 'source': '/elsewhere'})
    assert calibration_key(speeds, renamed, 0.95, 1500, 1) == base
    noisier = params.__class__(**{**params.__dict__, 'sigma': params.sigma * 1.01})
    assert calibration_key(speeds, noisier, 0.95, 1500, 1) != base
    assert calibration_key((2.1, 28.6), params, 0.95, 1500, 1) != base
    assert calibration_key(speeds, params, 0.9, 1500, 1) != base


def _calibrate_in_subprocess(cache, speeds):
    """Calibrate in a new process (empty in-process cache); return (cutoffs, seconds)."""
    code = ('import json, sys, time\n'
            'from robot_wear_monitor.estimation.intervals import calibrate_cutoffs\n'
            'from robot_wear_monitor.model.params import load_parameter_set\n'
            't = time.perf_counter()\n'
            f'c = calibrate_cutoffs({list(speeds)!r}, params=load_parameter_set(None),'
            ' runs=200, seed=5)\n'
            'print(json.dumps([c.cutoff.tolist(), time.perf_counter() - t]))\n')
    env = {'ROBOT_WEAR_MONITOR_CACHE': str(cache), 'PATH': '/usr/bin:/bin',
           'PYTHONPATH': ':'.join(sys.path)}
    out = subprocess.run([sys.executable, '-c', code], env=env, capture_output=True,
                         text=True, check=True, timeout=120)
    return json.loads(out.stdout)


def test_a_stored_calibration_is_reused_by_the_next_process_with_the_same_numbers(tmp_path):
    speeds = (5.0, 60.0)
    first, _ = _calibrate_in_subprocess(tmp_path, speeds)
    stored = list(tmp_path.glob('cutoffs-*.json'))
    assert len(stored) == 1
    second, _ = _calibrate_in_subprocess(tmp_path, speeds)
    assert second == first  # read back exactly
    stored[0].write_text('{"wear": [0, 1], "cut')  # damaged (e.g. a full disk): ignored
    third, _ = _calibrate_in_subprocess(tmp_path, speeds)
    assert third == first
    assert json.loads(stored[0].read_text())['cutoff'] == first  # and written anew


def test_an_empty_cache_variable_disables_the_store(tmp_path, monkeypatch):
    monkeypatch.setenv('ROBOT_WEAR_MONITOR_CACHE', '')
    assert intervals.calibration_cache_dir() is None
    intervals._calibrate.cache_clear()
    calibration = calibrate_cutoffs((7.0, 70.0), params=load_parameter_set(None), runs=100,
                                    seed=3)
    assert calibration.cutoff.shape == calibration.wear.shape
    assert not list(tmp_path.iterdir())


@pytest.mark.parametrize('speeds', [(2.1, 28.5, 35.1, 41.7), (2.12, 28.46, 35.13, 41.66)])
def test_the_default_design_is_not_simulated_at_run_time(speeds, monkeypatch):
    """Measured speeds of the default design find the shipped calibration (no simulation)."""
    intervals._calibrate.cache_clear()
    monkeypatch.setattr(intervals, 'simulate_cutoffs', None)  # would raise if called
    calibration = calibrate_cutoffs(speeds, params=load_parameter_set(None))
    assert calibration.runs == intervals.CALIBRATION_RUNS
    intervals._calibrate.cache_clear()
