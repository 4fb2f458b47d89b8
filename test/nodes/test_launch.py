"""
The launch file: the nodes from their executables with the packaged params file.

ROS 2's ``launch`` and ``launch_ros`` are not on PyPI, so the test loads the launch file with
minimal stand-ins of the few classes it uses and asserts on the description it returns: the three
node executables of this package, their names, the params file argument that defaults to the
installed ``config/wear_monitor.yaml`` and the ``runner`` argument that conditions the
friction_experiment_runner.  ``ros2 launch`` itself runs on a ROS 2 host.
"""

import importlib.util
from pathlib import Path
import sys
import types

LAUNCH_FILE = Path(__file__).resolve().parents[2] / 'launch' / 'wear_monitor_launch.py'


class _Recorded:

    def __init__(self, *args, **kwargs):
        """Keep the constructor arguments."""
        self.args, self.kwargs = args, kwargs


def _stand_ins(share_dir):
    launch = types.ModuleType('launch')
    launch.LaunchDescription = lambda entities: list(entities)
    actions = types.ModuleType('launch.actions')
    actions.DeclareLaunchArgument = type('DeclareLaunchArgument', (_Recorded,), {})
    substitutions = types.ModuleType('launch.substitutions')
    substitutions.LaunchConfiguration = type('LaunchConfiguration', (_Recorded,), {})
    conditions = types.ModuleType('launch.conditions')
    conditions.IfCondition = type('IfCondition', (_Recorded,), {})
    launch_ros = types.ModuleType('launch_ros')
    ros_actions = types.ModuleType('launch_ros.actions')
    ros_actions.Node = type('Node', (_Recorded,), {})
    ament = types.ModuleType('ament_index_python')
    packages = types.ModuleType('ament_index_python.packages')
    packages.get_package_share_directory = lambda name: str(share_dir / name)
    return {'launch': launch, 'launch.actions': actions, 'launch.substitutions': substitutions,
            'launch.conditions': conditions,
            'launch_ros': launch_ros, 'launch_ros.actions': ros_actions,
            'ament_index_python': ament, 'ament_index_python.packages': packages}


def test_launch_description_starts_the_nodes_with_the_params_file(monkeypatch, tmp_path):
    for name, module in _stand_ins(tmp_path).items():
        monkeypatch.setitem(sys.modules, name, module)
    spec = importlib.util.spec_from_file_location('wear_monitor_launch', LAUNCH_FILE)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    entities = module.generate_launch_description()
    arguments = {e.args[0]: e for e in entities if type(e).__name__ == 'DeclareLaunchArgument'}
    assert sorted(arguments) == ['params_file', 'runner']
    assert arguments['params_file'].kwargs['default_value'] == str(
        tmp_path / 'robot_wear_monitor' / 'config' / 'wear_monitor.yaml')
    assert arguments['runner'].kwargs['default_value'] == 'true'
    nodes = [e for e in entities if type(e).__name__ == 'Node']
    assert sorted((n.kwargs['executable'], n.kwargs['name']) for n in nodes) == [
        ('friction_experiment_node', 'friction_experiment_node'),
        ('friction_experiment_runner', 'friction_experiment_runner'),
        ('wear_estimator_node', 'wear_estimator_node')]
    for node in nodes:
        assert node.kwargs['package'] == 'robot_wear_monitor'
        [params] = node.kwargs['parameters']
        assert params.args == ('params_file',)
        condition = node.kwargs.get('condition')
        if node.kwargs['executable'] == 'friction_experiment_runner':
            [runner] = condition.args
            assert runner.args == ('runner',)
        else:
            assert condition is None
    for executable in ('friction_experiment_node', 'wear_estimator_node',
                       'friction_experiment_runner'):
        assert (Path(__file__).resolve().parents[2] / 'robot_wear_monitor' / 'nodes'
                / f'{executable}.py').is_file()
