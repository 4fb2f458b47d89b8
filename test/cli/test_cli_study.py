"""``robot-wear-monitor study``: JSON, the figure and the text table."""

import json

from robot_wear_monitor.cli import main


def test_study_json_and_plot(capsys, tmp_path):
    png = tmp_path / 'study.png'
    assert main(['study', '--n', '2', '--speeds', '35.84,40.84', '--temperatures', '35:45:5',
                 '--runs', '40', '--seed', '2', '--json', '--plot', str(png)]) == 0
    payload = json.loads(capsys.readouterr().out)
    assert payload['temperatures'] == [35.0, 40.0, 45.0] and len(payload['variance']) == 3
    assert png.stat().st_size > 0
    assert main(['study', '--n', '1', '--speeds', '38.6', '--temperatures', '40:40:1',
                 '--runs', '20']) == 0
    assert 'CRB' in capsys.readouterr().out
