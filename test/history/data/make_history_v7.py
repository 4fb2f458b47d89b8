# flake8: noqa  (a one-off script run with the released code; see README.md)
"""Write a small version-7 fleet history with the released API (main at 7976ebe)."""
import sys

from robot_wear_monitor.history import (AlarmEvent, HistoryRecord, SCHEMA_VERSION,
                                        WearHistory)
assert SCHEMA_VERSION == 7


def record(k, *, robot, joint, wear, alarm=False, evidence=0.0):
    return HistoryRecord(robot=robot, joint=joint, stamp_s=1.7e9 + 3600.0 * k,
                         speeds_rad_s=(2.1, 28.5), frictions=(0.1 + wear / 1000, 0.05),
                         temperature_degc=40.0, temperature_std_degc=2.0, wear=wear,
                         wear_std=2.5, chi2=1.0, dof=0, p_value=0.5,
                         temperature_at_bound=False, wear_at_bound=False, alarm_active=alarm,
                         alarm_evidence=evidence, status_level=2 if alarm else 0,
                         parameter_set='abb_irb6620_joint2', wear_low=wear - 5, wear_high=wear + 5,
                         trend_wear=wear, trend_low=wear - 3, trend_high=wear + 3,
                         crossing_experiments=max(0.0, (50 - wear) / 5),
                         crossing_time_s=3600.0 * max(0.0, (50 - wear) / 5))


with WearHistory(sys.argv[1], robot='cell_1') as h:
    # cell_1/joint_2: raised at k=3 (w = 38), latched
    for k, wear in enumerate((20.0, 30.0, 33.0, 38.0)):
        events = [AlarmEvent(joint='joint_2', stamp_s=1.7e9 + 3600.0 * k, event='raised',
                             wear=wear, note='w above the threshold')] if k == 3 else []
        h.append(record(k, robot='cell_1', joint='joint_2', wear=wear, alarm=k >= 3,
                        evidence=2.0 * k), events=events)
    # cell_1/joint_3: healthy
    for k, wear in enumerate((12.0, 14.0)):
        h.append(record(k, robot='cell_1', joint='joint_3', wear=wear))
    h.add_user(name='mia', role='admin', password='admin-pass-123')
