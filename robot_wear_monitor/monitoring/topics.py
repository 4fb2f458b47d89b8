"""
Names of the monitoring nodes' topics and service, and the ROS type of every output.

Relative names resolve to ``/<name>`` in the root namespace; a node of several joints puts
each joint's outputs under ``<joint>/`` (see ``monitoring/joints.py``).
"""

from __future__ import annotations

from robot_wear_monitor.recordings import messages

#: Topics of the nodes (relative names resolve to /<name> in the root namespace).
FRICTION_LEVELS_TOPIC = 'friction_levels'
TEMPERATURE_TOPIC = 'temperature'
WEAR_TOPIC = 'wear'
ALARM_TOPIC = 'wear_alarm'
DIAGNOSTICS_TOPIC = '/diagnostics'
TREND_TOPIC = 'wear_trend'
RESET_SERVICE = '~/reset_alarm'

#: Topic -> ROS type of every output of the two nodes.
OUTPUT_TOPICS: dict[str, str] = {
    FRICTION_LEVELS_TOPIC: messages.FRICTION_LEVELS_TYPE,
    TEMPERATURE_TOPIC: messages.TEMPERATURE_TYPE,
    WEAR_TOPIC: messages.WEAR_TYPE,
    ALARM_TOPIC: messages.ALARM_TYPE,
    DIAGNOSTICS_TOPIC: messages.DIAGNOSTICS_TYPE,
    TREND_TOPIC: messages.TREND_TYPE,
}
