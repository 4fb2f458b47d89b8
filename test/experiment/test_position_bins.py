"""
Low-rate logs: segment names the reason and forms levels by eq. (3) over position bins.

Raw runs from :func:`wear_testing.direct_drive_arm.raw_run` (numpy only): the truth is the
friction of the joint's positive-direction model (4) at each set-point.
"""

import numpy as np
import pytest
from robot_wear_monitor.cli import main
from robot_wear_monitor.errors import InputError
from robot_wear_monitor.experiment.position_bins import position_binned_levels
from robot_wear_monitor.experiment.segmentation_settings import raw_run_segmenter_config
from robot_wear_monitor.monitoring.segment import segment_raw_csv
from wear_testing.direct_drive_arm import magnitude, raw_run

SPEEDS = np.linspace(0.35, 1.05, 13)  # rad/s, 13 set-points as the lab's arm


def _levels(result):
    levels = [row[0] for row in result.rows]
    return (np.array([lv.speed_rad_s for lv in levels]), np.array([lv.friction for lv in levels]),
            np.array([lv.friction_std_error for lv in levels]))


def test_a_2_hz_log_is_named_too_slow_with_its_numbers(tmp_path, capsys):
    path = tmp_path / 'slow.csv'
    raw_run(path, speeds=SPEEDS, rate_hz=2.0, cycles=6, travel_rad=1.2, seed=3)
    out = tmp_path / 'levels.csv'
    assert main(['segment', str(path), '--out', str(out)]) == 2
    error = capsys.readouterr().err
    assert 'too slow for time-window levels: 2 Hz (a sample every 0.5 s)' in error
    assert 'min_samples = 20' in error and 'max_gap_s = 0.05 s' in error
    assert '--position-bins N' in error
    assert 'too slow to tell from standstill' not in error
    counts = error.split('a pass holds ')[1].split(' samples')[0]
    low, high = (int(x) for x in counts.split('-'))
    assert 1 <= low <= high <= 8
    assert not out.exists()
    # the audit of the same raw run says it too, and where the binned levels come from
    assert main(['audit', str(path)]) == 2
    error = capsys.readouterr().err
    assert 'too slow for time-window levels: 2 Hz' in error
    assert 'segment RUN --position-bins N' in error


def test_a_2_hz_log_gives_one_level_per_set_point_over_position_bins(tmp_path, capsys):
    path = tmp_path / 'slow.csv'
    raw_run(path, speeds=SPEEDS, rate_hz=2.0, cycles=6, travel_rad=1.2, seed=3)
    out = tmp_path / 'levels.csv'
    speeds = ','.join(f'{v:.6g}' for v in SPEEDS)
    assert main(['segment', str(path), '--position-bins', '4', '--speeds', speeds,
                 '--out', str(out)]) == 0
    assert '13 friction levels' in capsys.readouterr().err
    rows = [line.split(',') for line in out.read_text().splitlines()]
    header, body = rows[0], rows[1:]
    speed = np.array([float(r[header.index('speed')]) for r in body])
    friction = np.array([float(r[header.index('friction')]) for r in body])
    error = np.array([float(r[header.index('friction_std_error')]) for r in body])
    np.testing.assert_allclose(speed, SPEEDS, rtol=0.01)
    # gravity (2 N.m x cos q) cancels bin by bin: the levels are the friction, within 3 SE
    z = (friction - magnitude('1', 'positive', speed)) / error
    assert np.all(np.abs(z) < 3.0), z
    assert np.all([int(r[header.index('n_forward')]) >= 2 for r in body])
    # without --speeds the set-points are found from the moves (close ones may merge)
    found = segment_raw_csv(path, position_bins=4)
    assert 10 <= found.n_levels <= 13


@pytest.mark.parametrize('cycles', [1, 3])
def test_on_a_high_rate_run_the_binned_levels_equal_the_time_window_ones(tmp_path, cycles):
    path = tmp_path / 'fast.csv'
    speeds = SPEEDS[::3]
    raw_run(path, speeds=speeds, rate_hz=200.0, cycles=cycles, seed=4)
    window_speed, window, window_error = _levels(segment_raw_csv(path))
    binned_speed, binned, binned_error = _levels(segment_raw_csv(path, position_bins=10))
    assert binned.size == speeds.size and window.size == cycles * speeds.size
    order = np.argsort(window_speed, kind='stable')
    mean_window = window[order].reshape(speeds.size, cycles).mean(axis=1)
    mean_error = np.sqrt(np.sum(window_error[order].reshape(speeds.size, cycles) ** 2,
                                axis=1)) / cycles
    np.testing.assert_allclose(binned_speed, speeds, rtol=0.005)
    # the same samples, the same eq. (3): equal within a standard error
    assert np.all(np.abs(binned - mean_window) <= np.maximum(mean_error, binned_error))
    np.testing.assert_allclose(binned, mean_window, rtol=0.003)


def test_position_bins_refuse_a_bag_and_a_bad_count(tmp_path, capsys):
    assert main(['segment', str(tmp_path), '--position-bins', '4']) == 2
    assert '--position-bins is for a raw CSV' in capsys.readouterr().err
    with pytest.raises(InputError, match='expected an integer >= 1, got 0'):
        position_binned_levels(time_s=[0.0], position_rad=[0.0], velocity_rad_s=[0.0],
                               effort=[0.0], config=raw_run_segmenter_config(), n_bins=0)
