"""Options shared by the verbs: ``--json`` / ``--json-out``, deprecated spellings, defaults."""

import json

import numpy as np
import pytest
from robot_wear_monitor import cli
from robot_wear_monitor.cli.level_options import level_source_scales
import test_identify_cli as levels

REPLAY_DEPRECATED = ('robot-wear-monitor replay: warning: --json PATH is deprecated; use '
                     '--json-out PATH')


@pytest.fixture(scope='module')
def small_bag(tmp_path_factory):
    folder = tmp_path_factory.mktemp('options')
    bag = folder / 'bag'
    assert cli.main(['simulate', '--out', str(bag), '--experiments', '3', '--seed', '7']) == 0
    return bag


@pytest.fixture(scope='module')
def baseline(tmp_path_factory):
    folder = tmp_path_factory.mktemp('levels')
    return levels.write_csv(folder / 'baseline.csv', levels.levels(seed=0, n_experiments=12))


def _summary(path, out):
    payload = json.loads(path.read_text())
    assert payload['out_bag'] == str(out)
    payload['out_bag'] = 'OUT'
    return payload


def test_replay_json_path_is_deprecated_and_still_writes_the_summary(small_bag, tmp_path,
                                                                     capsys):
    old, new = tmp_path / 'old.json', tmp_path / 'new.json'
    assert cli.main(['replay', str(small_bag), '--out', str(tmp_path / 'o1'), '--json',
                     str(old), '--no-progress']) == 0
    deprecated = capsys.readouterr()
    assert deprecated.err.strip().splitlines() == [REPLAY_DEPRECATED]
    assert '3 experiments from' in deprecated.out  # the text summary, as before
    assert cli.main(['replay', str(small_bag), '--out', str(tmp_path / 'o2'), '--json-out',
                     str(new), '--no-progress']) == 0
    current = capsys.readouterr()
    assert current.err == '' and current.out == deprecated.out.replace('o1', 'o2')
    summary = _summary(old, tmp_path / 'o1')
    assert summary == _summary(new, tmp_path / 'o2')
    assert len(summary['experiments']) == 3 and summary['joint'] == 'joint_2'


def test_replay_json_flag_prints_the_summary_on_stdout(small_bag, tmp_path, capsys):
    out, written = tmp_path / 'o', tmp_path / 's.json'
    assert cli.main(['replay', str(small_bag), '--out', str(out), '--no-progress',
                     '--json-out', str(written), '--json']) == 0
    captured = capsys.readouterr()
    printed = json.loads(captured.out)  # nothing but the JSON object on stdout
    assert captured.err == ''
    assert printed == json.loads(written.read_text())
    assert len(printed['experiments']) == 3 and printed['joint'] == 'joint_2'


def test_json_path_and_a_different_json_out_are_refused(small_bag, tmp_path, capsys):
    code = cli.main(['replay', str(small_bag), '--out', str(tmp_path / 'o'), '--json',
                     str(tmp_path / 'a.json'), '--json-out', str(tmp_path / 'b.json'),
                     '--no-progress'])
    assert code == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert err[0] == REPLAY_DEPRECATED and 'give one file' in err[1]
    assert not (tmp_path / 'o').exists() and not list(tmp_path.glob('*.json'))


def test_audit_json_spellings_give_one_report(baseline, tmp_path, capsys):
    argv = ['audit', str(baseline), '--model', 'nominal']
    assert cli.main(argv + ['--json']) == 0
    flag = capsys.readouterr()
    assert flag.err == ''
    report = json.loads(flag.out)
    assert cli.main(argv + ['--json', '-']) == 0
    dash = capsys.readouterr()
    assert dash.err.strip() == ('robot-wear-monitor audit: warning: --json - is deprecated; '
                                'use --json')
    assert json.loads(dash.out) == report
    path = tmp_path / 'audit.json'
    assert cli.main(argv + ['--json', str(path)]) == 0
    old = capsys.readouterr()
    assert 'warning: --json PATH is deprecated; use --json-out PATH' in old.err
    assert 'audit.json' not in old.out and old.out.strip()  # the text summary
    assert json.loads(path.read_text()) == report
    path.unlink()
    assert cli.main(argv + ['--json-out', str(path)]) == 0
    new = capsys.readouterr()
    # a text run says once that the table does not state its unit (issue 43), as the old
    # spelling did; nothing else on stderr
    unit_note = ('robot-wear-monitor audit: note: the friction unit of ' + str(baseline)
                 + " is not stated; the report says 'normalised' (give --friction-unit UNIT, "
                 'e.g. N.m)\n')
    assert new.err == unit_note and unit_note in old.err and new.out == old.out
    assert json.loads(path.read_text()) == report


