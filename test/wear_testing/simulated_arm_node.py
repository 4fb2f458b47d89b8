"""
A simulated arm on the ROS 2 graph for the closed-loop test (the tests' own code).

Usage: ``python3 -m wear_testing.simulated_arm_node CONFIG_JSON [--ros-args ...]`` with CONFIG_JSON
``{"names": [...], "posture": [...], "tested": {"joint_2": {JointTruth fields}, ...},
"controller": "joint_trajectory_controller", "rate_hz": 250.0, "seed": 0}``.

It stands in for a robot with ros2_control: it subscribes to
``/<controller>/joint_trajectory`` like a joint_trajectory_controller (a new trajectory replaces
the current one from the arm's present state, header stamp 0 = now) and publishes
``/joint_states`` at ``rate_hz`` in real time from a thread of its own, with the efforts of
``trajectory_follower.SimulatedArm`` (``independent_robot``'s friction model at the configured
wear, temperature and load, gravity, inertia and noise).

Like a controller manager's update loop, the arm samples on a regular grid of the ROS clock
(``rate_hz`` from its first sample) and stamps each sample with its grid time; a trajectory is
taken up by the first sample at or after its receipt.  When the process is starved of CPU the
samples come late, in a burst, but none is missing and their stamps stay regular: stamping
each sample with the time it happened to be computed left gaps of tens of ms in the stamps on
a loaded machine, which cut the runner's short plateaus (0.26 s, planned with 4 samples to
spare) below the segmentation's ``min_duration_s`` and lost a friction level.
"""

import json
import sys
import threading
import time

import rclpy
from rclpy.executors import ExternalShutdownException, SingleThreadedExecutor
from rclpy.qos import HistoryPolicy, QoSProfile, ReliabilityPolicy
from sensor_msgs.msg import JointState
from trajectory_msgs.msg import JointTrajectory
from wear_testing.trajectory_follower import JointTruth, SimulatedArm


def _qos(depth):
    return QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=depth,
                      reliability=ReliabilityPolicy.RELIABLE)


class ArmNode:
    """The node, the arm, and the publishing thread."""

    def __init__(self, config):
        """Subscribe to the controller's trajectory topic and advertise /joint_states."""
        self.node = rclpy.create_node('simulated_arm')
        self.arm = SimulatedArm(config['names'], config['posture'],
                                tested={j: JointTruth(**t) for j, t in config['tested'].items()},
                                seed=int(config.get('seed', 0)))
        self.period_s = 1.0 / float(config.get('rate_hz', 250.0))
        self.lock = threading.Lock()
        self.pending = []  # (receipt time [s], trajectory) not yet taken up by a sample
        self.running = True
        controller = config.get('controller', 'joint_trajectory_controller')
        self.node.create_subscription(JointTrajectory, f'/{controller}/joint_trajectory',
                                      self.on_trajectory, _qos(10))
        self.publisher = self.node.create_publisher(JointState, 'joint_states', _qos(1000))
        self.thread = threading.Thread(target=self.publish_loop, daemon=True)

    def now_s(self):
        return self.node.get_clock().now().nanoseconds * 1e-9

    def on_trajectory(self, msg):
        times = [p.time_from_start.sec + 1e-9 * p.time_from_start.nanosec for p in msg.points]
        command = {'joint_names': list(msg.joint_names), 'time_from_start_s': times,
                   'positions': [list(p.positions) for p in msg.points],
                   'velocities': [list(p.velocities) for p in msg.points]}
        with self.lock:
            self.pending.append((self.now_s(), command))
        self.node.get_logger().info(f'trajectory of {len(times)} points, '
                                    f'{times[-1] if times else 0.0:.2f} s')

    def publish_loop(self):
        # sample k at ROS time first_stamp + k period, published at monotonic first_due +
        # k period or, when late, at once (never skipped: see the module doc)
        first_due, first_stamp = time.monotonic(), self.now_s()
        names = list(self.arm.names)
        k = 0
        while self.running:
            delay = first_due + k * self.period_s - time.monotonic()
            if delay > 0:
                time.sleep(delay)
            stamp = first_stamp + k * self.period_s
            k += 1
            with self.lock:
                while self.pending and self.pending[0][0] <= stamp:
                    self.arm.command(stamp, **self.pending.pop(0)[1])
                position, velocity, effort = self.arm.sample(stamp)
            msg = JointState()
            msg.header.stamp.sec, msg.header.stamp.nanosec = divmod(int(stamp * 1e9),
                                                                    1_000_000_000)
            msg.name = names
            msg.position, msg.velocity, msg.effort = position, velocity, effort
            try:
                self.publisher.publish(msg)
            except Exception:  # noqa: BLE001 - shutting down under the thread
                return


def main():
    config = json.loads(sys.argv[1])
    rclpy.init(args=sys.argv)
    arm = ArmNode(config)
    executor = SingleThreadedExecutor()
    executor.add_node(arm.node)
    arm.thread.start()
    try:
        executor.spin()
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    finally:
        arm.running = False
        arm.thread.join(timeout=1.0)
        executor.shutdown()
        arm.node.destroy_node()
        rclpy.try_shutdown()
    return 0


if __name__ == '__main__':
    sys.exit(main())
