"""
The fleet read through its stored keys (schema 12) equals the full ranking, on both backends.

A simulated history holds a joint in every state (alarm, acknowledged, re-escalated by its
wear and by its planned date, cannot judge, stale, warning by level, by a near crossing and by
the parameter set's level of an older row, new life, ok).  At three moments (no write between
them: the clock alone makes joints stale, crossings near or overdue and a planned date pass)
the index's pages, filters, robots, stream and counts are those of
:func:`~robot_wear_monitor.fleet.ranking.fleet_view` of the whole fleet; a schema-11 history
migrates and gives the same; the robot search finds by prefix first.
"""

from collections import Counter
import sqlite3

import pytest
from robot_wear_monitor.fleet.indexed import fleet_clock, page_views, stream_views
from robot_wear_monitor.fleet.ranking import fleet_view
from robot_wear_monitor.fleet.states import STATES
from robot_wear_monitor.history import is_postgresql_url, WearHistory
from robot_wear_monitor.history.fleet_index import KEY_COLUMNS
from wear_testing.fleet_states import _fill, _record, HOUR_S, LAST_S, MOMENTS


def _full(history, now_s):
    return fleet_view(history.fleet(), now_s=now_s)


def _summary(views):
    return [(v.state.robot, v.state.joint, v.condition, v.reescalated, v.stale,
             v.crossing_overdue) for v in views]


@pytest.fixture
def history(history_location):
    with WearHistory(history_location) as opened:
        _fill(opened)
        yield opened


def _check_equal(history):
    index = history.fleet_index()
    seen = set()
    for now_s in MOMENTS:
        full = _full(history, now_s)
        clock = fleet_clock(index, now_s=now_s)
        assert _summary(page_views(index, clock)) == _summary(full)
        assert [v.as_json() for v in page_views(index, clock)] == [v.as_json() for v in full]
        for limit in (1, 3, 4):
            pages = [page_views(index, clock, offset=o, limit=limit)
                     for o in range(0, len(full) + limit, limit)]
            assert _summary([v for p in pages for v in p]) == _summary(full)
        assert _summary(stream_views(index, clock, chunk=2)) == _summary(full)
        for state in STATES:
            chosen = [v for v in full if v.condition == state]
            assert _summary(page_views(index, clock, state=state)) == _summary(chosen)
            assert index.total(clock, state=state) == len(chosen)
            assert _summary(page_views(index, clock, state=state, offset=1, limit=2)) == \
                _summary(chosen[1:3])
        for robot in {v.state.robot for v in full}:
            chosen = [v for v in full if v.state.robot == robot]
            assert _summary(page_views(index, clock, robot=robot)) == _summary(chosen)
            assert index.total(clock, robot=robot) == len(chosen)
        counts = index.counts(clock)
        assert counts == {s: Counter(v.condition for v in full)[s] for s in STATES}
        seen |= {v.condition for v in full}
    return seen


def test_the_index_gives_the_full_rankings_rows_order_and_states(history):
    seen = _check_equal(history)
    assert seen == set(STATES)  # every state met
    now = {v.state.joint: v for v in _full(history, MOMENTS[0])}
    assert now['reescalated_wear'].condition == 'alarm' and now['reescalated_wear'].reescalated
    assert now['planned'].condition == 'acknowledged'
    assert now['crossing_far'].condition == 'ok' and now['stale'].condition == 'stale'
    assert now['assumed'].condition == 'warning' and now['assumed'].threshold_assumed
    later = {v.state.joint: v for v in _full(history, MOMENTS[2])}
    assert later['planned'].condition == 'alarm' and 'planned' in later['planned'].reescalated
    assert later['crossing_far'].crossing_overdue and later['crossing_far'].stale


def test_a_write_moves_the_joint_in_the_index(history):
    """An acknowledgement, a withdrawal, a reset and a new experiment each keep the keys."""
    history.acknowledge_alarm(joint='alarm', robot='cell_a', user='ann', owner='team',
                              comment='on it')
    _check_equal(history)
    history.withdraw_acknowledgement(joint='acknowledged', robot='cell_a', user='ann',
                                     reason='wrong joint')
    history.reset_alarm(joint='reescalated_wear', robot='cell_a', user='ann', reason='done')
    history.append(_record('cell_d', 'new_life', LAST_S + HOUR_S, wear=3.0))
    history.append(_record('cell_d', 'ok_0', LAST_S + HOUR_S, wear=40.0, crossing=0.0))
    _check_equal(history)


