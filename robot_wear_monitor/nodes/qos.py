"""QoS profiles of the wear monitor's topics, shared by both nodes (publisher = subscriber)."""

from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy


def _reliable(depth: int, durability: DurabilityPolicy = DurabilityPolicy.VOLATILE
              ) -> QoSProfile:
    return QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=depth,
                      reliability=ReliabilityPolicy.RELIABLE, durability=durability)


#: /joint_states: reliable like joint_state_broadcaster, deep enough for one second at 1 kHz
#: (a slow callback elsewhere in the process must not drop samples of a friction pass).
JOINT_STATES_QOS = _reliable(1000)
#: friction_levels: every experiment matters and they are rare.
FRICTION_LEVELS_QOS = _reliable(10)
#: temperature, wear: one message per estimate.
ESTIMATE_QOS = _reliable(10)
#: The alarm state is latched: a late subscriber gets the current state at once.
ALARM_QOS = _reliable(1, DurabilityPolicy.TRANSIENT_LOCAL)
DIAGNOSTICS_QOS = _reliable(10)
