"""
A notification pass with marks reads what changed and what the clock moved, not every joint.

On the history of every state (``wear_testing.fleet_states``), both backends: the first pass
reads every joint; a pass with nothing new reads none; a new estimate, an acknowledgement and
a reset bring their joint; the clock alone brings the joints gone stale, the crossings come
near or passed and the planned date passed; and the events due for the joints read are those a
pass of every joint finds for them.
"""

import math

import pytest
from robot_wear_monitor.fleet.notifications import due_events, load_notification_config
from robot_wear_monitor.fleet.notify_marks import advance, joints_to_read, PassMarks
from robot_wear_monitor.history import WearHistory
from wear_testing.fleet_states import _fill, _record, DAY_S, HOUR_S, LAST_S, MOMENTS
import yaml


@pytest.fixture
def history(history_location):
    with WearHistory(history_location) as opened:
        _fill(opened)
        yield opened


@pytest.fixture
def config(tmp_path):
    path = tmp_path / 'notifications.yaml'
    path.write_text(yaml.safe_dump({
        'forecast_horizon_days': 30, 'first_pass_summary': False,
        'events': ['alarm_raised', 'forecast_crossing', 'joint_stale'],
        'webhooks': [{'name': 'ops', 'url': 'http://127.0.0.1:9/hook', 'receiver': 'x'}]}))
    return load_notification_config(path)


def _read(history, marks, now_s, config):
    joints, after = joints_to_read(history, marks, now_s=now_s,
                                   horizon_s=config.forecast_horizon_s, log_rows=[])
    advance(marks, after, now_s=now_s)
    return joints


def _keys(events):
    return sorted(e.key for e in events)


def test_a_pass_reads_what_changed_and_what_the_clock_moved(history, config):
    marks = PassMarks()
    assert _read(history, marks, MOMENTS[0], config) is None  # the first pass: every joint
    assert marks.started and marks.estimate_id > 0
    assert _read(history, marks, MOMENTS[0] + 1.0, config) == set()  # nothing new
    history.append(_record('cell_d', 'ok_1', LAST_S + HOUR_S, wear=8.0))
    history.acknowledge_alarm(joint='alarm', robot='cell_a', user='ann', owner='team',
                              comment='on it')
    assert _read(history, marks, MOMENTS[0] + 2.0, config) == {
        ('cell_d', 'ok_1'), ('cell_a', 'alarm')}
    # a day later, no write: every joint with a usual interval (an hour) went stale
    moved = _read(history, marks, MOMENTS[1], config)
    fresh = {('cell_b', 'stale')}  # stale before the last pass already
    every = {(r.robot, r.joint) for r in history.fleet()}
    assert moved == every - fresh
    # 50 days on: the far crossing (1,000 h) came near and passed, the planned date passed
    moved = _read(history, marks, MOMENTS[2], config)
    assert {('cell_c', 'crossing_far'), ('cell_b', 'planned')} <= moved
    assert ('cell_d', 'ok_2') not in moved  # stale long ago, nothing since


def test_the_events_of_the_joints_read_are_the_full_passs(history, config):
    marks = PassMarks()
    _read(history, marks, MOMENTS[0], config)
    for now_s in MOMENTS[1:]:
        joints = _read(history, marks, now_s, config)
        full = [e for e in due_events(history=history, config=config, now_s=now_s)
                if (e.robot, e.joint) in joints]
        assert _keys(due_events(history=history, config=config, now_s=now_s,
                                joints=joints)) == _keys(full)
        assert full  # something moved with the clock
    # every event due now whose joint was not read was due at the pass before (sent then)
    before = {e.key for e in due_events(history=history, config=config,
                                        now_s=MOMENTS[2] - DAY_S)}
    now = due_events(history=history, config=config, now_s=MOMENTS[2])
    assert all(e.key in before for e in now if (e.robot, e.joint) not in joints)
    assert not math.isnan(marks.now_s)
