# flake8: noqa  (a one-off script run with the released code; see README.md)
"""Add joint_3 (raised, then reset after maintenance) to the v2 history, with the released API."""
import sys

from robot_wear_monitor.history import AlarmEvent, HistoryRecord, WearHistory, SCHEMA_VERSION
assert SCHEMA_VERSION == 2
with WearHistory(sys.argv[1]) as h:
    base = h.records(joint='joint_2')
    for k, r in enumerate(base[:3]):
        rec = HistoryRecord(**{**r.__dict__, 'id': None, 'joint': 'joint_3',
                               'stamp_s': r.stamp_s + 10.0, 'alarm_active': k == 2})
        ev = [AlarmEvent(joint='joint_3', stamp_s=rec.stamp_s, event='raised', wear=rec.wear,
                         note='made by the released code')] if k == 2 else []
        last = h.append(rec, events=ev)
    h.record_event(AlarmEvent(joint='joint_3', stamp_s=base[2].stamp_s + 20.0, event='reset',
                              wear=None, note='reset after maintenance', estimate_id=last))
