"""
Without rclpy (a plain ``pip install .``) the verbs that need it end in one line, not a traceback.

Each verb runs in a process of its own whose ``sys.meta_path`` refuses ``rclpy`` (and its
submodules) as an interpreter without the ``ros`` extra would, whatever is installed here.
"""

import subprocess
import sys
import textwrap

import pytest

#: A ``python -c`` runner: rclpy unimportable, then the command line with ``sys.argv[1:]``.
WITHOUT_RCLPY = textwrap.dedent("""
    import sys

    class NoRclpy:
        def find_spec(self, name, path=None, target=None):
            if name == 'rclpy' or name.startswith('rclpy.'):
                raise ModuleNotFoundError(f"No module named {name!r}", name=name)
            return None

    sys.meta_path.insert(0, NoRclpy())
    from robot_wear_monitor.cli import main
    sys.exit(main())
""")


@pytest.mark.parametrize('command', [['live'], ['play', 'BAG'], ['call', 'start']],
                         ids=['live', 'play', 'call'])
def test_a_verb_that_needs_rclpy_names_the_ros_extra_in_one_line(tmp_path, command):
    if command[0] == 'play':  # a real bag: the missing rclpy, not the bag, is the error
        from wear_testing import independent_robot as robot
        bag = tmp_path / 'bag'
        robot.write_bag(bag, robot.generate_wear_test(n_experiments=1, wear_start=5.0,
                                                      wear_end=5.0, seed=1, rate_hz=100.0))
        command = ['play', str(bag)]
    done = subprocess.run([sys.executable, '-c', WITHOUT_RCLPY, *command], cwd=tmp_path,
                          capture_output=True, text=True, timeout=120)
    assert done.returncode == 2, done.stderr
    assert 'Traceback' not in done.stderr
    lines = done.stderr.strip().splitlines()
    assert len(lines) == 1, done.stderr
    assert lines[0].startswith(f'robot-wear-monitor {command[0]}: error: needs rclpy')
    assert '"ros" extra' in lines[0] and "pip install '.[ros]'" in lines[0]
    assert "No module named 'rclpy'" in lines[0]
    assert done.stdout == ''
