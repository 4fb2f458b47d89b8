"""The demo on a small scenario: every file of the report folder, valid JSON, CLI message."""

import json

from robot_wear_monitor import cli


def test_demo_writes_the_report_folder(tmp_path, capsys):
    folder = tmp_path / 'demo'
    assert cli.main(['demo', '--out', str(folder), '--experiments', '14', '--seed', '1',
                     '--no-progress']) == 0
    out = capsys.readouterr().out
    assert str(folder / 'report.md') in out
    for name in ('report.md', 'summary.json', 'wear_trend.png', 'friction_curves.png',
                 'scenario_bag.truth.json', 'wear_history.sqlite3'):
        assert (folder / name).stat().st_size > 0, name
    assert list((folder / 'scenario_bag').glob('*.mcap'))
    assert list((folder / 'monitor_bag').glob('*.mcap'))
    summary = json.loads((folder / 'summary.json').read_text())
    truth = json.loads((folder / 'scenario_bag.truth.json').read_text())
    assert len(summary['experiments']) == len(truth['experiments']) == 14
    assert [e['truth']['wear'] for e in summary['experiments']] == \
        [e['wear'] for e in truth['experiments']]
    report = (folder / 'report.md').read_text()
    assert report.count('\n| ') == 14 + 1  # header + one row per experiment
    assert '![' in report and 'wear_trend.png' in report
    # a second run into the same folder replaces the demo files
    assert cli.main(['demo', '--out', str(folder), '--experiments', '2', '--no-progress']) == 0
    assert len(json.loads((folder / 'summary.json').read_text())['experiments']) == 2


def test_demo_refuses_a_file_as_folder(tmp_path, capsys):
    target = tmp_path / 'file'
    target.write_text('x')
    assert cli.main(['demo', '--out', str(target), '--no-progress']) == 2
    assert 'not a folder' in capsys.readouterr().err
