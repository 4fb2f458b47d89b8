"""
How the friction_experiment_node takes /joint_states: :class:`DrainConfig`, declared once.

By default the node does not wake per message.  Every ``drain_period_s`` it takes every
message queued since its last wake (serialised, as the middleware holds them), decodes them in
one batch with the replay's CDR decoder and segments them with the replay's chunk segmenter
(:mod:`robot_wear_monitor.monitoring.joint_state_batches`), so rclpy's executor cost (about
290 us a wake on the reference machine) is paid per batch instead of per message.
``drain_period_s: 0.0`` goes back to one executor callback per message.

The /joint_states queue (``joint_states_depth``, the subscription's QoS depth) holds what
arrives between two wakes and while a wake is held back: by an estimate in the same process
(``robot-wear-monitor live``) or by a loaded machine that does not schedule the node.  The
default, 4000 messages, is sized as the fastest stream we plan for, 4 kHz, times a worst-case
stall of 1 s: a wake may come up to 0.95 s late at 4 kHz (3.95 s at 1 kHz) without a loss.  A
stall of 0.5 s at 4 kHz lost 1,018 of 40,000 messages at the former depth, 1000, and none at
4000; on a machine at load 15, a drained node at 4 kHz lost 1,649 in one run (a stall of at
least 0.66 s) (docs/benchmarks.md).  The memory is the middleware's, for the messages
queued: 260 bytes a 6-joint message (1 MiB for 4000); without a stall the node's peak RSS
is the same at either depth (165 and 166 MiB at 4 kHz in the bench).

The period is bounded: at 4 kHz the longest period, 0.2 s, is 800 messages, the default 0.05 s
is 200, so that even a 1000-message queue holds a period with room for a late wake.
"""

from __future__ import annotations

from dataclasses import dataclass

from robot_wear_monitor.setting_fields import check_settings, in_range, setting

#: Longest drain period [s]: 800 messages of a 4 kHz stream in a 1000-message queue.
MAX_DRAIN_PERIOD_S = 0.2
#: The default queue [messages]: 4 kHz x a 1 s stall (see the module docstring).
JOINT_STATES_DEPTH = 4000
#: The deepest queue accepted [messages]: 25 s at 4 kHz.
MAX_JOINT_STATES_DEPTH = 100_000


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

    joint_states_depth: int = setting(
        JOINT_STATES_DEPTH, unit='messages', check=in_range(1, MAX_JOINT_STATES_DEPTH),
        description='depth of the /joint_states subscription (reliable, keep last): what the '
                    'middleware holds between two wakes and while one is held back; the '
                    'default is 4 kHz x a 1 s stall; a wake later than depth / rate - '
                    'drain_period_s loses the oldest messages')

    def __post_init__(self) -> None:
        """Check the declared settings."""
        check_settings(self)
