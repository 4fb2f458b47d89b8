"""Recordings: ROS 2 bags, message mapping, measured raw tables."""