def test_identify_json_path_is_deprecated_and_json_out_writes_the_same(baseline, tmp_path,
                                                                       capsys):
    argv = ['identify', str(baseline), '--out', str(tmp_path / 'p.yaml')]
    assert cli.main(argv + ['--json', str(tmp_path / 'old.json')]) == 0
    old = capsys.readouterr()
    assert old.err.strip() == ('robot-wear-monitor identify: warning: --json PATH is '
                               'deprecated; use --json-out PATH')
    assert cli.main(argv + ['--json-out', str(tmp_path / 'new.json')]) == 0
    new = capsys.readouterr()
    assert new.err == '' and new.out == old.out and 'written to' in new.out
    report = json.loads((tmp_path / 'new.json').read_text())
    assert report == json.loads((tmp_path / 'old.json').read_text())
    assert report['name'] == 'identified_baseline' and report['loaded_back'] is True


def test_plan_rate_is_the_deprecated_sample_rate(tmp_path, capsys):
    argv = ['plan', '--joint', 'joint_2', '--speeds', '28.5,41.7', '--center', '0.2',
            '--half-range', '0.5', '--gear-ratio', '150', '--max-acceleration', '10', '--json']
    assert cli.main(argv + ['--rate', '500']) == 0
    old = capsys.readouterr()
    assert old.err.strip() == ('robot-wear-monitor plan: warning: --rate HZ is deprecated; '
                               'use --sample-rate HZ')
    assert cli.main(argv + ['--sample-rate', '500']) == 0
    new = capsys.readouterr()
    assert new.err == '' and json.loads(new.out) == json.loads(old.out)
    assert cli.main(argv) == 0
    default = json.loads(capsys.readouterr().out)
    assert default['samples_per_pass'] < json.loads(new.out)['samples_per_pass']


def test_plan_min_plateau_is_the_deprecated_min_duration(capsys):
    """One setting, one name: the segmentation's min_duration_s (the node parameter's)."""
    argv = ['plan', '--joint', 'joint_2', '--speeds', '28.5,41.7', '--center', '0.2',
            '--half-range', '0.5', '--gear-ratio', '150', '--max-acceleration', '10', '--json']
    assert cli.main(argv + ['--min-plateau', '0.5']) == 0
    old = capsys.readouterr()
    assert old.err.strip() == ('robot-wear-monitor plan: warning: --min-plateau S is '
                               'deprecated; use --min-duration S')
    assert cli.main(argv + ['--min-duration', '0.5']) == 0
    new = capsys.readouterr()
    assert new.err == '' and json.loads(new.out) == json.loads(old.out)
    assert json.loads(new.out)['samples_per_pass'] == 125  # 0.5 s at 250 Hz
    assert cli.main(argv) == 0  # the default: the segmentation's 0.2 s, 50 samples
    assert json.loads(capsys.readouterr().out)['samples_per_pass'] == 50
    assert cli.main(argv + ['--min-samples', '2']) == 2  # the segmentation's one check
    assert 'argument --min-samples: must be >= 3, got 2' in capsys.readouterr().err


