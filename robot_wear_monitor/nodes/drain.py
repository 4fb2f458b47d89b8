"""
A subscription the executor does not wait on, drained by the node's own timer.

rclpy's executor costs about 290 us of CPU per callback on the reference machine
(docs/benchmarks.md), whatever the callback does; at 1 kHz that is most of a bare
subscriber's cost.  :class:`DrainedSubscription` is an ordinary rclpy subscription (same topic
resolution, remapping and QoS) in a :class:`DrainedCallbackGroup`, which keeps it out of the
executor's wait set, and without QoS event handlers (rclpy's default one only logs a
publisher of incompatible QoS; with Fast DDS its wait woke the executor on every message).
The middleware queues its messages (up to the QoS depth) and
:meth:`DrainedSubscription.take_all`, called from a timer, takes every queued message as
serialised CDR bytes with its reception time.  The executor then wakes once per
timer period, not once per message.

rclpy is imported at the top: only the rclpy nodes import this module.
"""

from __future__ import annotations

import time
from typing import Any

import numpy as np
from rclpy.callback_groups import CallbackGroup
from rclpy.event_handler import SubscriptionEventCallbacks
from rclpy.subscription import Subscription


class DrainedCallbackGroup(CallbackGroup):
    """A callback group whose subscriptions no executor waits on or calls (they are drained)."""

    def can_execute(self, entity: Any) -> bool:
        """Return False for a subscription (kept out of the wait set), True otherwise."""
        return not isinstance(entity, Subscription)

    def beginning_execution(self, entity: Any) -> bool:
        """Allow the group's other entities (the subscription's QoS event handlers)."""
        return not isinstance(entity, Subscription)

    def ending_execution(self, entity: Any) -> None:
        """Nothing to release."""


class DrainedSubscription:
    """
    A raw subscription of ``node`` to ``topic`` that is taken from, never called back.

    :ivar subscription: the rclpy Subscription (``topic_name``, ``get_publisher_count()``).

    """

    def __init__(self, node: Any, msg_type: Any, topic: str, qos: Any) -> None:
        """Subscribe ``node`` (raw: the CDR bytes are kept) in a drained callback group."""
        self.msg_type = msg_type
        # no QoS event handlers: with Fast DDS their wait shares the reader's status
        # condition and woke the executor on every message (measured: more CPU than a
        # callback per message)
        self.subscription = node.create_subscription(
            msg_type, topic, _never_called, qos, callback_group=DrainedCallbackGroup(),
            event_callbacks=SubscriptionEventCallbacks(use_default_callbacks=False), raw=True)
        # what the per-message path's zero stamps take: the node's clock at reception
        self._sim_time = bool(node.get_parameter('use_sim_time').value)
        self._clock = node.get_clock()

    @property
    def topic_name(self) -> str:
        """Return the resolved topic name."""
        return self.subscription.topic_name

    def take_all(self, limit: int) -> tuple[list[bytes], np.ndarray]:
        """
        Take the queued messages, at most ``limit``; return (CDR bytes, reception times [ns]).

        The reception times are the middleware's (system clock), moved onto the node's clock
        under ``use_sim_time``; shape (n,), int64.
        """
        handle = self.subscription.handle
        raws: list[bytes] = []
        received: list[int] = []
        with handle:
            while len(raws) < limit:
                taken = handle.take_message(self.msg_type, True)
                if taken is None:
                    break
                raws.append(taken[0])
                received.append(taken[1]['received_timestamp'])
        stamps = np.array(received, dtype=np.int64)
        if self._sim_time and raws:
            stamps += self._clock.now().nanoseconds - time.time_ns()
        return raws, stamps


def _never_called(_: Any) -> None:  # the group keeps the executor from calling it
    raise RuntimeError('a drained subscription was called back by an executor')
