"""
Play a recorded bag on the live ROS 2 graph (``robot-wear-monitor play``).

For hosts without rosbag2 (a pip-only install): the bag is read with rosbags and every message
of the chosen topics is published as recorded (raw CDR bytes, header stamps untouched) at the
recorded pace divided by ``rate``, like ``ros2 bag play --rate``.  Topics whose message package
is not importable are skipped and named.  Publishers are reliable (depth 1000); the player
waits for subscribers before it starts (discovery takes a moment on a fresh graph) and for
every subscriber to acknowledge the last messages before it ends.
"""

from __future__ import annotations

from dataclasses import dataclass
import importlib
import os
import time
from typing import Any, Callable, Optional, Sequence

from rclpy.duration import Duration
from rclpy.node import Node
from rclpy.qos import HistoryPolicy, QoSProfile, ReliabilityPolicy
from robot_wear_monitor.recordings.bags import BagError, iter_recorded_messages, recorded_topics

PLAYER_NODE = 'robot_wear_monitor_player'
PLAYER_QOS = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=1000,
                        reliability=ReliabilityPolicy.RELIABLE)


def message_class(msgtype: str) -> Optional[type]:
    """Return the rclpy class of ``pkg/msg/Name``, or None when its package is not installed."""
    package, kind, name = (msgtype.split('/') + ['', ''])[:3]
    try:
        return getattr(importlib.import_module(f'{package}.{kind}'), name)
    except (ImportError, AttributeError, ValueError):
        return None


@dataclass
class PlayResult:
    """What a play published: messages per topic, wall time, skipped topics."""

    published: dict[str, int]
    skipped: dict[str, str]
    wall_s: float
    bag_span_s: float


class BagPlayer(Node):
    """A node with one raw publisher per played topic."""

    def __init__(self, topics: dict[str, type], **kwargs: Any) -> None:
        """Advertise ``topics`` (topic -> message class)."""
        super().__init__(PLAYER_NODE, **kwargs)
        self.publishers_by_topic = {topic: self.create_publisher(cls, topic, PLAYER_QOS)
                                    for topic, cls in topics.items()}

    def wait_for_subscribers(self, count: int, *, timeout_s: float) -> bool:
        """Wait until every topic has ``count`` subscribers; False on timeout."""
        deadline = time.monotonic() + timeout_s
        while time.monotonic() < deadline:
            if all(p.get_subscription_count() >= count
                   for p in self.publishers_by_topic.values()):
                return True
            time.sleep(0.05)
        return False

    def wait_for_acks(self, timeout_s: float) -> bool:
        """Wait until every reliable subscriber acknowledged what was published."""
        timeout = Duration(seconds=timeout_s)
        return all(p.wait_for_all_acked(timeout) for p in self.publishers_by_topic.values())


def play_bag(bag: str | os.PathLike, *, rate: float = 1.0, topics: Sequence[str] | None = None,
             wait_for_subscribers: int = 1, wait_timeout_s: float = 10.0,
             say: Callable[[str], None] = print) -> PlayResult:
    """
    Publish the messages of ``bag`` at the recorded pace / ``rate`` (rclpy must be init).

    :param bag: the bag folder (MCAP or sqlite3).
    :param rate: speed-up of the recorded pace (2.0 plays twice as fast); > 0.
    :param topics: topics to play (all recorded ones when None).
    :param wait_for_subscribers: subscribers each topic waits for before the play starts.
    :param wait_timeout_s: how long to wait for them; the play starts anyway afterwards.
    :param say: where progress lines go.

    :raises BagError: the bag cannot be read, or a requested topic is not in it.

    """
    if not rate > 0:
        raise BagError(f'{bag}: rate must be > 0, got {rate}')
    recorded = recorded_topics(bag)
    wanted = list(recorded) if topics is None else list(topics)
    missing = [t for t in wanted if t not in recorded]
    if missing:
        raise BagError(f'{bag}: no topic {missing[0]} (topics: {", ".join(sorted(recorded))})')
    classes, skipped = {}, {}
    for topic in wanted:
        cls = message_class(recorded[topic])
        if cls is None:
            skipped[topic] = f'{recorded[topic]} is not installed'
        else:
            classes[topic] = cls
    for topic, why in skipped.items():
        say(f'skipping {topic}: {why}')
    player = BagPlayer(classes)
    published = dict.fromkeys(classes, 0)
    try:
        if wait_for_subscribers > 0 and not player.wait_for_subscribers(
                wait_for_subscribers, timeout_s=wait_timeout_s):
            say(f'no {wait_for_subscribers} subscriber(s) after {wait_timeout_s:g} s; '
                'playing anyway')
        say(f'playing {", ".join(classes) or "nothing"} from {bag} at rate {rate:g}')
        start = time.monotonic()
        first_ns = last_ns = None
        for topic, stamp_ns, raw in iter_recorded_messages(bag, topics=list(classes)):
            if first_ns is None:
                first_ns = stamp_ns
            last_ns = stamp_ns
            due = start + (stamp_ns - first_ns) * 1e-9 / rate
            delay = due - time.monotonic()
            if delay > 0:
                time.sleep(delay)
            player.publishers_by_topic[topic].publish(bytes(raw))
            published[topic] += 1
        wall_s = time.monotonic() - start
        player.wait_for_acks(timeout_s=10.0)
    finally:
        player.destroy_node()
    span = 0.0 if first_ns is None or last_ns is None else (last_ns - first_ns) * 1e-9
    say(f'played {sum(published.values())} messages ('
        + ', '.join(f'{t}: {n}' for t, n in published.items())
        + f') spanning {span:.1f} s of recording in {wall_s:.1f} s')
    return PlayResult(published=published, skipped=skipped, wall_s=wall_s, bag_span_s=span)
