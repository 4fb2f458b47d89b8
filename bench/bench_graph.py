"""
Cost on the graph: friction_experiment_node against a do-nothing subscriber (prints only).

    python3 bench/bench_graph.py [--rates 250,1000] [--duration 10] [--repeat 1]
        [--variants single,single-callback,events] [--profile 20000]
        [--no-shell] [--no-estimator] [--pin]

A 6-joint sensor_msgs/JointState stream (joint_1..joint_6, the node's /joint_states QoS from
``robot_wear_monitor.nodes.qos``) is published at each rate for ``--duration`` seconds by a
publisher process, paced with ``time.perf_counter``.  ``joint_2`` moves back and forth at
constant speeds (a triangle wave in position cycling through the node's default experiment
speeds, 0.5 s per pass; effort = friction + gravity + noise) so the node really segments,
completes experiments (one every 4 s) and publishes ``friction_levels``; it stands still for the
last 0.5 s; header stamps are the simulated times.

One run per rate and variant, each with its own ROS_DOMAIN_ID and localhost-only discovery, and
these processes: the publisher (it starts once it has matched every subscriber), the node (the
package's ``FrictionExperimentNode``, default parameters, plus a message counter), its shell
(the same node with the callback replaced by the counter: imports, entities and executor
without the work) and a do-nothing rclpy subscriber of the same topic and QoS that only counts;
and (unless ``--no-estimator``) the package's ``WearEstimatorNode`` (default parameters but an
in-memory history) with a probe of its ``wear`` and ``temperature`` and of ``friction_levels``,
in a process of its own.  After the stream (and after the CPU figures are taken) the bench
waits until the estimator has published every experiment's wear (the node closes the last
one when /joint_states has been silent for ``idle_gap_s``) and compares, per run, the
published friction levels, w-hat and T-hat with what the package's replay
(``replay_bag``) makes of a bag of the same CDR payloads: ``equal`` only if every value is
the same float (no tolerance).
All subscribers of a run use the same executor (the variant's first word); the do-nothing
subscriber is always a plain callback per message (typed; raw with ``-raw``, ``-cdr``,
``-batch``):

* ``single``: rclpy's SingleThreadedExecutor (what ``rclpy.spin`` and the nodes use), the node
  with its defaults: it drains /joint_states every ``drain_period_s`` (0.05 s) and segments each
  batch (its shell only counts the drained messages);
* ``-callback``: the node with ``drain_period_s: 0.0``, one callback per message (the node's
  behaviour before issue 46; the ``-raw``, ``-cdr`` and ``-batch`` nodes are built on it);
* ``events``: ``rclpy.experimental.EventsExecutor``, driven by ``spin_once(timeout_sec=3600)``
  (its ``spin()`` busy-polls in rclpy 7.1.6, see the executor check);
* ``-raw``: ``raw=True`` subscriptions; the node deserialises with
  ``rclpy.serialization.deserialize_message``, the do-nothing subscriber does not deserialise;
* ``-cdr``: raw subscriptions; the node reads only its joint from the CDR bytes
  (:func:`parse_joint_cdr`, the package's CDR decoding) into ``service.add_sample``;
* ``-batch``: as ``-cdr``, but the callback only queues the bytes and a 50 Hz timer of the node
  parses the queue (warm caches for a whole batch; results up to 20 ms later).

CPU time (user + system of all threads, /proc/<pid>/stat) is sampled when publishing starts and
when the subscribers are idle again after the last message; CPU % = CPU s / publishing s
(100 % = one core).  The subscribers print their message counts when stopped with SIGINT;
lost = sent - received.

Before the runs, child processes check that the EventsExecutor works with this rclpy
(subscriptions, timers incl. sim time, services, coroutines, parameter services, guard
conditions, idle CPU and return of the blocking spin calls).  After them ``--profile N`` feeds
N messages to the node callback in-process (no graph) and prints the cost of each stage, the
cost of a call with cold caches, and a cProfile of the callback.

``--role pub|node|shell|nothing|check`` are the child processes (internal).
"""

import argparse
import cProfile
import gc
import io
import json
import math
import os
from pathlib import Path
import pstats
import queue
import resource
import signal
import subprocess
import sys
import tempfile
import threading
import time

from robot_wear_monitor.recordings.bags import BagError, decode_joint_state

TOPIC = '/joint_states'
JOINTS = tuple(f'joint_{i}' for i in range(1, 7))
PASS_S = 0.5                 # duration of one constant-speed pass [s]
SIM_EPOCH_S = 1000.0         # simulated time of the first sample [s]
SETTLE_S = 0.5               # wait after matching before publishing [s]
#: The stream's last seconds: joint_2 stands still (a robot stops; its joint_state_broadcaster
#: goes on), so the move in progress ends in the stream, not at its cut [s].
STOP_S = 0.5
TICK_S = 1.0 / os.sysconf('SC_CLK_TCK')
VARIANTS = ('single', 'single-callback', 'events', 'events-callback', 'single-raw',
            'events-raw', 'single-cdr', 'events-cdr', 'single-batch', 'events-batch')
DEFAULT_VARIANTS = ('single', 'single-callback')
#: The target of issue 46: the default node at most this much of the do-nothing subscriber's CPU.
TARGET_RATIO = 0.5
BATCH_PERIOD_S = 0.02        # -batch variants: the node parses its queued messages at 50 Hz
#: Subscriber processes of a run: the node, its shell (callback = counter), the do-nothing one.
ROLES = ('node', 'shell', 'nothing')
#: ``--stall``: (messages received before the stall, seconds the executor is held).
STALL = {'after': 0, 's': 0.0, 'done': False}


def _maybe_stall(count):
    """Hold the executor once for ``STALL['s']`` after ``STALL['after']`` messages."""
    if STALL['s'] > 0 and not STALL['done'] and count >= STALL['after']:
        STALL['done'] = True
        time.sleep(STALL['s'])


# --------------------------------------------------------------------------- the stream

def _node_default(name):
    from robot_wear_monitor.monitoring.node_config import FRICTION_EXPERIMENT_PARAMETERS as specs
    return next(spec.default for spec in specs if spec.name == name)


