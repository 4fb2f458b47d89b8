"""The monitor's small typestore equals rosbags' ROS 2 Jazzy store for every type it holds."""

import pytest
from robot_wear_monitor.recordings import bags
from robot_wear_monitor.recordings.bags.message_types import FIELDDEFS, monitor_typestore
from robot_wear_monitor.recordings.messages import (ALARM_TYPE, DIAGNOSTICS_TYPE,
                                                    TEMPERATURE_TYPE, TRAJECTORY_TYPE,
                                                    TREND_TYPE, WEAR_TYPE)
from rosbags.typesys import get_typestore, Stores


def test_every_type_equals_the_jazzy_store_with_the_same_definition_and_hash():
    jazzy = get_typestore(Stores.ROS2_JAZZY)
    ours = monitor_typestore()
    assert set(ours.fielddefs) == set(FIELDDEFS)
    for name in FIELDDEFS:
        assert ours.fielddefs[name] == jazzy.fielddefs[name], name
        assert ours.generate_msgdef(name, ros_version=2) == jazzy.generate_msgdef(
            name, ros_version=2), name
        assert ours.hash_rihs01(name) == jazzy.hash_rihs01(name), name


def test_the_store_holds_what_the_monitor_reads_and_writes():
    names = set(monitor_typestore().types)
    wanted = {bags.JOINT_STATE_TYPE, *bags.SCALAR_FIELDS, ALARM_TYPE, DIAGNOSTICS_TYPE,
              TEMPERATURE_TYPE, TRAJECTORY_TYPE, TREND_TYPE, WEAR_TYPE}
    assert wanted <= names


def test_a_message_serialises_to_the_same_bytes_as_with_the_jazzy_store():
    jazzy = get_typestore(Stores.ROS2_JAZZY)
    ours = bags.MONITOR_TYPESTORE
    status = ours.types['diagnostic_msgs/msg/DiagnosticStatus'](
        level=1, name='wear', message='ok', hardware_id='joint_2',
        values=[ours.types['diagnostic_msgs/msg/KeyValue'](key='w', value='3.5')])
    raw = bytes(ours.serialize_cdr(status, 'diagnostic_msgs/msg/DiagnosticStatus'))
    again = jazzy.deserialize_cdr(raw, 'diagnostic_msgs/msg/DiagnosticStatus')
    assert bytes(jazzy.serialize_cdr(again, 'diagnostic_msgs/msg/DiagnosticStatus')) == raw
    assert again.hardware_id == 'joint_2' and again.values[0].value == '3.5'


def test_the_package_still_offers_the_whole_jazzy_store_as_typestore():
    assert 'geometry_msgs/msg/Twist' in bags.TYPESTORE.types
    assert bags.TYPESTORE is bags.common.TYPESTORE


def test_the_bag_writer_still_writes_any_jazzy_type(tmp_path):
    """A type outside the monitor's 16 comes from rosbags' whole Jazzy store, as before."""
    from rosbags.rosbag2 import Reader

    jazzy = get_typestore(Stores.ROS2_JAZZY)
    twist = jazzy.types['geometry_msgs/msg/Twist'](
        linear=jazzy.types['geometry_msgs/msg/Vector3'](x=1.5, y=0.0, z=-2.0),
        angular=jazzy.types['geometry_msgs/msg/Vector3'](x=0.0, y=0.25, z=0.0))
    with bags.atomic_bag_writer(tmp_path / 'bag') as writer:
        writer.add_topic('/cmd_vel', 'geometry_msgs/msg/Twist')
        writer.add_topic('/wear', WEAR_TYPE)
        writer.write('/cmd_vel', twist, 1_000)
        writer.write('/wear', ours_float(3.5), 2_000)
        with pytest.raises(bags.BagError, match='unknown message type'):
            writer.add_topic('/x', 'no_msgs/msg/Nothing')
    with Reader(tmp_path / 'bag') as reader:
        got = {c.topic: jazzy.deserialize_cdr(raw, c.msgtype)
               for c, _, raw in reader.messages()}
        types = {c.topic: (c.msgtype, c.digest) for c in reader.connections}
    assert got['/cmd_vel'].linear.z == -2.0 and got['/cmd_vel'].angular.y == 0.25
    assert got['/wear'].data == 3.5
    assert types['/cmd_vel'][1] == jazzy.hash_rihs01('geometry_msgs/msg/Twist')


def ours_float(value):
    """Return a std_msgs/Float64 of the monitor's own store."""
    return bags.MONITOR_TYPESTORE.types[WEAR_TYPE](data=value)
