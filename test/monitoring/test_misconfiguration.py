"""
A misconfigured monitor never says "no alarm": it says it cannot judge, and names the cause.

The recordings come from the independent generator (``test/wear_testing/independent_robot.py``: its
own trajectory, noise and protocol) of a joint that wears from w = 20 to w = 70, so that the right
configuration raises the wear alarm.  Replayed with a wrong gear ratio, a wrong torque scale,
another joint's friction or a saturated drive torque, every estimate must be invalid, the
summary must say so in words with the likely cause, and nothing may read "no alarm".
"""

from __future__ import annotations

import json
from pathlib import Path
import subprocess
import sys

import pytest
from robot_wear_monitor.history import open_history
from robot_wear_monitor.monitoring.diagnostics import is_routine
from wear_testing import independent_robot as robot

N_EXPERIMENTS = 3


def _bag(folder: Path, name: str, **options) -> Path:
    recording = robot.generate_wear_test(n_experiments=N_EXPERIMENTS, wear_start=20.0,
                                         wear_end=70.0, seed=7, rate_hz=500.0, **options)
    return robot.write_bag(folder / name, recording)


def _replay(bag: Path, history: Path, *options: str) -> tuple[dict, str]:
    common = [sys.executable, '-m', 'robot_wear_monitor.cli', 'replay', str(bag), '--history',
              str(history), '--no-progress']
    text = subprocess.run(common + list(options), capture_output=True, text=True, check=True,
                          timeout=300)
    history.unlink()
    done = subprocess.run(common + ['--json', *options], capture_output=True, text=True,
                          check=True, timeout=300)
    return json.loads(done.stdout), text.stdout


@pytest.fixture(scope='module')
def bags(tmp_path_factory) -> dict[str, Path]:
    folder = tmp_path_factory.mktemp('misconfigured')
    return {
        'right': _bag(folder, 'right'),
        # another joint: three times the Coulomb friction, no Stribeck rise, more viscous
        'other_joint': _bag(folder, 'other_joint', friction_parameters={
            'F_c0': 0.09, 'F_ctl': 0.0, 'F_s0': 0.0, 'F_stl': 0.0, 'F_sT': 0.0,
            'F_v0': 2.0e-3}),
        # the drive's torque limit cuts the forward passes (gravity 0.8 cos(0.6) = 0.66 plus
        # friction exceeds 0.72 normalised = 7.2 effort units)
        'saturated': _bag(folder, 'saturated', effort_limit=7.2),
    }


def test_the_right_configuration_raises_the_alarm(bags, tmp_path):
    summary, line = _replay(bags['right'], tmp_path / 'h.db')
    assert summary['invalid_estimates'] == 0
    assert summary['first_alarm'] is not None, line
    assert all(e['valid'] for e in summary['experiments'])


@pytest.mark.parametrize('case, bag, options, cause', [
    ('gear ratio 1 instead of 150', 'right', ('--gear-ratio', '1'), 'gear ratio'),
    ('torque scale 100 instead of 10', 'right', ('--torque-scale', '100'), 'torque scale'),
    ('torque scale 1 instead of 10', 'right', ('--torque-scale', '1'), 'torque scale'),
    ("another joint's friction", 'other_joint', (), 'another joint'),
])
def test_a_misconfiguration_is_named_never_no_alarm(bags, tmp_path, case, bag, options, cause):
    summary, line = _replay(bags[bag], tmp_path / 'h.db', *options)
    experiments = summary['experiments']
    assert experiments, f'{case}: {line}'
    invalid = [e for e in experiments if not e['valid']]
    assert len(invalid) == len(experiments) == summary['invalid_estimates'], case
    assert 'no alarm' not in line, f'{case}: {line}'
    assert 'CANNOT JUDGE' in line and 'estimates invalid' in line, line
    for entry in invalid:
        assert entry['status'] == 'ERROR' and entry['message'].startswith('CANNOT JUDGE')
        assert entry['invalid_reasons'] and entry['likely_cause'], entry
        assert cause in entry['likely_cause'], (case, entry['likely_cause'])
        assert entry['alarm'] is False and entry['trend'] is None  # never evidence
    assert summary['first_alarm'] is None


def test_a_saturated_drive_torque_is_named_and_its_levels_are_not_used(bags, tmp_path):
    summary, line = _replay(bags['saturated'], tmp_path / 'h.db')
    assert summary['rejections'].get('segmentation_pass_torque_saturated', 0) > 0
    assert 'no alarm' not in line
    assert 'WARNING: rejected as bad data: segmentation_pass_torque_saturated' in line
    assert 'torque sat at its limit' in line
    # what is estimated comes from the passes below the limit only (the high speeds, where
    # the friction is lowest), never from a clipped one
    for entry in summary['experiments']:
        assert 0 < len(entry['speeds_rad_s']) < len(robot.TABLE_V_SPEEDS_RAD_S)
        assert min(entry['speeds_rad_s']) > 30.0


def test_estimate_says_when_a_fit_fails_instead_of_a_wear_value():
    for levels in ('0.5,0.5,0.5,0.5', '0,0,0,0'):
        command = [sys.executable, '-m', 'robot_wear_monitor.cli', 'estimate', '--speeds',
                   '2.1,28.5,35.1,41.7', '--friction', levels]
        text = subprocess.run(command, capture_output=True, text=True, check=True).stdout
        assert 'CANNOT JUDGE' in text and 'INVALID: cannot judge the wear' in text
        assert 'alarm               no' not in text
        report = json.loads(subprocess.run(command + ['--json'], capture_output=True,
                                           text=True, check=True).stdout)
        assert report['valid'] is False and report['alarm'] is None
        assert 'model_check' in report['invalid_checks'] or 'friction_range' in \
            report['invalid_checks']


