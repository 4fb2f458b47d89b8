"""Tests of the message mapping with the rosbags Jazzy typestore (round trips through CDR)."""

import math

import numpy as np
import pytest
from robot_wear_monitor.recordings import messages
from robot_wear_monitor.recordings.messages import MessageError
from rosbags.typesys import get_typestore, Stores

TYPESTORE = get_typestore(Stores.ROS2_JAZZY)
KIT = messages.rosbags_kit(TYPESTORE)


def _roundtrip(msg):
    raw = TYPESTORE.serialize_cdr(msg, msg.__msgtype__)
    return TYPESTORE.deserialize_cdr(raw, msg.__msgtype__)


def test_friction_levels_round_trip_through_cdr():
    msg = messages.friction_levels_to_msg(KIT, stamp_s=1704067200.123456789, joint='joint_2',
                                          speeds_rad_s=[2.1, 28.5, 35.1, 41.7],
                                          frictions=[0.13, 0.06, 0.055, 0.058])
    back = messages.friction_levels_from_msg(_roundtrip(msg))
    assert back.joint == 'joint_2'
    assert back.speeds_rad_s == (2.1, 28.5, 35.1, 41.7)
    assert back.frictions == (0.13, 0.06, 0.055, 0.058)
    assert abs(back.stamp_s - 1704067200.123456789) < 1e-6
    decoded = _roundtrip(msg)
    assert list(decoded.name) == ['joint_2/level_0', 'joint_2/level_1', 'joint_2/level_2',
                                  'joint_2/level_3']
    assert decoded.position.size == 0


@pytest.mark.parametrize('velocity, effort, names, reason', [
    ([], [], [], 'empty'),
    ([2.1, 28.5], [0.1], [], 'length_mismatch'),
    ([2.1], [0.1], ['a', 'b'], 'length_mismatch'),
    ([2.1, float('nan')], [0.1, 0.2], [], 'not_finite'),
    ([2.1, 0.0], [0.1, 0.2], [], 'non_positive_speed'),
])
def test_bad_friction_levels_are_rejected_with_a_reason(velocity, effort, names, reason):
    msg = KIT.make('sensor_msgs/msg/JointState',
                   header=messages.make_header(KIT, stamp_s=1.0, frame_id='j'), name=names,
                   position=KIT.float_array([]), velocity=KIT.float_array(velocity),
                   effort=KIT.float_array(effort))
    with pytest.raises(MessageError) as caught:
        messages.friction_levels_from_msg(msg)
    assert caught.value.reason == reason


def test_estimator_outputs_round_trip():
    temperature = _roundtrip(messages.temperature_to_msg(
        KIT, stamp_s=12.5, frame_id='joint_2', temperature_degc=41.2, variance_degc2=9.0))
    assert (temperature.temperature, temperature.variance) == (41.2, 9.0)
    assert (temperature.header.stamp.sec, temperature.header.stamp.nanosec) == (12, 500000000)
    unknown = messages.temperature_to_msg(KIT, stamp_s=0.0, frame_id='', temperature_degc=40.0,
                                          variance_degc2=float('nan'))
    assert unknown.variance == 0.0
    assert _roundtrip(messages.wear_to_msg(KIT, wear=36.5)).data == 36.5
    assert _roundtrip(messages.alarm_to_msg(KIT, active=True)).data is True
    array = _roundtrip(messages.diagnostics_to_msg(
        KIT, stamp_s=3.0, name='wear_monitor: joint_2', hardware_id='joint_2',
        level=messages.DIAGNOSTIC_ERROR, message='alarm', values=[('wear', '36.5')]))
    assert messages.diagnostics_from_msg(array) == [
        (2, 'wear_monitor: joint_2', 'alarm', {'wear': '36.5'})]


def test_rclpy_kit_conventions():
    made = {}

    def get_type(name):
        return lambda **fields: made.setdefault(name, fields)

    kit = messages.rclpy_kit(get_type)
    messages.diagnostics_to_msg(kit, stamp_s=1.0, name='n', hardware_id='h',
                                level=messages.DIAGNOSTIC_WARN, message='m', values=[])
    assert made['diagnostic_msgs/msg/DiagnosticStatus']['level'] == b'\x01'
    assert messages.level_to_int(b'\x02') == 2 and messages.level_to_int(2) == 2
    messages.friction_levels_to_msg(kit, stamp_s=1.0, joint='j', speeds_rad_s=np.array([1.0]),
                                    frictions=np.array([0.1]))
    assert made['sensor_msgs/msg/JointState']['velocity'] == [1.0]
    assert type(made['sensor_msgs/msg/JointState']['velocity'][0]) is float


def test_split_stamp_carries_nanoseconds():
    assert messages.split_stamp(1.9999999999) == (2, 0)
    sec, nanosec = messages.split_stamp(-0.25)
    assert (sec, nanosec) == (-1, 750000000)
    assert math.isclose(messages.stamp_to_nanoseconds(1.5), 1_500_000_000)
