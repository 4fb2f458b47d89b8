"""
A ROS 2 graph of real processes and one probe node, for the process-level node tests.

launch_testing's habit without launch (not on PyPI): start the real executables on a fresh
ROS domain, wait for what a subscriber sees, stop everything at the end.  A test's graph
subclasses :class:`ProcessGraph`, creates its subscriptions, publishers and clients on
``self.node`` and then calls :meth:`ProcessGraph.spin`.
"""

import os
from pathlib import Path
import signal
import subprocess
import threading
import time

import rclpy
from rclpy.executors import SingleThreadedExecutor
from robot_wear_monitor.history import AlarmEvent, HistoryRecord, open_history
from wear_testing.paths import console_script
from wear_testing.ros_graph import next_ros_domain_id

#: ``test/``, where the package ``wear_testing`` is.
TEST_DIR = Path(__file__).resolve().parents[1]


def write_latched_history(path, *, robot=None):
    """Write a history whose joint_2 has a latched alarm (as a node before would have)."""
    with open_history(path, robot=robot) as history:
        record = HistoryRecord(joint='joint_2', stamp_s=100.0, speeds_rad_s=(2.1, 28.5),
                               frictions=(0.2, 0.1), temperature_degc=40.0,
                               temperature_std_degc=2.0, wear=48.0, wear_std=4.0, chi2=1.0,
                               dof=0, p_value=float('nan'), temperature_at_bound=False,
                               wear_at_bound=False, alarm_active=True, alarm_evidence=3.0,
                               status_level=2, parameter_set='abb_irb6620_joint2')
        history.append(record, events=[AlarmEvent(joint='joint_2', stamp_s=100.0,
                                                  event='raised', wear=48.0)])


class ProcessGraph:
    """Processes and a probe node on one fresh ROS domain; everything is stopped at the end."""

    def __init__(self, tmp_path, *, probe='user_probe'):
        """Start a context on a fresh domain with the probe node (not spinning yet)."""
        self.tmp_path = tmp_path
        self.env = {**os.environ, 'ROS_DOMAIN_ID': str(next_ros_domain_id()),
                    'ROS_AUTOMATIC_DISCOVERY_RANGE': 'LOCALHOST', 'PYTHONUNBUFFERED': '1',
                    'RCUTILS_LOGGING_BUFFERED_STREAM': '0',
                    'PYTHONFAULTHANDLER': '1',  # a crash prints every thread's stack
                    # the tests' helper package for ``python -m wear_testing...`` processes
                    'PYTHONPATH': os.pathsep.join(
                        [str(TEST_DIR), *filter(None, [os.environ.get('PYTHONPATH')])])}
        self.processes = {}
        self.context = rclpy.Context()
        rclpy.init(context=self.context, domain_id=int(self.env['ROS_DOMAIN_ID']))
        self.node = rclpy.create_node(probe, context=self.context)
        self.lock = threading.Lock()
        self.executor = None
        self.spinner = None

    def spin(self):
        """Spin the probe node in a background thread (call after creating its endpoints)."""
        self.executor = SingleThreadedExecutor(context=self.context)
        self.executor.add_node(self.node)
        self.spinner = threading.Thread(target=self._spin, daemon=True)
        self.spinner.start()

    def _spin(self):
        while self.context.ok():
            try:
                self.executor.spin_once(timeout_sec=0.05)
            except Exception:  # noqa: BLE001 - the context is shut down under the loop
                return

    def _add(self, target, value):
        with self.lock:
            target.append(value)

    def start(self, name, *command):
        """Start ``command`` (its first word a console script or a path) logging to a file."""
        with open(self.tmp_path / f'{name}.log', 'ab') as log:
            self.processes[name] = subprocess.Popen(
                [console_script(command[0]), *command[1:]], env=self.env, stdout=log,
                stderr=subprocess.STDOUT)
        return self.processes[name]

    def log(self, name):
        """Return what process ``name`` has written so far."""
        return (self.tmp_path / f'{name}.log').read_text(errors='replace')

    def logs(self):
        """Return the tail of every process's log (for an assertion message)."""
        return '\n'.join(f'--- {name}\n{self.log(name)[-3000:]}' for name in self.processes)

    def wait(self, predicate, timeout_s):
        """Wait until ``predicate()`` (called under the lock) is true; return its last value."""
        deadline = time.monotonic() + timeout_s
        while time.monotonic() < deadline:
            with self.lock:
                if predicate():
                    return True
            time.sleep(0.05)
        with self.lock:
            return predicate()

    def settle(self, state, *, quiet_s=0.5, timeout_s=10.0):
        """
        Wait until ``state()`` (under the lock) has not changed for ``quiet_s``; return True.

        The condition of "nothing more arrives": False when it still changes at the deadline.
        """
        deadline = time.monotonic() + timeout_s
        with self.lock:
            last, since = state(), time.monotonic()
        while time.monotonic() < deadline:
            time.sleep(0.05)
            with self.lock:
                now = state()
            if now != last:
                last, since = now, time.monotonic()
            elif time.monotonic() - since >= quiet_s:
                return True
        return False

    def stop(self, name):
        """SIGINT, then kill: return the exit code (None when it had to be killed)."""
        process = self.processes[name]
        if process.poll() is None:
            process.send_signal(signal.SIGINT)
            try:
                return process.wait(timeout=5.0)
            except subprocess.TimeoutExpired:
                process.kill()
                process.wait()
                return None
        return process.returncode

    def close(self):
        """Kill what still runs and shut the probe's context down."""
        for process in self.processes.values():
            if process.poll() is None:
                process.kill()
                process.wait()
        if self.executor is not None:
            self.executor.shutdown()
        self.node.destroy_node()
        rclpy.try_shutdown(context=self.context)
        if self.spinner is not None:
            self.spinner.join(timeout=2.0)