def test_clean_data_reads_clean(bags, tmp_path):
    done = subprocess.run([sys.executable, '-m', 'robot_wear_monitor.cli', 'replay',
                           str(bags['right']), '--history', str(tmp_path / 'h.db'),
                           '--no-progress', '--json-out', str(tmp_path / 'summary.json')],
                          capture_output=True, text=True, check=True)
    assert 'rejected' not in done.stdout and 'WARNING' not in done.stdout
    # the summary JSON tells the routine rejections apart from those that mean bad data
    summary = json.loads((tmp_path / 'summary.json').read_text())
    assert summary['bad_data_rejections'] == {}
    assert sum(summary['routine_rejections'].values()) == sum(summary['rejections'].values())
    segment = subprocess.run([sys.executable, '-m', 'robot_wear_monitor.cli', 'segment',
                              str(bags['right']), '--out', str(tmp_path / 'levels.csv')],
                             capture_output=True, text=True, check=True)
    assert 'rejected as bad data' not in segment.stderr
    # the project's own simulator: its sweeps end in an unpaired pass and its experiments
    # are apart; counted as routine, never as rejections
    simulated = tmp_path / 'simulated'
    subprocess.run([sys.executable, '-m', 'robot_wear_monitor.cli', 'simulate', '--out',
                    str(simulated), '--experiments', '2'], check=True, capture_output=True)
    segment = subprocess.run([sys.executable, '-m', 'robot_wear_monitor.cli', 'segment',
                              str(simulated), '--out', str(tmp_path / 'sim.csv')],
                             capture_output=True, text=True, check=True)
    assert 'routine:' in segment.stderr and 'rejected' not in segment.stderr
    subprocess.run([sys.executable, '-m', 'robot_wear_monitor.cli', 'replay', str(simulated),
                    '--history', str(tmp_path / 'sim.db'), '--no-progress', '--json-out',
                    str(tmp_path / 'sim.json')], check=True, capture_output=True)
    summary = json.loads((tmp_path / 'sim.json').read_text())
    assert summary['bad_data_rejections'] == {}
    assert summary['routine_rejections'] and all(
        is_routine(reason) for reason in summary['routine_rejections'])
    assert summary['routine_rejections'] == {r: n for r, n in summary['rejections'].items() if n}
    for joint in summary['joints']:
        assert joint['bad_data_rejected'] == {}
        assert joint['routine_rejected'] == {r: n for r, n in joint['rejected'].items() if n}
    again = subprocess.run([sys.executable, '-m', 'robot_wear_monitor.cli', 'simulate',
                            '--out', str(simulated)], capture_output=True, text=True)
    assert again.returncode == 2 and '--overwrite' in again.stderr


def test_the_history_export_says_what_audit_needs(bags, tmp_path):
    history = tmp_path / 'h.db'
    subprocess.run([sys.executable, '-m', 'robot_wear_monitor.cli', 'replay',
                    str(bags['right']), '--history', str(history), '--no-progress'],
                   check=True, capture_output=True)
    done = subprocess.run([sys.executable, '-m', 'robot_wear_monitor.cli', 'history',
                           str(history), '--csv', str(tmp_path / 'levels.csv')],
                          capture_output=True, text=True, check=True)
    assert 'the audit needs levels at 6 or more distinct speeds and these have 4' in \
        done.stdout


def test_an_invalid_estimate_is_stored_and_the_fleet_cannot_judge_the_joint(bags, tmp_path):
    history = tmp_path / 'h.db'
    subprocess.run([sys.executable, '-m', 'robot_wear_monitor.cli', 'replay',
                    str(bags['right']), '--history', str(history), '--no-progress',
                    '--gear-ratio', '1'], check=True, capture_output=True, timeout=300)
    with open_history(history, init=False) as stored:
        records = stored.records(joint='joint_2')
        [row] = stored.fleet()
    assert records and not any(r.valid for r in records)
    assert all('gear ratio' in r.invalid_reason for r in records)
    assert row.invalid_reason and not row.alarm
    fleet = subprocess.run([sys.executable, '-m', 'robot_wear_monitor.cli', 'fleet',
                            '--history', str(history)], capture_output=True, text=True,
                           check=True, timeout=120).stdout
    assert 'CANNOT JUDGE' in fleet
    shown = subprocess.run([sys.executable, '-m', 'robot_wear_monitor.cli', 'history',
                            str(history)], capture_output=True, text=True, check=True,
                           timeout=120).stdout
    assert shown.count('INVALID: cannot judge the wear') == len(records)


def test_a_rerun_reports_the_latched_alarm_from_the_history(bags, tmp_path):
    history = tmp_path / 'h.db'
    out = tmp_path / 'summary.json'
    command = [sys.executable, '-m', 'robot_wear_monitor.cli', 'replay', str(bags['right']),
               '--history', str(history), '--no-progress', '--json-out', str(out)]
    subprocess.run(command, check=True, capture_output=True, timeout=300)
    first = json.loads(out.read_text())
    assert first['first_alarm'] is not None
    again = subprocess.run(command, check=True, capture_output=True, text=True, timeout=300)
    assert 'no alarm' not in again.stdout
    assert f'{N_EXPERIMENTS} already in the history' in again.stdout
    assert 'alarm LATCHED (from the history' in again.stdout
    assert f'{out} held {N_EXPERIMENTS} experiments, this run estimated 0' in again.stderr
    second = json.loads(out.read_text())
    [state] = second['state']
    assert state['alarm'] and state['estimates'] == N_EXPERIMENTS
    assert state['last_estimate']['wear'] == pytest.approx(first['experiments'][-1]['wear'])
