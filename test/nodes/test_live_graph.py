"""
End to end on a live ROS 2 graph, as processes, the way a user runs the monitor.

``friction_experiment_node`` and ``wear_estimator_node`` start from their console scripts with
the packaged params file; ``robot-wear-monitor play`` plays a recording made by the test's own
generator (``independent_robot``, not the project's simulator) on ``/joint_states`` at its
recorded 1 kHz pace; this test subscribes as any user would.  It compares every ``/wear`` with
the offline ``robot-wear-monitor replay`` of the same bag, checks the latched alarm, a clean
SIGINT exit, the history, and a SIGKILL of the estimator followed by a restart.  Each run has
its own ROS_DOMAIN_ID and localhost-only discovery.
"""

import json
from pathlib import Path
import signal
import sqlite3
import subprocess
import sys
import threading
import time

from diagnostic_msgs.msg import DiagnosticArray
import pytest
from robot_wear_monitor.monitoring.node_config import default_node_config_file
from robot_wear_monitor.nodes.qos import ALARM_QOS, DIAGNOSTICS_QOS
from robot_wear_monitor.recordings.messages import diagnostics_from_msg
from sensor_msgs.msg import JointState, Temperature
from std_msgs.msg import Bool, Float64
from wear_testing import independent_robot as robot
from wear_testing.paths import console_script
from wear_testing.process_graph import ProcessGraph

N_EXPERIMENTS = 8
BIN = Path(sys.executable).parent


class Graph(ProcessGraph):
    """Processes and a subscriber on one ROS domain; everything is stopped at the end."""

    def __init__(self, tmp_path):
        """Start a context on a fresh domain and subscribe to every output."""
        super().__init__(tmp_path, probe='user_probe')
        self.wear, self.alarm, self.temperature = [], [], []
        self.levels, self.diagnostics = [], {}
        self.lock = threading.Lock()
        self.node.create_subscription(Float64, 'wear', lambda m: self._add(self.wear, m.data),
                                      10)
        self.node.create_subscription(Bool, 'wear_alarm',
                                      lambda m: self._add(self.alarm, m.data), ALARM_QOS)
        self.node.create_subscription(Temperature, 'temperature',
                                      lambda m: self._add(self.temperature, m.temperature), 10)
        self.node.create_subscription(JointState, 'friction_levels',
                                      lambda m: self._add(self.levels, list(m.effort)), 10)
        self.node.create_subscription(DiagnosticArray, '/diagnostics', self._on_diagnostics,
                                      DIAGNOSTICS_QOS)
        self.levels_publisher = self.node.create_publisher(JointState, 'friction_levels', 10)
        self.spin()

    def _on_diagnostics(self, msg):
        for level, name, message, values in diagnostics_from_msg(msg):
            self._add(self.diagnostics.setdefault(name.split(':')[0], []),
                      (level, message, values))


@pytest.fixture
def graph(tmp_path):
    g = Graph(tmp_path)
    yield g
    g.close()


