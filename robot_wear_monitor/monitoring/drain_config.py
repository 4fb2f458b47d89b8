"""
How the friction_experiment_node takes /joint_states: :class:`DrainConfig`, declared once.

By default the node does not wake per message.  Every ``drain_period_s`` it takes every
message queued since its last wake (serialised, as the middleware holds them), decodes them in
one batch with the replay's CDR decoder and segments them with the replay's chunk segmenter
(:mod:`robot_wear_monitor.monitoring.joint_state_batches`), so rclpy's executor cost (about
290 us a wake on the reference machine) is paid per batch instead of per message.
``drain_period_s: 0.0`` goes back to one executor callback per message.

The period is bounded: the /joint_states queue (depth 1000,
:data:`robot_wear_monitor.nodes.qos.JOINT_STATES_QOS`) must hold what arrives between two wakes
with room for a late one: at 4 kHz the longest period, 0.2 s, is 800 messages, the default
0.05 s is 200 (0.2 s of slack for a wake held back by an estimate in the same process).
"""

from __future__ import annotations

from dataclasses import dataclass

from robot_wear_monitor.setting_fields import check_settings, in_range, setting

#: Longest drain period [s]: 800 messages of a 4 kHz stream in the 1000-message queue.
MAX_DRAIN_PERIOD_S = 0.2


@dataclass(frozen=True)
class DrainConfig:
    """The friction_experiment_node's intake of /joint_states (see the module docstring)."""

    drain_period_s: float = setting(
        0.05, unit='s', check=in_range(0.0, MAX_DRAIN_PERIOD_S),
        description='period of the wakes that take every /joint_states message queued since '
                    'the last one and segment them as one batch (the executor is paid per '
                    'batch, not per message); an experiment is published at most this much '
                    'plus the batch processing after the sample that completes it; 0: one '
                    'executor callback per message')

    def __post_init__(self) -> None:
        """Check the declared settings."""
        check_settings(self)
