"""
The joints per state kept on write (schema 14) and the clock's share of the counts.

The stored counts equal a count of ``joint_summary`` after every kind of write, on both
backends, also with writers at once on PostgreSQL (their counts spread over stripes); the
counts per state equal the full ranking's at the moments the clock passes a stored time (a
stale moment, the end of a crossing's horizon) within the second the counts judge exactly
and outside it; the ETag's next times change when, and only when, the clock passes one.
"""

from collections import Counter
import threading

import pytest
from robot_wear_monitor.fleet.indexed import fleet_clock
from robot_wear_monitor.fleet.ranking import fleet_view
from robot_wear_monitor.fleet.states import DAY_S, DEFAULT_FORECAST_HORIZON_DAYS, STATES
from robot_wear_monitor.history import WearHistory
from robot_wear_monitor.history.fleet_counts import stable_counts
from wear_testing.fleet_states import _fill, _record, HOUR_S, LAST_S

HORIZON_S = DEFAULT_FORECAST_HORIZON_DAYS * DAY_S


@pytest.fixture
def history(history_location):
    with WearHistory(history_location) as opened:
        _fill(opened)
        yield opened


def _recounted(history):
    rows = history._backend.execute('SELECT state_base, warn_fixed, COUNT(*) FROM joint_summary '
                                    'GROUP BY state_base, warn_fixed')
    return sorted((r[0], int(r[1]), int(r[2])) for r in rows)


def _stored(history):
    return sorted(stable_counts(history._backend))


def _times(history, column):
    return {r[0]: float(r[1]) for r in history._backend.execute(
        f'SELECT joint, {column} FROM joint_summary WHERE {column} IS NOT NULL')}


def test_the_stored_counts_follow_every_kind_of_write(history):
    assert _stored(history) == _recounted(history)
    assert sum(c for _, _, c in _stored(history)) == len(history.fleet())
    history.acknowledge_alarm(joint='alarm', robot='cell_a', user='ann', owner='team',
                              comment='on it')
    history.withdraw_acknowledgement(joint='acknowledged', robot='cell_a', user='ann',
                                     reason='wrong joint')
    history.reset_alarm(joint='reescalated_wear', robot='cell_a', user='ann', reason='done')
    history.append(_record('cell_d', 'ok_0', LAST_S + HOUR_S, wear=40.0, crossing=0.0))
    history.append(_record('cell_f', 'brand_new', LAST_S + HOUR_S, wear=3.0))
    assert _stored(history) == _recounted(history)
    before = {(b, f): c for b, f, c in _stored(history)}
    assert before[('acknowledged', 1)] >= 1 and before[('new life', 0)] >= 1


def test_the_counts_at_the_clocks_edges_equal_the_full_ranking(history):
    stale_at = _times(history, 'stale_at_s')['stale']
    crossing_at = _times(history, 'crossing_at_s')['warning_crossing']
    moments = [stale_at + d for d in (-2.0, -0.5, -1e-3, 1e-3, 0.5, 2.0)]
    moments += [crossing_at - HORIZON_S + d for d in (-2.0, -0.5, -1e-3, 1e-3, 0.5, 2.0)]
    index = history.fleet_index()
    rows = history.fleet()
    seen = set()
    for now_s in moments:
        full = Counter(v.condition for v in fleet_view(rows, now_s=now_s))
        assert index.counts(fleet_clock(index, now_s=now_s)) == {s: full[s] for s in STATES}
        seen.add((full['stale'], full['warning']))
    assert len(seen) >= 3  # the edges moved joints both ways


def test_the_etags_next_times_change_when_the_clock_passes_a_stored_time(history):
    index = history.fleet_index()

    def passed(now_s):
        return index.next_times(fleet_clock(index, now_s=now_s))

    stale_at = _times(history, 'stale_at_s')['stale']
    assert passed(stale_at - 2.0) == passed(stale_at - 1.0)
    assert passed(stale_at - 1.0) != passed(stale_at + 1.0)
    crossing_at = _times(history, 'crossing_at_s')['warning_crossing']
    edge = crossing_at - HORIZON_S
    times = sorted([*_times(history, 'stale_at_s').values(),
                    *_times(history, 'crossing_at_s').values(),
                    *(t - HORIZON_S for t in _times(history, 'crossing_at_s').values())])
    nearest = min(abs(t - edge) for t in times if t != edge and t != crossing_at)
    assert nearest > 2.0  # nothing else passes between the two moments below
    assert passed(edge - 1.0) != passed(edge + 1.0)


def test_writers_at_once_keep_the_counts(postgresql_url):
    """Check PostgreSQL's writers at once (SQLite has one writer at a time)."""
    history_location = postgresql_url
    with WearHistory(history_location) as history:
        _fill(history)
    errors = []

    def write(worker):
        try:
            with WearHistory(history_location) as mine:
                for k in range(12):
                    wear = 10.0 + 2.5 * k  # judged, then warned, then an alarm level
                    mine.append(_record(f'cell_w{worker}', f'joint_{k % 3}',
                                        LAST_S + (k + 1) * 60.0, wear=wear,
                                        crossing=0.0 if wear >= 30.0 else 50.0))
        except Exception as error:  # a thread's failure, failed in the test below
            errors.append(error)

    threads = [threading.Thread(target=write, args=(w,)) for w in range(4)]
    for thread in threads:
        thread.start()
    for thread in threads:
        thread.join()
    assert not errors
    with WearHistory(history_location) as history:
        assert _stored(history) == _recounted(history)
        stripes = history._backend.execute('SELECT COUNT(DISTINCT stripe) FROM '
                                           'fleet_state_counts')[0][0]
        assert int(stripes) >= 2  # the writers' counts spread over several rows
