"""The launch file: both nodes with the packaged parameters (skipped without ROS 2 launch)."""

import importlib.util
from pathlib import Path

import pytest

LAUNCH_FILE = Path(__file__).resolve().parents[1] / 'launch' / 'wear_monitor_launch.py'


def test_launch_description_starts_both_nodes():
    pytest.importorskip('launch_ros',
                        reason='launch_ros is not installed (no ROS 2 on this host)')
    from launch_ros.actions import Node
    spec = importlib.util.spec_from_file_location('wear_monitor_launch', LAUNCH_FILE)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    description = module.generate_launch_description()
    nodes = [e for e in description.entities if isinstance(e, Node)]
    assert sorted(n.node_executable for n in nodes) == ['friction_experiment_node',
                                                        'wear_estimator_node']


def test_launch_file_parses_without_ros():
    import ast
    tree = ast.parse(LAUNCH_FILE.read_text())
    assert any(isinstance(n, ast.FunctionDef) and n.name == 'generate_launch_description'
               for n in tree.body)
