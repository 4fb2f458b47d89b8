"""
Launch the wear monitor: friction_experiment_node, wear_estimator_node and the runner.

Usage: ``ros2 launch robot_wear_monitor wear_monitor_launch.py [params_file:=my.yaml]
[runner:=false]``.  The friction_experiment_runner only moves the robot when its ``~/start``
service is called; ``runner:=false`` leaves it out.
"""

import os

from ament_index_python.packages import get_package_share_directory
from launch import LaunchDescription
from launch.actions import DeclareLaunchArgument
from launch.conditions import IfCondition
from launch.substitutions import LaunchConfiguration
from launch_ros.actions import Node


def generate_launch_description():
    """Return the nodes with the packaged config/wear_monitor.yaml (overridable)."""
    default_params = os.path.join(get_package_share_directory('robot_wear_monitor'), 'config',
                                  'wear_monitor.yaml')
    params_file = LaunchConfiguration('params_file')
    return LaunchDescription([
        DeclareLaunchArgument('params_file', default_value=default_params,
                              description='ROS 2 parameter YAML of the nodes'),
        DeclareLaunchArgument('runner', default_value='true',
                              description='also start friction_experiment_runner'),
        Node(package='robot_wear_monitor', executable='friction_experiment_node',
             name='friction_experiment_node', parameters=[params_file], output='screen'),
        Node(package='robot_wear_monitor', executable='wear_estimator_node',
             name='wear_estimator_node', parameters=[params_file], output='screen'),
        Node(package='robot_wear_monitor', executable='friction_experiment_runner',
             name='friction_experiment_runner', parameters=[params_file], output='screen',
             condition=IfCondition(LaunchConfiguration('runner'))),
    ])
