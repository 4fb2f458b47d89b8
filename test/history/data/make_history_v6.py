# flake8: noqa  (a one-off script run with the released code; see README.md)
"""Write a small version-6 fleet history with the released API (main at 6cbfde9)."""
import sys

from robot_wear_monitor.history import (AlarmEvent, HistoryRecord, SCHEMA_VERSION,
                                        WearHistory)
assert SCHEMA_VERSION == 6


def record(k, *, robot, joint, wear, alarm=False, evidence=0.0):
    return HistoryRecord(robot=robot, joint=joint, stamp_s=1.7e9 + 3600.0 * k,
                         speeds_rad_s=(2.1, 28.5), frictions=(0.1 + wear / 1000, 0.05),
                         temperature_degc=40.0, temperature_std_degc=2.0, wear=wear,
                         wear_std=2.5, chi2=1.0, dof=0, p_value=0.5,
                         temperature_at_bound=False, wear_at_bound=False, alarm_active=alarm,
                         alarm_evidence=evidence, status_level=2 if alarm else 0,
                         parameter_set='kuka', wear_low=wear - 5, wear_high=wear + 5,
                         trend_wear=wear, trend_low=wear - 3, trend_high=wear + 3,
                         crossing_experiments=max(0.0, (50 - wear) / 5),
                         crossing_time_s=3600.0 * max(0.0, (50 - wear) / 5))


with WearHistory(sys.argv[1], robot='cell_1') as h:
    # cell_1/joint_2: raised at k=3, acknowledged by mia (latched)
    for k, wear in enumerate((20.0, 30.0, 38.0, 46.0, 50.0)):
        events = [AlarmEvent(joint='joint_2', stamp_s=1.7e9 + 3600.0 * k, event='raised',
                             wear=wear, note='w above the threshold')] if k == 3 else []
        h.append(record(k, robot='cell_1', joint='joint_2', wear=wear, alarm=k >= 3,
                        evidence=2.0 * k), events=events)
    h.acknowledge_alarm(joint='joint_2', user='mia', owner='Team B', comment='gearbox ordered',
                        planned_maintenance='2026-12-01')
    # cell_1/joint_3: raised at k=1, reset by mia after maintenance
    for k, wear in enumerate((40.0, 48.0)):
        events = [AlarmEvent(joint='joint_3', stamp_s=1.7e9 + 3600.0 * k, event='raised',
                             wear=wear, note='w above the threshold')] if k == 1 else []
        h.append(record(k, robot='cell_1', joint='joint_3', wear=wear, alarm=k == 1,
                        evidence=3.0 * k), events=events)
    h.reset_alarm(joint='joint_3', user='mia', reason='gearbox replaced')
    h.add_user(name='mia', role='maintainer', password='maintainer-pass-1')
    h.add_user(name='vic', role='viewer', password='viewer-pass-22')
    h.start_session(user='mia', lifetime_s=10 * 365 * 86400.0)
    h.claim_notification(event_key='cell_1/joint_2/raised/4', robot='cell_1', joint='joint_2',
                         kind='alarm_raised', channel='webhook', payload={'summary': 'wear alarm'})
    h.add_recording(fingerprint='cd' * 16, name='cell_1_2026-06-01.mcap', experiments=7)