def _offline_replay(bag, tmp_path):
    summary = tmp_path / 'replay.json'
    done = subprocess.run([console_script('robot-wear-monitor'), 'replay', str(bag), '--out',
                           str(tmp_path / 'replayed'), '--json', str(summary),
                           '--no-progress'], capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stderr
    return json.loads(summary.read_text())


def test_both_nodes_as_processes_match_the_offline_replay_and_survive_the_alarm(graph,
                                                                                tmp_path):
    recording = robot.generate_wear_test(n_experiments=N_EXPERIMENTS, wear_start=5.0,
                                         wear_end=60.0, seed=11, rate_hz=1000.0)
    bag = tmp_path / 'wear_test'
    robot.write_bag(bag, recording)
    offline = _offline_replay(bag, tmp_path)
    expected = [e['wear'] for e in offline['experiments']]
    assert len(expected) == N_EXPERIMENTS
    first_alarm = offline['first_alarm']['index']
    truth_wear = [t.wear for t in recording.truth]
    assert truth_wear[first_alarm - 1] > 30.0  # the alarm comes where the joint is worn

    params_file = str(default_node_config_file())
    history = tmp_path / 'history.sqlite3'
    graph.start('friction_experiment_node', 'friction_experiment_node', '--ros-args',
                '--params-file', params_file)
    graph.start('wear_estimator_node', 'wear_estimator_node', '--ros-args', '--params-file',
                params_file, '-p', f'history_file:={history}')
    assert graph.wait(lambda: graph.alarm == [False] and len(graph.diagnostics) == 2, 20.0), \
        'the nodes did not come up: ' + graph.log('wear_estimator_node')
    player = graph.start('player', 'robot-wear-monitor', 'play', str(bag), '--topics',
                         '/joint_states', '--wait-for-subscribers', '1')
    player.wait(timeout=120)
    assert player.returncode == 0, graph.log('player')
    assert f'played {len(recording.stamps_s)} messages' in graph.log('player')
    assert graph.wait(lambda: len(graph.wear) >= N_EXPERIMENTS, 20.0), graph.log(
        'wear_estimator_node')
    # nothing more may come (the outputs stay the same for 1.5 s); the diagnostics go on
    assert graph.settle(lambda: (len(graph.wear), len(graph.temperature), len(graph.alarm)),
                        quiet_s=1.5)

    assert len(graph.wear) == N_EXPERIMENTS
    assert graph.wear == pytest.approx(expected, abs=1e-6)
    assert len(graph.temperature) == N_EXPERIMENTS
    assert graph.alarm[-1] is True
    assert graph.alarm.index(True) == first_alarm  # the first message is the latched False
    level, message, values = graph.diagnostics['wear_monitor'][-1]
    assert level == 2 and values['experiments'] == str(N_EXPERIMENTS)
    _, _, segmentation = graph.diagnostics['friction_experiment'][-1]
    assert segmentation['joint_states'] == str(len(recording.stamps_s))  # no message lost
    for name in ('friction_experiment_node', 'wear_estimator_node'):
        assert graph.processes[name].poll() is None, f'{name} died: ' + graph.log(name)

    started = time.monotonic()
    for name in ('friction_experiment_node', 'wear_estimator_node'):
        graph.processes[name].send_signal(signal.SIGINT)
    for name in ('friction_experiment_node', 'wear_estimator_node'):
        assert graph.processes[name].wait(timeout=5.0) == 0, graph.log(name)
    assert time.monotonic() - started < 5.0
    for name in ('friction_experiment_node', 'wear_estimator_node', 'player'):
        assert 'Traceback' not in graph.log(name), graph.log(name)
    assert 'WEAR ALARM raised by experiment' in graph.log('wear_estimator_node')
    with sqlite3.connect(history) as conn:
        stored = [row[0] for row in conn.execute('SELECT wear FROM estimates ORDER BY id')]
    assert stored == pytest.approx(expected, abs=1e-6)

    # SIGKILL after one more estimate was written: the restart has it and the latched alarm.
    graph.alarm.clear()
    estimator = graph.start('wear_estimator_node', 'wear_estimator_node', '--ros-args',
                            '--params-file', params_file, '-p', f'history_file:={history}')
    assert graph.wait(lambda: graph.alarm == [True], 20.0), graph.log('wear_estimator_node')
    assert graph.wait(lambda: graph.levels_publisher.get_subscription_count() >= 2, 10.0)
    last = recording.truth[-1]
    msg = JointState()
    msg.header.stamp.sec = int(recording.stamps_s[-1]) + 60
    msg.header.frame_id = 'joint_2'
    msg.name = [f'joint_2/level_{i}' for i in range(4)]
    msg.velocity = list(last.speeds_rad_s)
    msg.effort = list(last.friction_true)
    graph.levels_publisher.publish(msg)
    assert graph.wait(lambda: len(graph.wear) == N_EXPERIMENTS + 1, 10.0)
    estimator.send_signal(signal.SIGKILL)
    estimator.wait(timeout=5.0)
    graph.alarm.clear()
    graph.start('wear_estimator_node', 'wear_estimator_node', '--ros-args', '--params-file',
                params_file, '-p', f'history_file:={history}')
    assert graph.wait(lambda: graph.alarm == [True], 20.0), graph.log('wear_estimator_node')
    assert graph.wait(lambda: any(v['experiments'] == str(N_EXPERIMENTS + 1) and 'restored'
                                  in m for _, m, v in graph.diagnostics['wear_monitor']), 5.0)
    with sqlite3.connect(history) as conn:
        assert conn.execute('SELECT COUNT(*) FROM estimates').fetchone()[0] == N_EXPERIMENTS + 1


def test_live_command_runs_both_nodes_in_one_process(graph, tmp_path):
    recording = robot.generate_wear_test(n_experiments=2, wear_start=40.0, wear_end=45.0,
                                         seed=3, rate_hz=500.0)
    bag = tmp_path / 'two'
    robot.write_bag(bag, recording)
    live = graph.start('live', 'robot-wear-monitor', 'live', '--history',
                       str(tmp_path / 'h.sqlite3'))
    assert graph.wait(lambda: len(graph.diagnostics) == 2, 20.0), graph.log('live')
    player = graph.start('player', 'robot-wear-monitor', 'play', str(bag), '--rate', '2')
    assert player.wait(timeout=60) == 0, graph.log('player')
    assert graph.wait(lambda: len(graph.wear) == 2, 20.0), graph.log('live')
    assert graph.wear[0] == pytest.approx(40.0, abs=6.0)
    assert graph.alarm[-1] is True
    live.send_signal(signal.SIGINT)  # Ctrl-C: 130, as every verb interrupted (command-line.md)
    assert live.wait(timeout=5.0) == 130, graph.log('live')
    assert 'Traceback' not in graph.log('live')


def test_live_command_exits_0_on_sigterm(graph, tmp_path):
    """SIGTERM is a service manager's stop, not an interruption: exit 0, the history whole."""
    history = tmp_path / 'h.sqlite3'
    live = graph.start('live', 'robot-wear-monitor', 'live', '--history', str(history))
    assert graph.wait(lambda: len(graph.diagnostics) == 2, 40.0), graph.log('live')
    live.send_signal(signal.SIGTERM)
    assert live.wait(timeout=10.0) == 0, graph.log('live')
    assert 'Traceback' not in graph.log('live')
    with sqlite3.connect(history) as conn:
        assert conn.execute('PRAGMA integrity_check').fetchone() == ('ok',)


def test_live_command_refuses_a_bad_params_file(tmp_path):
    bad = tmp_path / 'bad.yaml'
    bad.write_text('friction_experiment_node:\n  ros__parameters:\n    gear_ratio: 150\n')
    done = subprocess.run([console_script('robot-wear-monitor'), 'live', '--params-file',
                           str(bad)], capture_output=True, text=True, timeout=60)
    assert done.returncode == 2
    assert 'gear_ratio: expected a double, got integer 150' in done.stderr
    assert 'Traceback' not in done.stderr
