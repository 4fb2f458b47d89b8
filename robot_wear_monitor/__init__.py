"""
robot_wear_monitor: wear monitoring of a robot joint from constant-speed friction data.

The core (model, params, estimation, design, segmentation, simulation, bags, history, audit) is
ROS-agnostic: it imports numpy, scipy (audit, identify, design) and rosbags only.  The rclpy
nodes live in ``robot_wear_monitor.nodes`` and are thin shells over the core.
"""

__version__ = '0.4.0'
