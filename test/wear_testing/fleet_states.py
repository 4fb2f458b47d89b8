"""
A simulated history with a joint in every state of the fleet view, and the clock's moments.

Alarm, acknowledged,
re-escalated by its wear and by its planned date, cannot judge, stale, warning by level, by a
near crossing and by the parameter set's level of an older row, new life, ok), and the moments
at which the clock alone changes them.
"""

import datetime
import math

from robot_wear_monitor.history import AlarmEvent, HistoryRecord

HOUR_S = 3600.0
DAY_S = 86400.0
#: The last experiment of every joint but the stale one: two hours ago.
LAST_S = math.floor(datetime.datetime.now(datetime.timezone.utc).timestamp()) - 2 * HOUR_S


def _record(robot, joint, stamp_s, *, wear, crossing=math.nan, invalid='', levels=(30.0, 24.0),
            parameter_set='abb_irb6620_joint2'):
    return HistoryRecord(joint=joint, robot=robot, stamp_s=stamp_s, speeds_rad_s=(2.1, 28.5),
                         frictions=(0.1, 0.05), temperature_degc=40.0,
                         temperature_std_degc=2.0, wear=wear, wear_std=2.0, chi2=1.0, dof=0,
                         p_value=0.5, temperature_at_bound=False, wear_at_bound=False,
                         alarm_active=wear >= levels[0], alarm_evidence=0.0, status_level=0,
                         parameter_set=parameter_set, wear_low=wear - 4.0,
                         wear_high=wear + 4.0, trend_wear=wear, trend_low=wear - 3.0,
                         trend_high=wear + 3.0, crossing_experiments=crossing,
                         invalid_reason=invalid, threshold=levels[0], warning_level=levels[1])


def _joint(history, robot, joint, wears, *, last_s=LAST_S, **kwargs):
    for k, wear in enumerate(wears):
        history.append(_record(robot, joint, last_s - (len(wears) - 1 - k) * HOUR_S, wear=wear,
                               **kwargs))


def _raise(history, robot, joint, wear):
    history.record_event(AlarmEvent(joint=joint, robot=robot, stamp_s=LAST_S, event='raised',
                                    wear=wear, note='w-hat >= 30'))


def _fill(history):
    """Write a joint in every state (the names say which, at the first moment)."""
    _joint(history, 'cell_a', 'alarm', [28.0, 31.0, 33.0], crossing=0.0)
    _raise(history, 'cell_a', 'alarm', 33.0)
    _joint(history, 'cell_a', 'acknowledged', [28.0, 31.0, 32.0], crossing=0.0)
    _raise(history, 'cell_a', 'acknowledged', 32.0)
    history.acknowledge_alarm(joint='acknowledged', robot='cell_a', user='ann', owner='team',
                              comment='ordered')
    # acknowledged at 31, then the wear rose 6 past it: re-escalated by its wear
    _joint(history, 'cell_a', 'reescalated_wear', [28.0, 31.0], last_s=LAST_S - HOUR_S,
           crossing=0.0)
    _raise(history, 'cell_a', 'reescalated_wear', 31.0)
    history.acknowledge_alarm(joint='reescalated_wear', robot='cell_a', user='ann',
                              owner='team', comment='ordered')
    history.append(_record('cell_a', 'reescalated_wear', LAST_S, wear=37.0, crossing=0.0))
    # acknowledged, its planned date passes in three days (the clock alone re-escalates it)
    _joint(history, 'cell_b', 'planned', [29.0, 30.5, 31.0], crossing=0.0)
    _raise(history, 'cell_b', 'planned', 31.0)
    planned = datetime.datetime.fromtimestamp(LAST_S + 2 * DAY_S, tz=datetime.timezone.utc)
    history.acknowledge_alarm(joint='planned', robot='cell_b', user='bob', owner='team',
                              comment='next week', planned_maintenance=planned.date().isoformat())
    _joint(history, 'cell_b', 'cannot_judge', [10.0, 11.0, 12.0], invalid='p-value below 1e-3')
    _joint(history, 'cell_b', 'stale', [5.0, 6.0, 7.0], last_s=LAST_S - 2 * DAY_S)
    _joint(history, 'cell_c', 'warning_level', [20.0, 23.0, 25.0])
    # a crossing in 10 experiments an hour apart (near), one in 1,000 (41 days: later near)
    _joint(history, 'cell_c', 'warning_crossing', [10.0, 11.0, 12.0], crossing=10.0)
    _joint(history, 'cell_c', 'crossing_far', [10.0, 11.0, 12.0], crossing=1000.0)
    # an older row: no stored levels (the parameter set's warning level, assumed)
    _joint(history, 'cell_c', 'assumed', [60.0, 61.0, 62.0], levels=(math.nan, math.nan),
           parameter_set='no such set')
    _joint(history, 'cell_d', 'new_life', [30.0, 31.0, 32.0], crossing=0.0)
    _raise(history, 'cell_d', 'new_life', 32.0)
    history.reset_alarm(joint='new_life', robot='cell_d', user='ann', reason='gearbox replaced',
                        stamp_s=LAST_S + 60.0)
    for index in range(4):
        _joint(history, 'cell_d', f'ok_{index}', [5.0 + index, 6.0 + index, 7.0])
    _joint(history, 'arm_cell_e', 'ok', [1.0, 2.0, 3.0])


#: The moments: now; a day later (every joint stale); 50 days later (the planned date and the
#: far crossing passed, overdue).
MOMENTS = (LAST_S + HOUR_S, LAST_S + DAY_S, LAST_S + 50 * DAY_S)
