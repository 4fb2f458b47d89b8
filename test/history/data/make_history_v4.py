# flake8: noqa  (a one-off script run with the released code; see README.md)
"""Write a small version-4 fleet history with the released API (main at 1885e4b)."""
import sys

from robot_wear_monitor.history import (AlarmEvent, HistoryRecord, SCHEMA_VERSION,
                                                   WearHistory)
assert SCHEMA_VERSION == 4


def record(k, *, robot, joint, wear, alarm=False, evidence=0.0, invalid=''):
    return HistoryRecord(robot=robot, joint=joint, stamp_s=1.7e9 + 3600.0 * k,
                         speeds_rad_s=(2.1, 28.5), frictions=(0.1 + wear / 1000, 0.05),
                         temperature_degc=40.0, temperature_std_degc=2.0, wear=wear,
                         wear_std=2.5, chi2=1.0, dof=0, p_value=0.5,
                         temperature_at_bound=False, wear_at_bound=False, alarm_active=alarm,
                         alarm_evidence=evidence, status_level=2 if alarm else 0,
                         parameter_set='kuka', wear_low=wear - 5, wear_high=wear + 5,
                         trend_wear=wear, trend_low=wear - 3, trend_high=wear + 3,
                         crossing_experiments=max(0.0, (50 - wear) / 5),
                         crossing_time_s=3600.0 * max(0.0, (50 - wear) / 5),
                         invalid_reason=invalid)


with WearHistory(sys.argv[1], robot='cell_1') as h:
    # cell_1/joint_2: wear rises, the alarm is raised at k=4 and stays latched
    for k, wear in enumerate((20.0, 28.0, 36.0, 44.0, 52.0, 55.0)):
        alarm = k >= 4
        events = [AlarmEvent(joint='joint_2', stamp_s=1.7e9 + 3600.0 * k, event='raised',
                             wear=wear, note='w above the threshold')] if k == 4 else []
        h.append(record(k, robot='cell_1', joint='joint_2', wear=wear, alarm=alarm,
                        evidence=2.0 * max(0, k - 2)), events=events)
    # cell_1/joint_3: raised at k=2, then reset after maintenance, one new-life estimate
    last = None
    for k, wear in enumerate((40.0, 48.0, 53.0)):
        events = [AlarmEvent(joint='joint_3', stamp_s=1.7e9 + 3600.0 * k, event='raised',
                             wear=wear, note='w above the threshold')] if k == 2 else []
        last = h.append(record(k, robot='cell_1', joint='joint_3', wear=wear, alarm=k == 2,
                               evidence=3.0 * k), events=events)
    h.record_event(AlarmEvent(joint='joint_3', stamp_s=1.7e9 + 3600.0 * 2.5, event='reset',
                              wear=None, note='reset after maintenance', estimate_id=last))
    h.append(record(3, robot='cell_1', joint='joint_3', wear=5.0))
    # cell_2/joint_1: two estimates, the latest one could not be judged
    h.append(record(0, robot='cell_2', joint='joint_1', wear=12.0))
    h.append(record(1, robot='cell_2', joint='joint_1', wear=13.0,
                    invalid='temperature far outside the identified range'))
    h.add_recording(fingerprint='ab' * 16, name='cell_1_2026-01-01.mcap', experiments=9)