def test_live_params_file_is_the_deprecated_config(tmp_path, capsys):
    bad = tmp_path / 'bad.yaml'
    bad.write_text('friction_experiment_node:\n  ros__parameters:\n    gear_ratio: 150\n')
    assert cli.main(['live', '--params-file', str(bad)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert err[0] == ('robot-wear-monitor live: warning: --params-file is deprecated; use '
                      '--config')
    assert 'gear_ratio: expected a double, got integer 150' in err[1] and len(err) == 2
    assert cli.main(['live', '--config', str(bad)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and 'gear_ratio: expected a double' in err[0]


@pytest.mark.parametrize('verb', ['audit', 'identify'])
def test_level_sources_leave_the_scales_to_the_input_kind(verb):
    """Not given: None, so that a bag takes the node config's 150 and 10 and a raw run 1."""
    parser = cli.build_parser()
    extra = ['--out', 'p.yaml'] if verb == 'identify' else []
    args = parser.parse_args([verb, 'data.csv'] + extra)
    assert args.gear_ratio is None and level_source_scales(args) == (None, None)
    assert args.config is None
    args = parser.parse_args([verb, 'bag', '--gear-ratio', '150', '--torque-scale', '10']
                             + extra)
    assert level_source_scales(args) == (150.0, 10.0)


def test_segment_of_a_bag_defaults_to_the_node_config(small_bag, tmp_path, capsys):
    assert cli.main(['segment', str(small_bag)]) == 0
    default = capsys.readouterr().out
    assert cli.main(['segment', str(small_bag), '--gear-ratio', '150', '--torque-scale',
                     '10']) == 0
    assert capsys.readouterr().out == default
    rows = default.strip().splitlines()
    assert rows[0].startswith('speed,friction,') and len(rows) == 1 + 3 * 4
    speeds = np.array([float(r.split(',')[0]) for r in rows[1:]])
    nearest = np.abs(speeds[:, None] - np.array([2.1, 28.5, 35.1, 41.7])).min(axis=1)
    assert np.all(nearest < 0.2)  # motor speeds: the joint speeds x 150 (not x 1)


@pytest.mark.parametrize('option, value, named', [
    ('--interval', '1', '--interval 1 s: an experiment lasts'),
    ('--sample-rate', '1', '--speeds/--sample-rate: the experiment cannot be planned at 1 Hz'),
])
def test_simulate_errors_name_the_users_option_not_a_field(option, value, named,
                                                           tmp_path, capsys):
    out = tmp_path / 'bag'
    assert cli.main(['simulate', '--out', str(out), '--experiments', '3', option, value]) == 2
    error = capsys.readouterr().err
    assert named in error
    assert 'ScenarioConfig' not in error and 'window' not in error.split('(')[-1]
    assert not out.exists()


def _replay_stderr(bag, out, *, terminal: bool, extra=()) -> str:
    """Run ``replay`` in a new process with stderr on a pipe or a pseudo-terminal."""
    import os
    import pty
    import subprocess
    import sys
    command = [sys.executable, '-m', 'robot_wear_monitor.cli', 'replay', str(bag), '--out',
               str(out), *extra]
    if not terminal:
        done = subprocess.run(command, capture_output=True, text=True, timeout=120)
        assert done.returncode == 0, done.stderr
        return done.stderr
    import fcntl
    import struct
    import termios
    leader, follower = pty.openpty()
    # 24 x 80: tqdm fits its bar to the terminal's width (a new pty has 0 columns)
    fcntl.ioctl(follower, termios.TIOCSWINSZ, struct.pack('HHHH', 24, 80, 0, 0))
    try:
        process = subprocess.Popen(command, stdout=subprocess.DEVNULL, stderr=follower)
        os.close(follower)
        chunks = []
        while True:
            try:
                chunk = os.read(leader, 4096)
            except OSError:  # EIO: the process closed its end
                break
            if not chunk:
                break
            chunks.append(chunk)
        assert process.wait(timeout=120) == 0
    finally:
        os.close(leader)
    return b''.join(chunks).decode(errors='replace')


def test_the_progress_bar_is_drawn_on_a_terminal_only(small_bag, tmp_path):
    """A pipe or a log file gets no bar; a terminal gets it unless --no-progress."""
    bar = f'read {small_bag.name}:'
    assert bar not in _replay_stderr(small_bag, tmp_path / 'pipe', terminal=False)
    assert bar in _replay_stderr(small_bag, tmp_path / 'tty', terminal=True)
    assert bar not in _replay_stderr(small_bag, tmp_path / 'quiet', terminal=True,
                                     extra=['--no-progress'])
