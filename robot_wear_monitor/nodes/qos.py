"""QoS profiles of the wear monitor's topics, shared by the nodes (publisher = subscriber)."""

from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy


def _reliable(depth: int, durability: DurabilityPolicy = DurabilityPolicy.VOLATILE
              ) -> QoSProfile:
    return QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=depth,
                      reliability=ReliabilityPolicy.RELIABLE, durability=durability)


#: /joint_states: reliable like joint_state_broadcaster, deep enough for one second at 1 kHz
#: (a slow callback elsewhere in the process must not drop samples of a friction pass).
JOINT_STATES_QOS = _reliable(1000)


def joint_states_qos(depth: int) -> QoSProfile:
    """Return :data:`JOINT_STATES_QOS` with another depth (the friction node's parameter)."""
    return _reliable(depth)


#: friction_levels: every experiment matters and they are rare.
FRICTION_LEVELS_QOS = _reliable(10)
#: temperature, wear: one message per estimate.
ESTIMATE_QOS = _reliable(10)
#: The alarm state is latched: a late subscriber gets the current state at once.
ALARM_QOS = _reliable(1, DurabilityPolicy.TRANSIENT_LOCAL)
DIAGNOSTICS_QOS = _reliable(10)
#: The runner's JointTrajectory: reliable, volatile, like the controller's subscription
#: (ros2_control's joint_trajectory_controller subscribes with the system default QoS); a
#: trajectory must never reach a controller late, so it is not kept for late joiners.
TRAJECTORY_QOS = _reliable(10)
#: The runner's experiment events: reliable and transient local, so that a consumer that
#: (re)starts during an experiment still gets its ``start`` (and a recorder the recent
#: events); both are needed for the boundaries, and they are rare.  Depth 100 keeps the last
#: 50 experiments.  A transient-local publisher also serves volatile subscribers
#: (``ros2 topic echo``); the friction_experiment_node subscribes transient local.
EXPERIMENT_EVENTS_QOS = _reliable(100, DurabilityPolicy.TRANSIENT_LOCAL)