def _downgrade_to_11(location):
    """Make the history a schema-11 one: ``joint_summary`` without the keys, version 11."""
    # version 14's additions first (the counts kept on write), then 13's (the login
    # failures, the notifications' lease)
    postgresql = is_postgresql_url(location)
    statements = ['DROP TABLE fleet_state_counts', 'DROP INDEX joint_summary_stale_state']
    on_table = ' ON joint_summary' if postgresql else ''
    statements += [f'DROP TRIGGER IF EXISTS {name}{on_table}'
                   for name in ('joint_summary_count_insert', 'joint_summary_count_delete',
                                'joint_summary_count_update', 'joint_summary_count_rows')]
    statements += ['DROP FUNCTION wear_fleet_state_count'] if postgresql else []
    statements += ['DROP TABLE login_failures',
                   'ALTER TABLE notifications DROP COLUMN pending_until_s']
    statements += [f'DROP INDEX IF EXISTS {name}' for name in (
        'joint_summary_rank', 'joint_summary_stale', 'joint_summary_crossing',
        'joint_summary_last', 'joint_summary_assumed', 'joint_summary_state',
        'joint_summary_rise', 'joint_summary_planned', 'joint_summary_near')]
    statements += ['DROP TABLE fleet_robots']
    statements += [f'ALTER TABLE joint_summary DROP COLUMN {c}' for c in KEY_COLUMNS]
    statements += ['UPDATE schema_version SET version = 11']
    if is_postgresql_url(location):
        import psycopg  # deferred import: optional extra (PostgreSQL)
        with psycopg.connect(location, autocommit=True) as conn:
            for sql in statements:
                conn.execute(sql)
        return
    with sqlite3.connect(location) as conn:
        for sql in statements:
            conn.execute(sql)


def test_a_schema_11_history_migrates_and_gives_the_same_page(history_location):
    with WearHistory(history_location) as history:
        _fill(history)
        expected = {now_s: _summary(_full(history, now_s)) for now_s in MOMENTS}
    _downgrade_to_11(history_location)
    with WearHistory(history_location) as history:
        index = history.fleet_index()
        for now_s in MOMENTS:
            clock = fleet_clock(index, now_s=now_s)
            assert _summary(page_views(index, clock)) == expected[now_s]
        _check_equal(history)


def test_the_robot_search_finds_by_prefix_first(history):
    index = history.fleet_index()
    assert index.robots(search='cell') == ['cell_a', 'cell_b', 'cell_c', 'cell_d', 'arm_cell_e']
    assert index.robots(search='CELL_B') == ['cell_b']
    assert index.robots(search='cell', limit=2) == ['cell_a', 'cell_b']
    assert index.robots(search='%') == [] and index.robots(search='_e') == ['arm_cell_e']
    assert index.robot_count() == 5 and index.has_robot('cell_c')
    assert not index.has_robot('cell')


@pytest.mark.parametrize('robot', [None, 'cell_c'])
def test_fleet_json_is_streamed_unchanged(history, history_location, capsys, robot):
    """``fleet --json`` prints the full ranking's list, byte for byte as one document did."""
    import json
    from robot_wear_monitor.cli import main
    now_s = MOMENTS[1]
    rows = [v.as_json() for v in fleet_view(history.fleet(robot=robot), now_s=now_s)]
    capsys.readouterr()
    more = ['--robot', robot] if robot else []
    assert main(['fleet', '--history', history_location, '--now', str(now_s), *more,
                 '--json']) == 0
    out = capsys.readouterr().out
    assert out == json.dumps(rows, indent=2, allow_nan=False) + '\n'
    assert len(json.loads(out)) == (16 if robot is None else 4)


def test_an_empty_fleet_prints_an_empty_json_list(history_location, capsys):
    from robot_wear_monitor.cli import main
    WearHistory(history_location).close()
    capsys.readouterr()
    assert main(['fleet', '--history', history_location, '--json']) == 0
    assert capsys.readouterr().out == '[]\n'
