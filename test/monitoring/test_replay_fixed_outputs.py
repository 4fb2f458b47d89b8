"""
The replay's outputs, fixed: a summary JSON and an output bag compared with committed files.

A simulated recording (``simulate --experiments 60 --seed 7``: 210,840 JointState messages, an
alarm on the way) is replayed, and its summary JSON and every number of its output bag
(``/wear``, ``/temperature``, ``/wear_alarm``, ``/wear_trend``, ``/friction_levels``,
``/diagnostics``) must equal ``data/replay_60_seed7.json`` bit for bit.  The file was made by
the code of 2026-11-26 after that day's issues (34-37) had landed, before any work on the
replay's speed (issue 38): a change that moves a number must say so and write the file anew
(``PYTHONPATH=test python3 test/monitoring/test_replay_fixed_outputs.py --write``).  Keys added
since (the ``threshold`` and ``warning_level`` of each ``state`` entry, issue 42) are checked
against the node configuration and taken out before the comparison.
"""

import json
import math
from pathlib import Path
import sys

from robot_wear_monitor.cli import main
from rosbags.rosbag2 import Reader

FIXED = Path(__file__).resolve().parent / 'data' / 'replay_60_seed7.json'
#: keys of the summary that name paths of this run (not numbers of the replay)
PATH_KEYS = ('out_bag',)


def _plain(value):
    """Return ``value`` as JSON data: numpy arrays and messages' numbers as lists and floats."""
    if hasattr(value, 'tolist'):
        return value.tolist()
    if isinstance(value, float) and not math.isfinite(value):
        return repr(value)
    return value


def _message_numbers(msgtype: str, msg) -> object:
    if msgtype == 'std_msgs/msg/Float64' or msgtype == 'std_msgs/msg/Bool':
        return _plain(msg.data)
    if msgtype == 'std_msgs/msg/Float64MultiArray':
        return _plain(msg.data)
    if msgtype == 'sensor_msgs/msg/Temperature':
        return [_plain(msg.temperature), _plain(msg.variance)]
    if msgtype == 'sensor_msgs/msg/JointState':
        return {'name': list(msg.name), 'position': _plain(msg.position),
                'velocity': _plain(msg.velocity), 'effort': _plain(msg.effort)}
    if msgtype == 'diagnostic_msgs/msg/DiagnosticArray':
        return [{'level': int(s.level), 'name': s.name, 'message': s.message,
                 'values': {kv.key: kv.value for kv in s.values}} for s in msg.status]
    raise AssertionError(f'an output topic of an unexpected type: {msgtype}')


def replay_outputs(folder: Path) -> dict:
    """Simulate the recording in ``folder``, replay it; return its summary and bag numbers."""
    from robot_wear_monitor.recordings.bags import jazzy_typestore
    bag, out = folder / 'run.bag', folder / 'out.bag'
    assert main(['simulate', '--out', str(bag), '--experiments', '60', '--seed', '7']) == 0
    summary_path = folder / 'summary.json'
    assert main(['replay', str(bag), '--out', str(out), '--json-out', str(summary_path),
                 '--no-progress']) == 0
    summary = json.loads(summary_path.read_text(encoding='utf-8'))
    for key in PATH_KEYS:
        summary.pop(key, None)
    store = jazzy_typestore()
    topics: dict = {}
    with Reader(out) as reader:
        for connection, stamp_ns, raw in reader.messages():
            msg = store.deserialize_cdr(raw, connection.msgtype)
            topics.setdefault(connection.topic, []).append(
                [int(stamp_ns), _message_numbers(connection.msgtype, msg)])
    return {'summary': summary, 'bag': topics}


def _pop_new_state_keys(summary: dict) -> list:
    """
    Remove the keys the summary's ``state`` entries gained after the file was made.

    Issue 42 (schema version 8) added ``threshold`` and ``warning_level`` (the levels the
    latest estimate was judged by); returned per entry ((None, None) where absent, as in a
    file made before), to be checked against the node configuration the replay ran with.
    """
    return [(entry.pop('threshold', None), entry.pop('warning_level', None))
            for entry in summary['state']]


def test_the_replay_gives_the_fixed_outputs_bit_for_bit(tmp_path, capsys):
    from robot_wear_monitor.model.params import load_parameter_set
    from robot_wear_monitor.monitoring.node_config import (load_node_parameters,
                                                           WEAR_ESTIMATOR_NODE)
    from robot_wear_monitor.monitoring.wear_update import node_alarm_levels
    got = json.loads(json.dumps(replay_outputs(tmp_path)))
    capsys.readouterr()
    fixed = json.loads(FIXED.read_text(encoding='utf-8'))
    packaged = load_node_parameters(WEAR_ESTIMATOR_NODE)  # the replay ran with this file
    # its levels are 0: the packaged parameter set's, 35 and 28, judged by and stored
    judged = node_alarm_levels(packaged, load_parameter_set(None))
    assert judged == (35.0, 28.0)
    levels = [judged] * len(fixed['summary']['state'])
    assert _pop_new_state_keys(got['summary']) == levels
    assert _pop_new_state_keys(fixed['summary']) in (levels, [(None, None)] * len(levels))
    assert got['summary'] == fixed['summary']
    assert sorted(got['bag']) == sorted(fixed['bag'])
    for topic in fixed['bag']:
        assert got['bag'][topic] == fixed['bag'][topic], topic
    # the recording raised the alarm on the way: the comparison covers a latch
    assert any(alarm for _, alarm in fixed['bag']['/wear_alarm'])


if __name__ == '__main__' and sys.argv[1:] == ['--write']:
    import tempfile
    with tempfile.TemporaryDirectory() as work:
        FIXED.write_text(json.dumps(replay_outputs(Path(work)), indent=1) + '\n',
                         encoding='utf-8')
    print(f'wrote {FIXED}')
