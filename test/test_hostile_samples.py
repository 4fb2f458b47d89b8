"""
Bad samples are rejected one by one: the rest of the recording is used, the reason named.

Recordings of the independent generator (``independent_robot.py``) with every 7th effort NaN,
every 50th stamp a duplicate of the one before or three back, or efforts or speeds of 1e308:
the replay must find the same experiments as on the clean recording, estimate nearly the same
wear, and name the bad samples (not "no plateau", not the gear ratio), without a numpy
warning.
"""

from __future__ import annotations

import dataclasses
import json
import subprocess
import sys

import numpy as np
import pytest
from wear_testing import independent_robot as robot


@pytest.fixture(scope='module')
def recording():
    return robot.generate_wear_test(n_experiments=3, wear_start=20.0, wear_end=70.0, seed=7,
                                    rate_hz=500.0)


def _damaged(recording, kind):
    if kind == 'clean':
        return recording
    if kind == 'nan_effort':
        effort = recording.effort.copy()
        effort[::7, 1] = np.nan
        return dataclasses.replace(recording, effort=effort)
    if kind == 'duplicate_stamps':
        stamps = recording.stamps_ns.copy()
        stamps[100::50] = stamps[99::50][:stamps[100::50].size]
        return dataclasses.replace(recording, stamps_ns=stamps, stamps_s=stamps / 1e9)
    if kind == 'backward_stamps':
        stamps = recording.stamps_ns.copy()
        stamps[100::50] = stamps[97::50][:stamps[100::50].size]
        return dataclasses.replace(recording, stamps_ns=stamps, stamps_s=stamps / 1e9)
    if kind == 'huge_velocity':
        velocity = recording.velocity.copy()
        velocity[3::500, 1] = 1e308
        return dataclasses.replace(recording, velocity=velocity)
    if kind == 'huge_values':
        effort = recording.effort.copy()
        effort[3::500, 1] = 1e308
        return dataclasses.replace(recording, effort=effort)
    raise ValueError(kind)


def _replay(recording, kind, tmp_path):
    bag = robot.write_bag(tmp_path / kind, _damaged(recording, kind))
    done = subprocess.run(
        [sys.executable, '-W', 'error::RuntimeWarning', '-m', 'robot_wear_monitor.cli',
         'replay', str(bag), '--history', str(tmp_path / f'{kind}.db'), '--no-progress',
         '--json'], capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stderr
    assert 'Warning' not in done.stderr, done.stderr
    return json.loads(done.stdout)


@pytest.mark.parametrize('kind, reason', [('nan_effort', 'segmentation_non_finite'),
                                          ('duplicate_stamps',
                                           'segmentation_time_not_increasing'),
                                          ('backward_stamps',
                                           'segmentation_time_not_increasing'),
                                          ('huge_values', 'segmentation_out_of_range'),
                                          ('huge_velocity', 'segmentation_out_of_range')])
def test_bad_samples_are_rejected_alone(recording, tmp_path, kind, reason):
    clean = _replay(recording, 'clean', tmp_path)
    damaged = _replay(recording, kind, tmp_path)
    assert damaged['rejections'].get(reason, 0) > 0
    assert len(damaged['experiments']) == len(clean['experiments']) == 3
    for bad, good in zip(damaged['experiments'], clean['experiments']):
        assert bad['valid'] and bad['speeds_rad_s'] == pytest.approx(good['speeds_rad_s'],
                                                                     abs=0.5)
        # a seventh of the samples fewer: the levels move by their standard error, not more
        assert bad['wear'] == pytest.approx(good['wear'], abs=6.0)


def test_the_replay_line_names_the_bad_samples(recording, tmp_path):
    bag = robot.write_bag(tmp_path / 'nan', _damaged(recording, 'nan_effort'))
    done = subprocess.run([sys.executable, '-m', 'robot_wear_monitor.cli', 'replay', str(bag),
                           '--history', str(tmp_path / 'h.db'), '--no-progress'],
                          capture_output=True, text=True, check=True, timeout=300)
    assert 'WARNING: rejected as bad data: segmentation_non_finite' in done.stdout
    assert 'plateau' not in done.stdout and 'gear ratio' not in done.stdout
