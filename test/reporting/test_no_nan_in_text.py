"""
No 'nan' or 'inf' in anything a person reads (JSON keeps null).

The demo's stdout and report, the diagnostics messages and key-values the nodes publish, and
the history text.
"""

import re

from robot_wear_monitor import cli
from rosbags.highlevel import AnyReader

#: 'nan'/'inf' as a word (not inside 'info', 'infinite', 'inference', ...)
NOT_A_NUMBER = re.compile(r'(?<![A-Za-z])[-+]?(nan|inf)(?![A-Za-z])', re.IGNORECASE)


def _words(text):
    return sorted({m.group(0) for m in NOT_A_NUMBER.finditer(text)})


def test_the_demo_reads_without_nan_or_inf(tmp_path, capsys):
    folder = tmp_path / 'demo'
    # 40 experiments: early ones have no wear std, open forecast ends and no crossing time
    assert cli.main(['demo', '--out', str(folder), '--experiments', '40', '--seed', '2',
                     '--no-progress']) == 0
    captured = capsys.readouterr()
    texts = {'stdout': captured.out, 'stderr': captured.err,
             'report.md': (folder / 'report.md').read_text()}
    diagnostics = []
    with AnyReader([folder / 'monitor_bag']) as reader:
        connections = [c for c in reader.connections if c.topic == '/diagnostics']
        for connection, _, raw in reader.messages(connections=connections):
            for status in reader.deserialize(raw, connection.msgtype).status:
                diagnostics.append(status.message)
                diagnostics += [f'{kv.key}: {kv.value}' for kv in status.values]
    assert len(diagnostics) > 40 * 10
    texts['diagnostics'] = '\n'.join(diagnostics)
    # the cases the words stand for did occur
    assert 'wear_std: not reported (see the interval)' in texts['diagnostics']
    assert 'beyond the forecast horizon' in texts['diagnostics']
    history = str(folder / 'wear_history.sqlite3')
    assert cli.main(['history', history]) == 0
    texts['history'] = capsys.readouterr().out
    found = {name: _words(text) for name, text in texts.items()}
    assert found == {name: [] for name in texts}, found
