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
    for entry in summary['experiments']:
        low, high = entry['wear_interval']
        assert 0.0 <= low <= entry['wear'] <= high <= low + 42.0
        assert entry['wear_std'] is None or entry['wear_std'] < 100.0  # no 0.3 +- 4317
        trend = entry['trend']
        assert 0.0 <= trend['wear_low'] <= trend['wear'] <= trend['wear_high']
    covered = sum(e['wear_interval'][0] - 1e-9 <= e['truth']['wear'] <= e['wear_interval'][1]
                  for e in summary['experiments'])
    assert covered >= 12  # 95 % intervals, 14 experiments
    assert summary['forecast']['experiments'] == 14
    report = (folder / 'report.md').read_text()
    assert report.count('\n| ') == 14 + 1  # header + one row per experiment
    assert 'After the last experiment: wear trend' in report and '+-' not in report
    assert '![' in report and 'wear_trend.png' in report
    # a second run into the same folder replaces the demo files
    assert cli.main(['demo', '--out', str(folder), '--experiments', '2', '--no-progress']) == 0
    assert len(json.loads((folder / 'summary.json').read_text())['experiments']) == 2


def test_demo_refuses_a_file_as_folder(tmp_path, capsys):
    target = tmp_path / 'file'
    target.write_text('x')
    assert cli.main(['demo', '--out', str(target), '--no-progress']) == 2
    assert 'not a folder' in capsys.readouterr().err