def joint_state_samples(rate, duration, seed=0):
    """
    Return (stamps [s], positions, velocities, efforts) of the stream, arrays (n, 6).

    joint_2 (the node's default joint) does forward/backward passes of ``PASS_S`` at each of the
    node's default experiment speeds in turn (motor side, divided by the default gear ratio)
    and stands still for the last ``STOP_S``; the other joints stand still with sensor noise.
    """
    import numpy as np

    gear = float(_node_default('gear_ratio'))
    scale = float(_node_default('torque_scale'))
    # the node finds the speeds in the data (experiment_speeds_rad_s defaults to []): the
    # stream uses the planned speeds of the runner (Table V)
    from robot_wear_monitor.monitoring.node_config import DEFAULT_EXPERIMENT_SPEEDS_RAD_S
    motor_speeds = np.asarray(_node_default('experiment_speeds_rad_s')
                              or DEFAULT_EXPERIMENT_SPEEDS_RAD_S, dtype=float)
    rng = np.random.default_rng(seed)
    n = int(round(rate * duration))
    dt = 1.0 / rate
    t = np.arange(n) * dt
    pass_index = (t // PASS_S).astype(int)
    motor = motor_speeds[(pass_index // 2) % motor_speeds.size]
    direction = np.where(pass_index % 2 == 0, 1.0, -1.0)
    moving = t < n * dt - STOP_S
    velocity_2 = np.where(moving, direction * motor / gear, 0.0)
    position_2 = 0.3 + np.concatenate(([0.0], np.cumsum(velocity_2[:-1]) * dt))
    friction = np.where(moving, direction * (0.05 + 4e-4 * motor), 0.0)
    effort_2 = scale * (friction + 0.4 * np.sin(position_2 + 0.5))
    position = np.tile(np.linspace(-0.5, 0.5, 6), (n, 1)) + rng.normal(0.0, 1e-5, (n, 6))
    velocity = rng.normal(0.0, 1e-4, (n, 6))
    effort = rng.normal(0.0, 0.02 * scale, (n, 6))
    position[:, 1] = position_2
    velocity[:, 1] = velocity_2 * (1.0 + rng.normal(0.0, 2e-3, n))
    effort[:, 1] += effort_2
    return SIM_EPOCH_S + t, position, velocity, effort


def joint_state_messages(rate, duration):
    """Return the stream as a list of sensor_msgs/JointState messages."""
    from sensor_msgs.msg import JointState

    stamps, position, velocity, effort = joint_state_samples(rate, duration)
    messages = []
    for i, stamp in enumerate(stamps):
        msg = JointState()
        sec = int(math.floor(stamp))
        msg.header.stamp.sec = sec
        msg.header.stamp.nanosec = int(round((stamp - sec) * 1e9)) % 1000000000
        msg.name = list(JOINTS)
        msg.position = position[i].tolist()
        msg.velocity = velocity[i].tolist()
        msg.effort = effort[i].tolist()
        messages.append(msg)
    return messages


def replay_expectation(rate, duration, folder):
    """
    Return what the replay makes of the stream: the friction levels and estimates.

    The publisher's exact CDR payloads are written to a bag in ``folder`` and replayed by the
    package's :func:`~robot_wear_monitor.monitoring.replay.replay_bag` (default parameters of
    both nodes, like the bench's nodes, and an in-memory history).  The replay closes the
    experiment in progress at the end of the bag (``finish``); the live node closes it once
    /joint_states has been silent for ``idle_gap_s`` (3 s).  ``by_stream``: how many of them
    the stream itself completes (the payloads fed in drained batches to
    :class:`~robot_wear_monitor.monitoring.joint_state_batches.JointStateBatches`, what the
    node runs).  Returns a dict: ``levels`` [(end stamp [s], speeds [rad/s], frictions)],
    ``wear`` [w-hat], ``temperature`` [T-hat, degC] per experiment, and ``by_stream``.
    """
    import numpy as np
    from rclpy.serialization import serialize_message
    from robot_wear_monitor.monitoring.joint_state_batches import JointStateBatches
    from robot_wear_monitor.monitoring.joints import JointExperiments
    from robot_wear_monitor.monitoring.monitor_config import MonitorConfig
    from robot_wear_monitor.monitoring.replay import replay_bag
    from robot_wear_monitor.recordings.bags.writer import atomic_bag_writer

    messages = joint_state_messages(rate, duration)
    payloads = [serialize_message(msg) for msg in messages]
    stamps_ns = [msg.header.stamp.sec * 1_000_000_000 + msg.header.stamp.nanosec
                 for msg in messages]
    bag = Path(folder) / f'stream_{int(rate)}Hz'
    with atomic_bag_writer(bag, overwrite=True) as writer:
        writer.add_topic(TOPIC, 'sensor_msgs/msg/JointState')
        writer.write_raw_many(TOPIC, payloads, stamps_ns)
    configuration = MonitorConfig.load()
    result = replay_bag(bag, out_bag=None, configuration=configuration)
    batches = JointStateBatches(JointExperiments(configuration.experiment, source='bench'))
    step = max(1, int(round(rate * _node_default('drain_period_s'))))
    live_ends = set()
    for start in range(0, len(payloads), step):
        chunk = payloads[start:start + step]
        live_ends.update(experiment.end_time_s for _, experiment
                         in batches.add(chunk, np.zeros(len(chunk), dtype=np.int64)))
    updates = result.updates
    return {'levels': [(u.stamp_s, list(u.speeds_rad_s), list(u.frictions)) for u in updates],
            'wear': [u.wear for u in updates],
            'temperature': [u.temperature_degc for u in updates],
            'by_stream': sum(u.stamp_s in live_ends for u in updates)}


# --------------------------------------------------------------------------- child roles

def _qos():
    from robot_wear_monitor.nodes.qos import JOINT_STATES_QOS
    return JOINT_STATES_QOS


def _emit(line):
    sys.stdout.write(line + '\n')
    sys.stdout.flush()


def role_publisher(args):
    """Publish the stream once ``--subs`` subscribers are matched; report START/END/ACKED."""
    import rclpy
    from rclpy.duration import Duration
    from rclpy.event_handler import PublisherEventCallbacks
    from rclpy.executors import ExternalShutdownException
    from rclpy.serialization import serialize_message
    from sensor_msgs.msg import JointState

    rclpy.init()
    node = rclpy.create_node('bench_joint_state_publisher')
    matched = [0]

    def on_matched(status):
        matched[0] = status.current_count

    publisher = node.create_publisher(JointState, TOPIC, _qos(),
                                      event_callbacks=PublisherEventCallbacks(matched=on_matched))
    payloads = [serialize_message(msg)
                for msg in joint_state_messages(args.rate, args.duration)]
    deadline = time.monotonic() + 60.0
    while publisher.get_subscription_count() < args.subs or matched[0] < args.subs:
        rclpy.spin_once(node, timeout_sec=0.05)
        if time.monotonic() > deadline:
            _emit(f'ERROR only {publisher.get_subscription_count()} subscribers '
                  f'({matched[0]} matched) after 60 s')
            return 3
    time.sleep(SETTLE_S)
    _emit('START')
    period = 1.0 / args.rate
    start = time.perf_counter()
    late = 0
    for i, payload in enumerate(payloads):
        delay = start + i * period - time.perf_counter()
        if delay > 0:
            time.sleep(delay)
        elif delay < -period:
            late += 1
        publisher.publish(payload)
    elapsed = time.perf_counter() - start
    _emit(f'END {len(payloads)} {elapsed:.6f} {late}')
    acked = publisher.wait_for_all_acked(Duration(seconds=10))
    _emit(f'ACKED {acked}')
    try:
        while rclpy.ok():
            rclpy.spin_once(node, timeout_sec=0.2)
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    node.destroy_node()
    rclpy.try_shutdown()
    return 0


def parse_joint_cdr(buffer, joint):
    """
    Return (stamp [s], position, velocity, effort) of ``joint`` from a serialized JointState.

    The fast path of the ``-cdr`` variants: the package's CDR decoding
    (:func:`robot_wear_monitor.recordings.bags.decode_joint_state`, the replay's decoder) on the
    bytes of a raw subscription, instead of building the whole Python message.  Returns None
    when the message cannot be used (malformed, joint missing, an array whose length differs
    from ``name``).
    """
    try:
        stamp, _, names, position, velocity, effort = decode_joint_state(buffer)
    except BagError:
        return None
    if joint not in names or not len(position) == len(velocity) == len(effort) == len(names):
        return None
    index = names.index(joint)
    return stamp, float(position[index]), float(velocity[index]), float(effort[index])


def _make_executor(name):
    if name == 'events':
        from rclpy.experimental import EventsExecutor
        return EventsExecutor()
    from rclpy.executors import SingleThreadedExecutor
    return SingleThreadedExecutor()


def _counting_node(raw, work=True, cdr=False, batch=False, drained=True, depth=None):
    """
    Return the package's FrictionExperimentNode with a message counter (raw: bytes in).

    ``drained``: the node's default intake (``drain_period_s`` 0.05 s: batches drained by a
    timer); otherwise one callback per message (``drain_period_s: 0.0``), which the other
    options build on.

    ``work=False`` gives the shell: the same node, entities and imports, but the callback only
    counts (the node's cost that is not its callback's work).  ``cdr``: raw subscription read
    by :func:`parse_joint_cdr` into ``service.add_sample`` (the shell then does not parse).
    ``batch``: like ``cdr``, but the callback only queues the bytes and a timer parses the
    queue every ``BATCH_PERIOD_S`` (the shell only counts).
    """
    from rclpy.parameter import Parameter
    from rclpy.serialization import deserialize_message
    from robot_wear_monitor.nodes.friction_experiment_node import FrictionExperimentNode
    from sensor_msgs.msg import JointState

    class CountingNode(FrictionExperimentNode):
        """The node under test; ``count`` = messages its callback processed."""

        count = 0
        timer_calls = 0
        wakes = 0
        max_wake_gap_s = 0.0
        max_wake_messages = 0
        _last_wake = None

        def on_joint_state(self, msg):
            """Count, then run the node's own callback."""
            self.count += 1
            _maybe_stall(self.count)
            super().on_joint_state(msg)

        def drain_joint_states(self):
            """Time the wakes that took messages (longest gap, most messages), then drain."""
            before = self.count
            now = time.monotonic()
            super().drain_joint_states()
            if self.count > before:
                if self._last_wake is not None:
                    self.max_wake_gap_s = max(self.max_wake_gap_s, now - self._last_wake)
                self._last_wake = now
                self.wakes += 1
                self.max_wake_messages = max(self.max_wake_messages, self.count - before)

        def on_joint_states(self, raws, receive_ns):
            """Count a drained batch, then segment it as the node does."""
            self.count += len(raws)
            _maybe_stall(self.count)
            super().on_joint_states(raws, receive_ns)

        def publish_diagnostics(self):
            """Count the node's periodic timer callbacks, then run it."""
            self.timer_calls += 1
            getattr(super(), 'publish_diagnostics', lambda: None)()

        def on_raw(self, data):
            """Deserialise a raw message and process it like the typed subscription."""
            self.on_joint_state(deserialize_message(data, JointState))

        def on_cdr(self, data):
            """Read the joint from the CDR bytes and feed the sample (the CDR fast path)."""
            self.count += 1
            sample = parse_joint_cdr(data, self.joint_cdr)
            if sample is None:
                self.service.rejections['cdr_unusable'] += 1
                return
            for experiment in self.service.add_sample(
                    time_s=sample[0], position_rad=sample[1], velocity_rad_s=sample[2],
                    effort=sample[3]):
                self.publisher.publish(self.service.friction_levels_message(self.kit,
                                                                            experiment))

        def on_queue(self, data):
            """Queue the raw message for the batch timer."""
            self.queue.append(data)

        def on_batch(self):
            """Parse and feed the queued messages (the batch timer)."""
            pending, self.queue = self.queue, []
            for data in pending:
                self.on_cdr(data)

        def result(self):
            """Return the figures printed at exit."""
            self.on_batch()
            self.drain_joint_states()
            rejections = self.service.all_rejections()
            return {'count': self.count, 'levels': len(self.service.levels),
                    'experiments': getattr(self.service, 'experiments', None),
                    'timer_calls': self.timer_calls, 'wakes': self.wakes,
                    'max_wake_gap_s': round(self.max_wake_gap_s, 4),
                    'max_wake_messages': self.max_wake_messages,
                    'depth': self.joint_states_qos.depth,
                    'rejections': {k: v for k, v in rejections.items() if v}}

    class ShellNode(CountingNode):
        """The node with its callback replaced by the counter."""

        def on_joint_state(self, msg):
            """Count only."""
            self.count += 1
            _maybe_stall(self.count)

        def on_joint_states(self, raws, receive_ns):
            """Count the drained batch only."""
            self.count += len(raws)
            _maybe_stall(self.count)

        def on_cdr(self, data):
            """Count only."""
            self.count += 1

        def on_queue(self, data):
            """Count only."""
            self.count += 1

    overrides = [] if drained and not raw else [Parameter('drain_period_s', value=0.0)]
    if depth is not None:
        overrides.append(Parameter('joint_states_depth', value=depth))
    node = (CountingNode if work else ShellNode)(parameter_overrides=overrides)
    node.joint_cdr = node.service.joint
    node.queue = []
    if raw:
        callback = node.on_queue if batch else node.on_cdr if cdr else node.on_raw
        node.destroy_subscription(node.subscription)
        node.subscription = node.create_subscription(JointState, 'joint_states', callback,
                                                     _qos(), raw=True)
    if batch:
        node.batch_timer = node.create_timer(BATCH_PERIOD_S, node.on_batch)
    return node


def _do_nothing_node(raw):
    """Return an rclpy node whose /joint_states callback only counts."""
    from rclpy.node import Node
    from sensor_msgs.msg import JointState

    class DoNothing(Node):
        """The floor: same topic and QoS, the callback only counts."""

        count = 0

        def __init__(self):
            """Subscribe (typed or raw)."""
            super().__init__('bench_do_nothing')
            self.subscription = self.create_subscription(JointState, TOPIC, self.on_message,
                                                         _qos(), raw=raw)

        def on_message(self, msg):
            """Count."""
            self.count += 1
            _maybe_stall(self.count)

        def result(self):
            """Return the figures printed at exit."""
            return {'count': self.count}

    return DoNothing()


def role_estimator(args):
    """
    Spin the package's WearEstimatorNode and a probe of its outputs until SIGINT.

    The estimator has its default parameters but ``history_file: ':memory:'`` (the replay's
    history: a fresh trend, not the user's).  The probe subscribes to ``friction_levels``
    (the friction node's), ``wear`` and ``temperature`` (the estimator's) with the nodes' QoS;
    READY comes once it is matched with the three publishers; a ``WEAR`` line is printed per
    wear received, RESULT (JSON, floats exact) at exit.
    """
    import rclpy
    from rclpy.executors import ExternalShutdownException, SingleThreadedExecutor
    from rclpy.parameter import Parameter
    from robot_wear_monitor.nodes.qos import ESTIMATE_QOS, FRICTION_LEVELS_QOS
    from robot_wear_monitor.nodes.wear_estimator_node import WearEstimatorNode
    from robot_wear_monitor.recordings.messages import stamp_to_seconds
    from sensor_msgs.msg import JointState, Temperature
    from std_msgs.msg import Float64

    rclpy.init()
    estimator = WearEstimatorNode(parameter_overrides=[Parameter('history_file',
                                                                 value=':memory:')])
    probe = rclpy.create_node('bench_estimator_probe')
    seen = {'levels': [], 'wear': [], 'temperature': []}

    def on_levels(msg):
        seen['levels'].append([stamp_to_seconds(msg.header.stamp), list(msg.velocity),
                               list(msg.effort)])

    def on_wear(msg):
        seen['wear'].append(msg.data)
        _emit(f'WEAR {len(seen["wear"])}')

    subscriptions = [
        probe.create_subscription(JointState, 'friction_levels', on_levels,
                                  FRICTION_LEVELS_QOS),
        probe.create_subscription(Float64, 'wear', on_wear, ESTIMATE_QOS),
        probe.create_subscription(Temperature, 'temperature',
                                  lambda m: seen['temperature'].append(m.temperature),
                                  ESTIMATE_QOS)]
    executor = SingleThreadedExecutor()
    executor.add_node(estimator)
    executor.add_node(probe)
    deadline = time.monotonic() + 60.0
    while not all(s.get_publisher_count() for s in subscriptions[1:]):
        executor.spin_once(timeout_sec=0.05)
        if time.monotonic() > deadline:
            _emit("ERROR the probe did not match the estimator's wear and temperature")
            return 3
    _emit('READY')
    try:
        while rclpy.ok():
            executor.spin_once(timeout_sec=3600.0)
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    _emit('RESULT ' + json.dumps(seen))
    executor.shutdown()
    probe.destroy_node()
    estimator.destroy_node()
    rclpy.try_shutdown()
    return 0


def role_subscriber(args):
    """Spin the node or the do-nothing subscriber until SIGINT; print RESULT as JSON."""
    import rclpy
    from rclpy.executors import ExternalShutdownException

    rclpy.init()
    STALL.update(after=args.stall_after, s=args.stall)
    batch = args.variant.endswith('-batch')
    cdr = batch or args.variant.endswith('-cdr')
    raw = cdr or args.variant.endswith('-raw')
    if args.role == 'nothing':
        node = _do_nothing_node(raw)
    else:
        node = _counting_node(raw, work=args.role == 'node', cdr=cdr, batch=batch,
                              drained='-' not in args.variant, depth=args.depth)
    executor = _make_executor(args.variant.split('-')[0])
    executor.add_node(node)
    _emit('READY')
    try:
        # Not executor.spin(): the EventsExecutor of rclpy 7.1.6 busy-polls in spin() and in
        # spin_once() without a timeout (see the check); a long finite timeout blocks.
        while rclpy.ok():
            executor.spin_once(timeout_sec=3600.0)
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    result = node.result()
    result['process_time_s'] = time.process_time()
    result['max_rss_kib'] = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    result['gc_collections'] = [generation['collections'] for generation in gc.get_stats()]
    result['gc_objects'] = len(gc.get_objects())
    _emit('RESULT ' + json.dumps(result))
    executor.shutdown()
    node.destroy_node()
    rclpy.try_shutdown()
    return 0


def _check(name, ok, detail=''):
    _emit(f'CHECK {name:<26} {"ok  " if ok else "FAIL"} {detail}')


def _spin_for(executor, seconds):
    end = time.monotonic() + seconds
    while time.monotonic() < end:
        executor.spin_once(timeout_sec=0.05)


def _check_basics(executor, node, client_node):
    """Check timers, a subscription, a service, a coroutine and the parameter services."""
    from rcl_interfaces.srv import GetParameters
    from std_msgs.msg import Float64
    from std_srvs.srv import Trigger

    node.declare_parameter('answer', 42)
    ticks, once, got = [], [], []
    timer = node.create_timer(0.01, lambda: ticks.append(time.monotonic()))

    def one_shot():
        once.append(1)
        one_shot_timer.cancel()

    one_shot_timer = node.create_timer(0.02, one_shot)
    node.create_subscription(Float64, 'bench_check', lambda m: got.append(m.data), 50)
    publisher = client_node.create_publisher(Float64, 'bench_check', 50)

    def on_trigger(request, response):
        response.success, response.message = True, 'pong'
        return response

    node.create_service(Trigger, 'bench_trigger', on_trigger)
    client = client_node.create_client(Trigger, 'bench_trigger')
    _spin_for(executor, 1.0)
    periods = [b - a for a, b in zip(ticks, ticks[1:])]
    mean_ms = 1e3 * sum(periods) / len(periods) if periods else float('nan')
    _check('timer', 90 <= len(ticks) <= 110 and abs(mean_ms - 10.0) < 1.0,
           f'{len(ticks)} ticks of a 10 ms timer in 1 s, mean period {mean_ms:.2f} ms')
    _check('timer_cancel_in_callback', len(once) == 1, f'one-shot fired {len(once)} time(s)')
    timer.cancel()
    before = len(ticks)
    _spin_for(executor, 0.1)
    _check('timer_cancel', len(ticks) == before, f'{len(ticks) - before} ticks after cancel')
    timer.reset()
    _spin_for(executor, 0.1)
    _check('timer_reset', len(ticks) > before, f'{len(ticks) - before} ticks in 0.1 s after reset')
    node.destroy_timer(timer)

    for i in range(20):
        publisher.publish(Float64(data=float(i)))
    _spin_for(executor, 0.3)
    _check('subscription', got == [float(i) for i in range(20)], f'{len(got)}/20 in order')

    _check('service_discovery', client.wait_for_service(timeout_sec=5.0))
    future = client.call_async(Trigger.Request())
    executor.spin_until_future_complete(future, timeout_sec=5.0)
    response = future.result() if future.done() else None
    _check('service_call', response is not None and response.message == 'pong',
           f'response {response}')

    awaited = []

    async def coroutine():
        awaited.append((await client.call_async(Trigger.Request())).message)

    task = executor.create_task(coroutine)
    executor.spin_until_future_complete(task, timeout_sec=5.0)
    _check('coroutine_awaits_service', awaited == ['pong'], f'{awaited}')

    parameters = client_node.create_client(GetParameters, f'/{node.get_name()}/get_parameters')
    parameters.wait_for_service(timeout_sec=5.0)
    future = parameters.call_async(GetParameters.Request(names=['answer']))
    executor.spin_until_future_complete(future, timeout_sec=5.0)
    values = future.result().values if future.done() else []
    _check('parameter_service', len(values) == 1 and values[0].integer_value == 42,
           f'{[v.integer_value for v in values]}')


def _check_sim_time(executor_factory):
    """Check a timer on ROS time driven by /clock (use_sim_time), as in a replay."""
    import rclpy
    from rclpy.parameter import Parameter
    from rosgraph_msgs.msg import Clock

    executor = executor_factory()
    node = rclpy.create_node('bench_check_sim_time', parameter_overrides=[
        Parameter('use_sim_time', Parameter.Type.BOOL, True)])
    clock_node = rclpy.create_node('bench_check_clock')
    publisher = clock_node.create_publisher(Clock, '/clock', 10)
    executor.add_node(node)
    executor.add_node(clock_node)
    ticks = []
    node.create_timer(0.1, lambda: ticks.append(node.get_clock().now().nanoseconds))
    _spin_for(executor, 0.5)
    for step in range(1, 101):  # 1 s of simulated time in 0.5 s of wall time
        publisher.publish(Clock(clock=rclpy.time.Time(nanoseconds=step * 10_000_000).to_msg()))
        _spin_for(executor, 0.005)
    _spin_for(executor, 0.2)
    _check('timer_on_sim_time', 8 <= len(ticks) <= 11,
           f'{len(ticks)} ticks of a 0.1 s timer over 1 s of /clock time')
    executor.shutdown()
    node.destroy_node()
    clock_node.destroy_node()


def _check_guard_condition(executor_factory):
    import rclpy

    executor = executor_factory()
    node = rclpy.create_node('bench_check_guard')
    hits = []
    guard = node.create_guard_condition(lambda: hits.append(1))
    executor.add_node(node)
    guard.trigger()
    try:
        _spin_for(executor, 0.1)
        _check('guard_condition', len(hits) == 1, f'{len(hits)} call(s)')
    except RuntimeError as error:
        _check('guard_condition', False, f'spin_once raised RuntimeError: {error}')
    executor.shutdown()
    node.destroy_node()


def _check_action(executor_factory):
    """Check an action server and client (waitables) on one executor."""
    import rclpy
    from rclpy.action import ActionClient, ActionServer
    from rclpy.action.server import ServerGoalHandle

    try:
        from example_interfaces.action import Fibonacci as Action
    except ImportError:
        try:
            from action_tutorials_interfaces.action import Fibonacci as Action
        except ImportError:
            _emit(f'CHECK {"action":<26} skip no action type installed')
            return

    executor = executor_factory()
    node = rclpy.create_node('bench_check_action')
    executor.add_node(node)

    def execute(goal: ServerGoalHandle):
        goal.succeed()
        result = Action.Result()
        result.sequence = [0, 1, 1]
        return result

    ActionServer(node, Action, 'bench_fibonacci', execute)
    client = ActionClient(node, Action, 'bench_fibonacci')
    try:
        client.wait_for_server(timeout_sec=5.0)
        future = client.send_goal_async(Action.Goal(order=3))
        executor.spin_until_future_complete(future, timeout_sec=5.0)
        result = future.result().get_result_async()
        executor.spin_until_future_complete(result, timeout_sec=5.0)
        _check('action', result.done(), f'{list(result.result().result.sequence)}')
    except Exception as error:  # noqa: B902 - report whatever the executor raises
        _check('action', False, f'{type(error).__name__}: {error}')
    executor.shutdown()
    node.destroy_node()


def _check_features(executor_name):
    """Run the feature checks on the executor (each blocking call with a finite timeout)."""
    import rclpy

    rclpy.init()
    executor = _make_executor(executor_name)
    node = rclpy.create_node('bench_check')
    client_node = rclpy.create_node('bench_check_client')
    executor.add_node(node)
    executor.add_node(client_node)

    def factory():
        return _make_executor(executor_name)

    for label, function in (
            ('basics', lambda: _check_basics(executor, node, client_node)),
            ('sim time', lambda: _check_sim_time(factory)),
            ('guard condition', lambda: _check_guard_condition(factory)),
            ('action', lambda: _check_action(factory))):
        try:
            function()
        except Exception as error:  # noqa: B902 - report and go on with the next check
            _check(label, False, f'raised {type(error).__name__}: {error}')
    start, cpu = time.monotonic(), time.process_time()
    executor.spin_once(timeout_sec=0.5)
    _check('idle_spin_once_timeout', time.process_time() - cpu < 0.05,
           f'spin_once(timeout_sec=0.5) used {100 * (time.process_time() - cpu):.0f} % CPU '
           f'over {time.monotonic() - start:.2f} s')
    executor.shutdown()
    rclpy.try_shutdown()
    return 0


def _check_blocking_call(executor_name, call):
    """
    Run one blocking call without timeout; print TICK/RETURNED (the parent times it).

    ``spin``: executor.spin() with a 0.1 s timer, rclpy.shutdown() from a thread after 1 s;
    ``spin_once``: spin_once() with a 0.5 s timer pending; ``future``:
    spin_until_future_complete(future) with a 0.5 s timer completing the future.
    """
    import rclpy
    from rclpy.executors import ExternalShutdownException
    from rclpy.task import Future

    rclpy.init()
    executor = _make_executor(executor_name)
    node = rclpy.create_node('bench_check_blocking')
    executor.add_node(node)
    future = Future()

    def tick():
        _emit('TICK')
        if call != 'spin':
            timer.cancel()
            future.set_result(True)

    timer = node.create_timer(0.1 if call == 'spin' else 0.5, tick)
    if call == 'spin':
        threading.Timer(1.0, rclpy.shutdown).start()
    _emit('CALLING')
    try:
        if call == 'spin':
            executor.spin()
        elif call == 'spin_once':
            executor.spin_once()
        else:
            executor.spin_until_future_complete(future)
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    _emit('RETURNED')
    return 0


def role_check(args):
    """Child of the executor check: ``--check features|spin|spin_once|future``."""
    if args.check == 'features':
        return _check_features(args.variant)
    return _check_blocking_call(args.variant, args.check)


# --------------------------------------------------------------------------- orchestration

class Child:
    """A child process of this script; its stdout lines arrive in a queue."""

    def __init__(self, label, role_args, env, log_dir):
        """Start ``python3 bench_graph.py --role ...``; stderr goes to a log file."""
        self.label = label
        self.stderr_path = Path(log_dir) / f'{label}.stderr'
        self._stderr = open(self.stderr_path, 'w')
        self.proc = subprocess.Popen([sys.executable, str(Path(__file__).resolve())]
                                     + role_args, stdout=subprocess.PIPE,
                                     stderr=self._stderr, env=env, text=True)
        self.lines = queue.Queue()
        threading.Thread(target=self._read, daemon=True).start()

    def _read(self):
        for line in self.proc.stdout:
            self.lines.put(line.rstrip('\n'))
        self.lines.put(None)

    def expect(self, prefix, timeout):
        """Return the first stdout line starting with ``prefix`` (RuntimeError otherwise)."""
        deadline = time.monotonic() + timeout
        while True:
            try:
                line = self.lines.get(timeout=max(deadline - time.monotonic(), 0.01))
            except queue.Empty:
                raise RuntimeError(f'{self.label}: no {prefix!r} within {timeout} s;'
                                   f'{self.stderr_tail()}') from None
            if line is None:
                raise RuntimeError(f'{self.label}: exited ({self.proc.poll()}) before '
                                   f'{prefix!r};{self.stderr_tail()}')
            if line.startswith(prefix):
                return line[len(prefix):].strip()
            if line.startswith('ERROR'):
                raise RuntimeError(f'{self.label}: {line}')

    def stderr_tail(self, lines=8):
        """Return the last lines of the child's stderr, indented."""
        if not self._stderr.closed:
            self._stderr.flush()
        text = self.stderr_path.read_text(errors='replace').splitlines()[-lines:]
        return ''.join(f'\n    {line}' for line in text)

    def cpu_s(self):
        """Return user + system CPU seconds of all the child's threads so far."""
        try:
            with open(f'/proc/{self.proc.pid}/stat') as stat:
                fields = stat.read().rsplit(')', 1)[1].split()
        except OSError:
            raise RuntimeError(f'{self.label}: exited ({self.proc.poll()});'
                               f'{self.stderr_tail()}') from None
        return (int(fields[11]) + int(fields[12])) * TICK_S

    def stop(self, timeout=10.0):
        """SIGINT, wait (kill after ``timeout``); return True when it exited by itself."""
        if self.proc.poll() is None:
            self.proc.send_signal(signal.SIGINT)
        try:
            self.proc.wait(timeout)
            clean = True
        except subprocess.TimeoutExpired:
            self.proc.kill()
            self.proc.wait()
            clean = False
        self._stderr.close()
        return clean


def _child_env(domain, log_dir):
    env = dict(os.environ)
    env.pop('ROS_LOCALHOST_ONLY', None)
    env.update(ROS_DOMAIN_ID=str(domain), ROS_AUTOMATIC_DISCOVERY_RANGE='LOCALHOST',
               ROS_LOG_DIR=str(log_dir), PYTHONUNBUFFERED='1')
    return env


def _wait_idle(children, quiet_s=0.3, timeout=15.0):
    """Wait until no child has used CPU for ``quiet_s`` (the last messages are processed)."""
    last = [c.cpu_s() for c in children]
    quiet_since = time.monotonic()
    deadline = quiet_since + timeout
    while time.monotonic() < deadline:
        time.sleep(0.05)
        now = [c.cpu_s() for c in children]
        if now != last:
            last, quiet_since = now, time.monotonic()
        elif time.monotonic() - quiet_since >= quiet_s:
            return True
    return False


def _pin(pid, cpus):
    """Restrict every thread of ``pid`` to ``cpus`` (threads started later inherit it)."""
    for task in Path(f'/proc/{pid}/task').iterdir():
        os.sched_setaffinity(int(task.name), cpus)


def _load_average():
    return float(Path('/proc/loadavg').read_text().split()[0])


def run_variant(rate, variant, duration, domain, log_dir, roles=ROLES, pin=False,
                expected=None, extra=()):
    """
    Run the publisher and one subscriber process per role once; return the figures.

    ``pin``: the subscribers share the last CPU, the publisher gets the others (the same
    conditions for every subscriber instead of the scheduler's placement).  ``expected``
    (:func:`replay_expectation`): also run the estimator and its probe (a process of its
    own, not pinned) and wait, after the stream and the CPU figures, until it has every
    expected wear (at most 15 s); its outputs are the run's ``estimator``.  ``extra``: more
    arguments of the subscriber processes (``--stall``, ``--depth``).
    """
    env = _child_env(domain, log_dir)
    tag = f'{int(rate)}Hz_{variant}'
    subs = {role: Child(f'{tag}_{role}', ['--role', role, '--variant', variant, *extra], env,
                        log_dir)
            for role in roles}
    children = list(subs.values())
    estimator = None
    if expected is not None:
        estimator = Child(f'{tag}_estimator', ['--role', 'estimator'], env, log_dir)
    cpus = sorted(os.sched_getaffinity(0))
    publisher = None
    estimates = None
    try:
        for child in children:
            child.expect('READY', 60)
            if pin and len(cpus) > 1:
                _pin(child.proc.pid, cpus[-1:])
        if estimator is not None:
            estimator.expect('READY', 60)
            estimator_cpu0 = estimator.cpu_s()
        publisher = Child(f'{tag}_pub', ['--role', 'pub', '--rate', str(rate), '--duration',
                                         str(duration), '--subs', str(len(roles))],
                          env, log_dir)
        if pin and len(cpus) > 1:
            _pin(publisher.proc.pid, cpus[:-1])
        publisher.expect('START', 90)
        cpu0 = {c.label: c.cpu_s() for c in children + [publisher]}
        load0 = _load_average()
        sent, elapsed, late = publisher.expect('END', duration + 60).split()
        pub_cpu = publisher.cpu_s() - cpu0[publisher.label]
        load1 = _load_average()
        acked = publisher.expect('ACKED', 30) == 'True'
        idle = _wait_idle(children)
        cpu = {c.label: c.cpu_s() - cpu0[c.label] for c in children}
        if estimator is not None:  # the node closes the last experiment after idle_gap_s
            estimates = _estimator_outputs(estimator, len(expected['wear']), estimator_cpu0)
        results = {}
        for role, child in subs.items():
            clean = child.stop()
            results[role] = json.loads(child.expect('RESULT', 5))
            results[role]['cpu_s'] = cpu[child.label]
            results[role]['clean_exit'] = clean
    finally:
        for child in children + [c for c in (publisher, estimator) if c is not None]:
            if child.proc.poll() is None:
                child.stop()
    wall = float(elapsed)
    return {'rate': rate, 'variant': variant, 'sent': int(sent), 'wall_s': wall,
            'late': int(late), 'acked': acked, 'drained': idle, 'pub_cpu_share': pub_cpu / wall,
            'load': (load0, load1), 'results': results, 'estimator': estimates,
            'expected': expected}


def _estimator_outputs(estimator, n_expected, cpu0, timeout=15.0):
    """Wait for ``n_expected`` WEAR lines (at most ``timeout`` s), then 0.5 s; return RESULT."""
    received = 0
    deadline = time.monotonic() + timeout
    while received < n_expected and time.monotonic() < deadline:
        try:
            line = estimator.lines.get(timeout=0.05)
        except queue.Empty:
            continue
        if line is None:
            break
        if line.startswith('WEAR '):
            received = int(line.split()[1])
    time.sleep(0.5)  # the same update's other outputs (temperature) may come after its wear
    try:
        cpu_s = estimator.cpu_s() - cpu0
        clean = estimator.stop()
        outputs = json.loads(estimator.expect('RESULT', 5))
    except RuntimeError as error:
        return {'error': str(error)}
    outputs.update(cpu_s=cpu_s, clean_exit=clean)
    return outputs


def compare_with_replay(run):
    """
    Return the estimator's outputs of a run against the replay's (None without estimator).

    A dict: ``published`` (wear messages) and ``expected`` (experiments the stream completes),
    ``dw`` and ``dT`` (max |live - replay| of w-hat and T-hat [degC] over the pairs, in
    order; nan without pairs), ``levels_equal`` (every friction_levels the friction node
    published equals the replay's, stamp [s], speeds and frictions, float for float) and
    ``equal``: the same count and every w-hat, T-hat and level bit-equal.
    """
    live, replay = run.get('estimator'), run.get('expected')
    if live is None or replay is None:
        return None
    if 'error' in live:
        return {'error': live['error'], 'equal': False}
    pairs_w = list(zip(live['wear'], replay['wear']))
    pairs_t = list(zip(live['temperature'], replay['temperature']))

    def worst(pairs):
        return max((abs(a - b) for a, b in pairs), default=float('nan'))

    levels = [(stamp, list(speeds), list(frictions)) for stamp, speeds, frictions
              in live['levels']]
    levels_equal = [tuple(level) for level in levels] == [tuple(level) for level
                                                          in replay['levels']]
    equal = (len(live['wear']) == len(replay['wear']) == len(live['temperature'])
             and all(a == b for a, b in pairs_w + pairs_t) and levels_equal)
    return {'published': len(live['wear']), 'expected': len(replay['wear']),
            'levels': len(live['levels']),
            'dw': worst(pairs_w), 'dT': worst(pairs_t), 'levels_equal': levels_equal,
            'equal': equal, 'cpu_s': live.get('cpu_s'), 'clean_exit': live.get('clean_exit')}


def print_table(runs):
    """Print one block per run: a row per subscriber process, ratios to the do-nothing one."""
    print()
    print(f'{"rate":>6} {"variant":<15} {"process":<8} {"sent":>6} {"recv":>6} {"lost":>5} '
          f'{"CPU %":>6} {"us/msg":>7} {"/nothing":>8}  notes')
    for run in runs:
        results = run['results']
        floor = results['nothing']['cpu_s']
        for role, res in results.items():
            received = res['count']
            share = res['cpu_s'] / run['wall_s']
            per_msg = 1e6 * res['cpu_s'] / received if received else float('nan')
            notes = []
            if role == 'node':
                notes.append(f'levels {res["levels"]}, experiments {res["experiments"]}, '
                             f'{res["timer_calls"]} diagnostics timer calls')
                if res.get('wakes'):
                    notes.append(f'depth {res["depth"]}, {res["wakes"]} wakes took messages: '
                                 f'longest gap {1e3 * res["max_wake_gap_s"]:.0f} ms, most '
                                 f'{res["max_wake_messages"]} messages; max RSS '
                                 f'{res["max_rss_kib"] / 1024:.0f} MiB')
                if res['rejections']:
                    notes.append(f'rejected {res["rejections"]}')
            elif role == 'nothing':
                notes.append(f'publisher CPU {100 * run["pub_cpu_share"]:.0f} %, load average '
                             f'{run["load"][0]:.2f} -> {run["load"][1]:.2f}')
                if run['late']:
                    notes.append(f'{run["late"]} sent >1 period late')
            if not run['acked']:
                notes.append('NOT ALL ACKED')
            if not run['drained']:
                notes.append('not idle after 15 s')
            if not res['clean_exit']:
                notes.append('killed')
            ratio = f'{res["cpu_s"] / floor:8.2f}' if role != 'nothing' and floor > 0 \
                else ' ' * 8
            print(f'{run["rate"]:>6g} {run["variant"]:<15} {role:<8} {run["sent"]:>6} '
                  f'{received:>6} {run["sent"] - received:>5} {100 * share:>6.1f} '
                  f'{per_msg:>7.1f} {ratio}  {"; ".join(notes)}')


def estimator_line(estimates):
    """Return the line of :func:`compare_with_replay`'s figures."""
    if 'error' in estimates:
        return f'estimator: FAILED {estimates["error"]}'
    return (f'estimator: wear published {estimates["published"]}/{estimates["expected"]} '
            f'experiments of the replay, max |w_live - w_replay| {estimates["dw"]:.3g}, max '
            f'|T_live - T_replay| {estimates["dT"]:.3g} degC, friction_levels '
            f'{estimates["levels"]} {"= the replay" if estimates["levels_equal"] else "DIFFER"}'
            f': {"equal" if estimates["equal"] else "NOT EQUAL"}')


def print_summary(runs):
    """Print the targets: no loss at the top rate, node within 0.5 x the do-nothing floor."""
    print()
    top = max(run['rate'] for run in runs)
    for run in runs:
        results = run['results']
        node, nothing = results['node'], results['nothing']
        lost = run['sent'] - node['count']
        ratio = node['cpu_s'] / nothing['cpu_s'] if nothing['cpu_s'] > 0 else float('inf')
        verdict = []
        if run['rate'] == top:
            verdict.append(f'no loss {"met" if lost == 0 else "MISSED"} ({lost} lost)')
        verdict.append(f'node <= {TARGET_RATIO:g} x do-nothing (same executor) '
                       f'{"met" if ratio <= TARGET_RATIO else "MISSED"} ({ratio:.2f} x)')
        print(f'{run["rate"]:>6g} Hz {run["variant"]:<15} ' + ', '.join(verdict))
        estimates = compare_with_replay(run)
        if estimates is not None:
            print(f'{run["rate"]:>6g} Hz {run["variant"]:<15} {estimator_line(estimates)}')
            print(f'{run["rate"]:>6g} Hz {run["variant"]:<15} issue 46 in this one run '
                  f'(node <= {TARGET_RATIO:g} x do-nothing and every wear = the replay): '
                  f'{"met" if ratio <= TARGET_RATIO and estimates["equal"] else "MISSED"}')
    repeated = {}
    for run in runs:
        results = run['results']
        if results['nothing']['cpu_s'] > 0:
            repeated.setdefault((run['rate'], run['variant']), []).append(
                results['node']['cpu_s'] / results['nothing']['cpu_s'])
    for (rate, variant), ratios in repeated.items():
        if len(ratios) > 1:
            print(f'{rate:>6g} Hz {variant:<15} node / do-nothing over {len(ratios)} runs: mean '
                  f'{sum(ratios) / len(ratios):.2f} x, min {min(ratios):.2f}, '
                  f'max {max(ratios):.2f}')
    for rate in sorted({run['rate'] for run in runs}):
        at_rate = [run for run in runs if run['rate'] == rate]

        def share(run, role):
            return run['results'][role]['cpu_s'] / run['wall_s']

        floor = min(at_rate, key=lambda run: share(run, 'nothing'))
        best = min(at_rate, key=lambda run: share(run, 'node'))
        line = (f'{rate:g} Hz: lowest do-nothing floor {100 * share(floor, "nothing"):.1f} % '
                f'({floor["variant"]}); cheapest node {100 * share(best, "node"):.1f} % '
                f'({best["variant"]})')
        plain = [run for run in at_rate if run['variant'] == 'single']
        if plain:
            line += (f' = {share(best, "node") / share(plain[0], "nothing"):.2f} x the plain '
                     f'rclpy.spin do-nothing subscriber')
        print(line)


BLOCKING_CALLS = {
    'spin': ('spin() with a 0.1 s timer, rclpy.shutdown() after 1 s', 1.0),
    'spin_once': ('spin_once() with a 0.5 s timer pending', 0.5),
    'future': ('spin_until_future_complete(f), a 0.5 s timer completes f', 0.5),
}


def _run_blocking_check(executor, call, env, log_dir, limit=3.0):
    """Time one blocking call in a child; kill it after ``limit`` s; return one report line."""
    what, expected = BLOCKING_CALLS[call]
    child = Child(f'check_{executor}_{call}', ['--role', 'check', '--variant', executor,
                                               '--check', call], env, log_dir)
    try:
        child.expect('CALLING', 30)
    except RuntimeError as error:
        child.stop(2)
        return f'{call:<10} FAIL {error}'
    start, cpu = time.monotonic(), child.cpu_s()
    ticks, returned = 0, None
    while time.monotonic() - start < limit:
        try:
            line = child.lines.get(timeout=0.05)
        except queue.Empty:
            continue
        if line == 'TICK':
            ticks += 1
        elif line == 'RETURNED':
            returned = time.monotonic() - start
            break
        elif line is None:
            break
    share = (child.cpu_s() - cpu) / (time.monotonic() - start)
    child.stop(2)
    ok = returned is not None and returned < expected + 1.0 and ticks > 0 and share < 0.2
    outcome = (f'returned after {returned:.2f} s' if returned is not None
               else f'still blocked after {limit:.0f} s (killed)')
    return (f'{call:<10} {"ok  " if ok else "FAIL"} {what}: {outcome}, {ticks} timer '
            f'callback(s), {100 * share:.0f} % CPU meanwhile')


def executor_check(log_dir, executors=('events',)):
    """Check the executors' features and blocking calls in child processes; print the lines."""
    for executor in executors:
        name = 'rclpy.experimental.EventsExecutor' if executor == 'events' else \
            'SingleThreadedExecutor'
        print(f'executor check: {name} (in child processes)')
        env = _child_env(1 + (os.getpid() + 50) % 100, log_dir)
        child = Child(f'check_{executor}_features', ['--role', 'check', '--variant', executor,
                                                     '--check', 'features'], env, log_dir)
        try:
            child.proc.wait(60)
        except subprocess.TimeoutExpired:
            print('  features: did not finish within 60 s (killed)')
        child.stop(2)
        while True:
            try:
                line = child.lines.get(timeout=2)
            except queue.Empty:
                break
            if line is None:
                break
            if line.startswith('CHECK '):
                print('  ' + line[len('CHECK '):])
        if child.proc.returncode not in (0, None):
            print(f'  features: exit code {child.proc.returncode}{child.stderr_tail()}')
        for call in BLOCKING_CALLS:
            print('  ' + _run_blocking_check(executor, call, env, log_dir), flush=True)


# --------------------------------------------------------------------------- in-process profile

def _print_cold_costs(fresh_node, messages, payloads, n=1500):
    """Print the median cost of one call back to back, 1 ms apart and after a cache sweep."""
    from rclpy.serialization import deserialize_message
    from sensor_msgs.msg import JointState

    n = max(1, min(n, len(messages) // 3, len(payloads) // 3))
    sweep = bytearray(8 << 20)
    node = fresh_node()
    calls = (('on_joint_state', node.on_joint_state, messages),
             ('deserialize_message', lambda p: deserialize_message(p, JointState), payloads))
    print(f'\nmedian cost of one call [us] ({n} calls each; a 1 kHz subscriber sleeps between '
          f'messages and other processes evict its caches):')
    print(f'  {"":<22} {"back to back":>12} {"1 ms apart":>11} {"after 8 MB sweep":>17}')
    for label, function, items in calls:
        medians = []
        for index, mode in enumerate(('hot', 'sleep', 'sweep')):
            times = []
            for item in items[index * n:(index + 1) * n]:  # stamps keep increasing
                if mode == 'sleep':
                    time.sleep(0.001)
                elif mode == 'sweep':
                    sweep[::64] = bytes(len(sweep) // 64)
                start = time.perf_counter_ns()
                function(item)
                times.append(time.perf_counter_ns() - start)
            times.sort()
            medians.append(times[len(times) // 2] / 1e3)
        print(f'  {label:<22} {medians[0]:>12.1f} {medians[1]:>11.1f} {medians[2]:>17.1f}')
    node.destroy_node()


def profile_callback(n_messages, top):
    """Feed ``n_messages`` 1 kHz messages to the node callback in-process; print the costs."""
    import numpy as np
    import rclpy
    from rclpy.parameter import Parameter
    from rclpy.serialization import deserialize_message, serialize_message
    from robot_wear_monitor.experiment import segmentation
    from robot_wear_monitor.nodes.friction_experiment_node import FrictionExperimentNode
    from robot_wear_monitor.recordings.messages import stamp_to_seconds
    from sensor_msgs.msg import JointState
    rate = 1000.0
    messages = joint_state_messages(rate, n_messages / rate)
    payloads = [serialize_message(m) for m in messages]
    os.environ['ROS_AUTOMATIC_DISCOVERY_RANGE'] = 'LOCALHOST'
    rclpy.init(domain_id=1 + (os.getpid() + 70) % 100)
    stages = []

    def stage(label, function, items):
        start = time.perf_counter()
        for item in items:
            function(item)
        stages.append((label, 1e6 * (time.perf_counter() - start) / len(items)))

    def fresh_node(drained=False):
        node = FrictionExperimentNode(parameter_overrides=[] if drained else [
            Parameter('drain_period_s', value=0.0)])
        node.get_logger().set_level(rclpy.logging.LoggingSeverity.ERROR)
        node.destroy_subscription(node.subscription)
        if drained:
            node.destroy_timer(node.drain_timer)
        return node

    try:
        node = fresh_node(drained=True)
        batch = int(round(rate * 0.05))
        batches = [(payloads[i:i + batch], np.zeros(len(payloads[i:i + batch]), dtype=np.int64))
                   for i in range(0, len(payloads), batch)]
        start = time.perf_counter()
        for raws, receive_ns in batches:
            node.on_joint_states(raws, receive_ns)
        stages.append((f'FrictionExperimentNode.on_joint_states, {batch}-message drained batches '
                       f'(the default), per message',
                       1e6 * (time.perf_counter() - start) / len(payloads)))
        node.destroy_node()
        stage('rclpy deserialisation (deserialize_message, what take does)',
              lambda p: deserialize_message(p, JointState), payloads)
        joint = _node_default('joint').encode()
        stage('parse_joint_cdr (prototype: only the joint, from the raw bytes)',
              lambda p: parse_joint_cdr(p, joint), payloads)
        node = fresh_node()
        stage('FrictionExperimentNode.on_joint_state, whole callback', node.on_joint_state,
              messages)
        levels = len(node.service.levels)
        node.destroy_node()
        stage('  stamp_to_seconds(msg.header.stamp)',
              lambda m: stamp_to_seconds(m.header.stamp), messages)
        node = fresh_node()
        service = node.service
        stage('  service.add_joint_state(msg.name, msg.position, ...)',
              lambda m: service.add_joint_state(stamp_s=stamp_to_seconds(m.header.stamp),
                                                name=m.name, position=m.position,
                                                velocity=m.velocity, effort=m.effort),
              messages)
        stage('  service.rejected_total', lambda _: service.rejected_total, messages)
        node.destroy_node()
        stage('    pick_joint(msg fields)', lambda m: segmentation.pick_joint(
            name=m.name, position=m.position, velocity=m.velocity, effort=m.effort,
            joint='joint_2'), messages)
        picked = [(stamp_to_seconds(m.header.stamp),) + segmentation.pick_joint(
            name=m.name, position=m.position, velocity=m.velocity, effort=m.effort,
            joint='joint_2') for m in messages]
        segmenter = segmentation.StreamingSegmenter(service.segmenter_config)
        stage('    StreamingSegmenter.add_sample (incl. the numpy analysis per move)',
              lambda s: segmenter.add_sample(time_s=s[0], position_rad=s[1],
                                             velocity_rad_s=s[2], effort=s[3]), picked)
        stage('  (scale) reading msg.name, .position, .velocity, .effort, .header.stamp',
              lambda m: (m.name, m.position, m.velocity, m.effort, m.header.stamp), messages)
        print(f'\nin-process cost per message, {n_messages} messages at {rate:g} Hz, no graph '
              f'({levels} levels found), back to back (warm caches):')
        for label, us in stages:
            print(f'  {us:8.2f} us  {label}')
        _print_cold_costs(fresh_node, messages, payloads)
        node = fresh_node()
        profiler = cProfile.Profile()
        profiler.enable()
        for msg in messages:
            node.on_joint_state(msg)
        profiler.disable()
        node.destroy_node()
        text = io.StringIO()
        pstats.Stats(profiler, stream=text).sort_stats('tottime').print_stats(top)
        body = text.getvalue()
        print(f'\ncProfile of on_joint_state over {n_messages} messages, top {top} by own time '
              f'(the profiler inflates small calls):')
        print(body[body.find('   ncalls'):].rstrip())
    finally:
        rclpy.try_shutdown()


# --------------------------------------------------------------------------- main

def _rates(text):
    rates = [float(v) for v in text.split(',') if v.strip()]
    if not rates or any(r <= 0 for r in rates):
        raise argparse.ArgumentTypeError(f'expected positive rates, got {text!r}')
    return rates


def _variants(text):
    variants = [v.strip() for v in text.split(',') if v.strip()]
    bad = [v for v in variants if v not in VARIANTS]
    if not variants or bad:
        raise argparse.ArgumentTypeError(f'variants are {", ".join(VARIANTS)}; got {text!r}')
    return variants


def main(argv=None):
    """Parse the arguments; run a child role or the whole benchmark."""
    parser = argparse.ArgumentParser(description=__doc__.strip().splitlines()[0])
    parser.add_argument('--rates', type=_rates, default=[250.0, 1000.0],
                        help='publishing rates [Hz], comma separated (default 250,1000)')
    parser.add_argument('--duration', type=float, default=10.0,
                        help='publishing time per run [s] (default 10)')
    parser.add_argument('--variants', type=_variants, default=list(DEFAULT_VARIANTS),
                        help=f'executor variants among {",".join(VARIANTS)} (default '
                             f'{",".join(DEFAULT_VARIANTS)})')
    parser.add_argument('--pin', action='store_true',
                        help='pin the subscribers to the last CPU and the publisher to the '
                             'others (same conditions for every subscriber)')
    parser.add_argument('--repeat', type=int, default=1,
                        help='rounds over all rates and variants (default 1)')
    parser.add_argument('--profile', type=int, default=20000, metavar='N',
                        help='messages fed to the callback in-process for the profile '
                             '(0: no profile; default 20000)')
    parser.add_argument('--no-events-check', action='store_true',
                        help='skip the EventsExecutor feature check')
    parser.add_argument('--check-executors', type=lambda t: t.split(','), default=['events'],
                        help='executors to check: events,single (default events)')
    parser.add_argument('--no-shell', action='store_true',
                        help='no shell process (the node with its callback replaced by a '
                             'counter) in the runs')
    parser.add_argument('--verbose', action='store_true',
                        help="print every subscriber's result (counts, gc statistics)")
    parser.add_argument('--keep-logs', action='store_true',
                        help="keep the children's stderr and ROS logs (path printed)")
    parser.add_argument('--no-estimator', action='store_true',
                        help='no wear_estimator_node process (nor its comparison with the '
                             'replay) in the runs')
    parser.add_argument('--stall', type=float, default=0.0, metavar='S',
                        help="hold every subscriber's executor once for S seconds half-way "
                             'through the stream (a wake held back: what the /joint_states '
                             'queue must bridge; default 0: none)')
    parser.add_argument('--depth', type=int, default=None, metavar='N',
                        help="the node's joint_states_depth (default: the node's default)")
    parser.add_argument('--stall-after', type=int, default=0, help=argparse.SUPPRESS)
    parser.add_argument('--role', choices=('pub', 'check', 'estimator') + ROLES,
                        help=argparse.SUPPRESS)
    parser.add_argument('--check', default='features',
                        choices=('features',) + tuple(BLOCKING_CALLS), help=argparse.SUPPRESS)
    parser.add_argument('--variant', default='single', help=argparse.SUPPRESS)
    parser.add_argument('--rate', type=float, help=argparse.SUPPRESS)
    parser.add_argument('--subs', type=int, default=2, help=argparse.SUPPRESS)
    args = parser.parse_args(argv)
    if args.role == 'pub':
        return role_publisher(args)
    if args.role in ROLES:
        return role_subscriber(args)
    if args.role == 'estimator':
        return role_estimator(args)
    if args.role == 'check':
        return role_check(args)

    import rclpy  # noqa: F401 - fail early, before any child, when rclpy is missing
    log_dir = Path(tempfile.mkdtemp(prefix='bench_graph_'))
    roles = ROLES if not args.no_shell else ('node', 'nothing')
    qos = _qos()
    print(f'{os.cpu_count()} cores, load average {_load_average():.2f}; '
          f'{", ".join(f"{r:g}" for r in args.rates)} Hz x {args.duration:g} s, variants '
          f'{", ".join(args.variants)}; /joint_states {qos.reliability.name.lower()} depth '
          f'{qos.depth}; localhost discovery, one ROS_DOMAIN_ID per run'
          + f"; the node's queue {args.depth or _node_default('joint_states_depth')}"
          + (f'; every subscriber held {args.stall:g} s once half-way' if args.stall else ''))
    start = time.monotonic()
    if not args.no_events_check:
        executor_check(log_dir, args.check_executors)
    expectations = {}
    if not args.no_estimator:
        for rate in args.rates:
            expected = expectations[rate] = replay_expectation(rate, args.duration, log_dir)
            print(f'replay of the {rate:g} Hz stream: {len(expected["wear"])} experiments '
                  f'({expected["by_stream"]} completed by the stream, the last closed at its '
                  f'end), w-hat {", ".join(f"{w:.4f}" for w in expected["wear"])}', flush=True)
    runs = []
    index = 0
    for rate, variant in [(r, v) for r in args.rates for v in args.variants] * args.repeat:
        domain = 1 + (os.getpid() + index) % 100
        index += 1
        try:
            extra = [] if args.depth is None else ['--depth', str(args.depth)]
            if args.stall > 0:
                extra += ['--stall', str(args.stall), '--stall-after',
                          str(int(rate * args.duration / 2))]
            run = run_variant(rate, variant, args.duration, domain, log_dir, roles, args.pin,
                              expected=expectations.get(rate), extra=extra)
        except RuntimeError as error:
            print(f'{rate:g} Hz {variant}: FAILED: {error}')
            continue
        runs.append(run)
        shares = ', '.join(f'{role} {100 * res["cpu_s"] / run["wall_s"]:.1f} %'
                           for role, res in run['results'].items())
        print(f'  {rate:g} Hz {variant:<15} domain {domain:>3}: received '
              f'{run["results"]["node"]["count"]}/{run["sent"]}; CPU {shares}', flush=True)
        estimates = compare_with_replay(run)
        if estimates is not None:
            cpu = estimates.get('cpu_s')
            print(f'    {estimator_line(estimates)}'
                  + (f'; estimator process {100 * cpu / run["wall_s"]:.1f} % CPU'
                     if cpu is not None else ''), flush=True)
        if args.verbose:
            for role, res in run['results'].items():
                print(f'    {role}: {json.dumps(res)}')
            if run['estimator'] is not None:
                for key in ('levels', 'wear', 'temperature'):
                    print(f'    {key} live:   {json.dumps(run["estimator"].get(key))}')
                    print(f'    {key} replay: {json.dumps(run["expected"][key])}')
    if runs:
        print_table(runs)
        print_summary(runs)
    print(f'\nCPU % = CPU s / publishing s (100 % = one core), from START to idle after the '
          f'last message; us/msg = CPU s / received;\n/nothing = CPU ratio to the do-nothing '
          f'subscriber of the same run and executor; shell = the node with its callback '
          f'replaced by a counter.\ngraph part took {time.monotonic() - start:.0f} s')
    if args.profile > 0:
        profile_callback(args.profile, top=14)
    if args.keep_logs:
        print(f'logs: {log_dir}')
    else:
        for path in sorted(log_dir.rglob('*'), reverse=True):
            path.rmdir() if path.is_dir() else path.unlink()
        log_dir.rmdir()
    return 0 if runs else 1


if __name__ == '__main__':
    sys.exit(main())
