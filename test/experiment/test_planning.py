"""
Tests of the friction-experiment planner (experiment/planning.py) and ``plan``.

The motion is checked by finite differences of densely sampled points and by executing the
trajectory *points* (what a controller receives) with a controller written here: a cubic
Hermite spline through positions and velocities (scipy), sampled at the JointState rate with
this file's own noise, friction from ``independent_robot.friction_model`` (written without the
package), gravity and inertia.  The package's segmentation must then accept every planned
speed, and the scatter of the levels over repeated runs must meet the target standard error.
"""

import csv
import json

import numpy as np
import pytest
from robot_wear_monitor import cli
from robot_wear_monitor.errors import InputError
from robot_wear_monitor.experiment.planning import (plan_experiment, plan_summary, PlanConfig,
                                                    PLATEAU, trajectory_points)
from robot_wear_monitor.experiment.segmentation import segment_batch, SegmenterConfig
from robot_wear_monitor.experiment.simulation import (experiment_trajectory, JointSimConfig,
                                                      plan_config_for)
from robot_wear_monitor.recordings.bags import TYPESTORE
from robot_wear_monitor.recordings.messages import trajectory_from_msg
from rosbags.rosbag2 import Reader
from scipy.interpolate import CubicHermiteSpline
from wear_testing import independent_robot as robot
import yaml

SPEEDS = (2.1, 28.5, 35.1, 41.7)
IRB = {'joint': 'joint_2', 'speeds_rad_s': SPEEDS, 'center_rad': 0.2, 'half_range_rad': 0.5,
       'gear_ratio': 150.0, 'max_acceleration_rad_s2': 10.0}


def _dense(plan, rate_hz=20_000.0):
    t = np.arange(0.0, plan.total_s, 1.0 / rate_hz)
    q, v, a, index = plan.sample(t)
    return t, q, v, a, index


@pytest.mark.parametrize('jerk', [None, 150.0])
def test_motion_respects_speed_acceleration_jerk_and_position_limits(jerk):
    config = PlanConfig(**{**IRB, 'half_range_rad': 0.05}, max_jerk_rad_s3=jerk,
                        max_speed_rad_s=0.3, position_limits_rad=(0.1, 0.3))
    plan = plan_experiment(config=config)
    t, q, v, a, _ = _dense(plan)
    dt = t[1] - t[0]
    # the sampled state is consistent: v = dq/dt, a = dv/dt (finite differences)
    assert np.max(np.abs(np.gradient(q, dt)[1:-1] - v[1:-1])) < 1e-3
    assert np.max(np.abs(np.diff(q))) <= 0.3 * dt * 1.0001  # continuous position
    assert np.max(np.abs(v)) <= 0.3 + 1e-9
    assert np.max(np.abs(a)) <= 10.0 + 1e-9
    if jerk is not None:
        assert np.max(np.abs(np.diff(a))) <= jerk * dt * 1.0001  # continuous acceleration
    else:
        assert np.max(np.abs(np.diff(v))) <= 10.0 * dt * 1.0001
    assert 0.1 <= q.min() and q.max() <= 0.3
    assert q[0] == pytest.approx(0.2) and v[0] == 0.0
    end = plan.sample(plan.total_s)
    assert end[0] == pytest.approx(0.2, abs=1e-12) and end[1] == pytest.approx(0.0, abs=1e-12)


def test_each_speed_has_a_centred_plateau_of_the_needed_length_in_both_directions():
    config = PlanConfig(**IRB)
    plan = plan_experiment(config=config)
    t, q, v, _, index = _dense(plan)
    dt = t[1] - t[0]
    plateau = plan.kind[np.searchsorted(plan.start_s, t, side='right') - 1] == PLATEAU
    # M >= noise^2 / (2 E^2) = 0.01^2 / (2e-6) = 50 samples, plus 2 trims and 2 samples
    assert config.samples_per_pass == 50
    assert config.plateau_s == pytest.approx(54 / 250 + 0.04)
    for i, speed in enumerate(SPEEDS):
        joint_speed = speed / 150.0
        for sign in (1.0, -1.0):
            cruise = plateau & (index == i) & (np.abs(v - sign * joint_speed) < 1e-9)
            assert cruise.sum() * dt == pytest.approx(config.plateau_s, abs=2 * dt)
            low, high = q[cruise].min(), q[cruise].max()
            assert (low + high) / 2 == pytest.approx(0.2, abs=joint_speed * dt)
            assert high - low == pytest.approx(joint_speed * config.plateau_s, rel=1e-3)
    # a jerk limit makes the ramps longer, never the plateaus shorter
    jerky = plan_experiment(config=PlanConfig(**IRB, max_jerk_rad_s3=100.0))
    assert jerky.total_s > plan.total_s
    assert [s.plateau_s for s in jerky.speeds] == pytest.approx([s.plateau_s for s in
                                                                 plan.speeds])
    # every plateau phase runs one planned speed exactly, two per speed (forward, backward)
    phases = plan.kind == PLATEAU
    assert np.all(plan.acceleration_rad_s2[phases] == 0) and np.all(plan.jerk_rad_s3[phases] == 0)
    motor = np.abs(plan.velocity_rad_s[phases]) * 150.0
    assert sorted(np.round(motor, 9)) == sorted(2 * list(SPEEDS))


def test_experiment_is_as_short_as_the_constraints_allow():
    short = plan_summary(plan_experiment(config=PlanConfig(**IRB)))
    looser = plan_summary(plan_experiment(config=PlanConfig(**IRB, target_std_error=2e-3)))
    tighter = plan_summary(plan_experiment(config=PlanConfig(**IRB, target_std_error=5e-4)))
    assert looser['total_s'] == short['total_s'] < tighter['total_s']
    # at a loose target the segmentation's minimum (0.2 s = 50 samples, trims, margin) binds
    assert looser['samples_per_pass'] == 50 and looser['plateau_s'] == pytest.approx(0.256)
    assert tighter['samples_per_pass'] == 200
    # the paper spent 2.5 s per speed (Sec. IV-D); here about 1 s per speed at E = 0.001
    assert all(row['duration_s'] < 1.2 for row in short['per_speed'])


def _controller_execution(points, rate_hz, rng, *, wear=10.0, temperature=40.0, load=0.5,
                          noise=0.01, speed_noise=0.01, gear_ratio=150.0):
    """Follow the points like a controller, sample sensors at rate_hz (this file's own code)."""
    times = np.concatenate([[0.0], points.time_from_start_s])
    j = points.joint_names.index('joint_2')
    q = np.concatenate([[points.positions_rad[0, j]], points.positions_rad[:, j]])
    v = np.concatenate([[0.0], points.velocities_rad_s[:, j]])
    spline = CubicHermiteSpline(times, q, v)
    t = np.arange(0.0, times[-1], 1.0 / rate_hz)
    t = t + rng.normal(0.0, 0.02 / rate_hz, t.size)  # stamp jitter
    t.sort()
    position, velocity, accel = spline(t), spline(t, 1), spline(t, 2)
    motor = gear_ratio * velocity
    friction = np.where(np.abs(motor) > 1e-6,
                        np.sign(motor) * robot.friction_model(np.abs(motor) + 1e-12, load,
                                                              temperature, wear), 0.0)
    tau = (friction + 0.3 * np.sin(position + 0.4) + 1e-4 * gear_ratio * accel
           + rng.normal(0.0, noise, t.size))
    measured_v = velocity + rng.normal(0.0, speed_noise / gear_ratio, t.size)
    return t, position, measured_v, tau


def test_executed_plan_gives_every_level_with_the_target_standard_error():
    config = PlanConfig(**IRB)
    points = trajectory_points(plan_experiment(config=config), point_rate_hz=50.0)
    segmenter = SegmenterConfig(joint='joint_2', gear_ratio=150.0, torque_scale=1.0,
                                standstill_speed_rad_s=0.1, speed_tolerance_fraction=0.05,
                                speed_tolerance_rad_s=0.05, min_duration_s=0.2, trim_s=0.02,
                                min_samples=20, max_gap_s=0.05)
    rng = np.random.default_rng(5)
    levels = []
    for _ in range(120):
        t, q, v, tau = _controller_execution(points, 250.0, rng)
        result = segment_batch(time_s=t, position_rad=q, velocity_rad_s=v, effort=tau,
                               config=segmenter)
        found = sorted(result.levels, key=lambda level: level.speed_rad_s)
        assert [round(level.speed_rad_s, 1) for level in found] == list(SPEEDS)
        levels.append([level.friction for level in found])
    levels = np.asarray(levels)
    truth = robot.friction_model(np.asarray(SPEEDS), 0.5, 40.0, 10.0)
    assert np.all(np.abs(levels.mean(axis=0) - truth) < 5e-4)
    # the scatter of each level is the target standard error (1e-3), not more
    spread = levels.std(axis=0, ddof=1)
    assert np.all(spread < 1.3e-3), spread
    assert np.all(spread > 0.6e-3), spread


def test_simulator_executes_the_planned_trajectory():
    sim = JointSimConfig()
    q, v, a, index = experiment_trajectory(speeds_rad_s=SPEEDS, config=sim)
    plan = plan_experiment(config=plan_config_for(sim, SPEEDS))
    t = np.arange(q.size) / sim.sample_rate_hz
    expected = plan.sample(t)
    for got, want in zip((q, v, a, index), expected):
        assert np.array_equal(got, want)
    assert t[-1] <= plan.total_s < t[-1] + 1.0 / sim.sample_rate_hz
    # a plateau too long for the window at a fast speed is shortened, never refused
    fast = plan_experiment(config=plan_config_for(sim, (2.1, 287.1)))
    assert fast.speeds[1].plateau_s < fast.speeds[0].plateau_s
    assert fast.speeds[1].window_rad[1] - fast.speeds[1].window_rad[0] == pytest.approx(1.2)


def test_bad_plans_are_refused_with_the_numbers():
    with pytest.raises(InputError, match='wider than the window'):
        plan_experiment(config=PlanConfig(**{**IRB, 'half_range_rad': 0.01}))
    with pytest.raises(InputError, match='beyond its limits'):
        plan_experiment(config=PlanConfig(**{**IRB, 'max_acceleration_rad_s2': 0.05},
                                          position_limits_rad=(-0.3, 0.75)))
    with pytest.raises(InputError, match='outside the joint range'):
        PlanConfig(**IRB, position_limits_rad=(0.0, 0.5))
    with pytest.raises(InputError, match='above its limit'):
        PlanConfig(**IRB, max_speed_rad_s=0.1)
    with pytest.raises(InputError, match='max_acceleration_rad_s2'):
        PlanConfig(**{**IRB, 'max_acceleration_rad_s2': 0.0})
    with pytest.raises(InputError, match='speeds'):
        PlanConfig(**{**IRB, 'speeds_rad_s': (2.1, -3.0)})


PLAN_ARGS = ['plan', '--joint', 'joint_2', '--speeds', '2.1,28.5,35.1,41.7', '--center', '0.2',
             '--half-range', '0.5', '--gear-ratio', '150', '--max-acceleration', '10']


@pytest.mark.parametrize('change, message', [
    (['--speeds', '2.1,90', '--max-speed', '0.5'], 'above its limit'),
    (['--position-limits', '0.0,0.5'], 'outside the joint range'),
    (['--max-acceleration', '0'], 'max_acceleration_rad_s2'),
    (['--half-range', '0.001'], 'wider than the window'),
    (['--hold', 'joint_1'], '--hold'),
])
def test_cli_refuses_bad_input_with_one_line_and_exit_2(change, message, capsys):
    args = list(PLAN_ARGS)
    for flag, value in zip(change[::2], change[1::2]):
        if flag in args:
            args[args.index(flag) + 1] = value
        else:
            args += [flag, value]
    assert cli.main(args) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and message in err


def test_cli_writes_yaml_bag_and_csv_of_the_same_plan(tmp_path, capsys):
    hold = ['--hold', 'joint_1=0.1,joint_3=-0.4']
    assert cli.main(PLAN_ARGS + hold + ['--out', str(tmp_path / 'plan.yaml'), '--json']) == 0
    summary = json.loads(capsys.readouterr().out)
    assert summary['topic'] == '/joint_trajectory_controller/joint_trajectory'
    assert summary['total_s'] == pytest.approx(sum(r['duration_s'] for r in
                                                   summary['per_speed']), abs=1.0)
    data = yaml.safe_load((tmp_path / 'plan.yaml').read_text())
    assert data['joint_names'] == ['joint_2', 'joint_1', 'joint_3']
    assert len(data['points']) == summary['points']
    last = data['points'][-1]
    assert last['positions'] == pytest.approx([0.2, 0.1, -0.4])
    assert last['time_from_start']['sec'] + last['time_from_start']['nanosec'] * 1e-9 == \
        pytest.approx(summary['total_s'], abs=1e-6)
    assert all(p['positions'][1:] == [0.1, -0.4] for p in data['points'])

    assert cli.main(PLAN_ARGS + hold + ['--out', str(tmp_path / 'plan_bag'),
                                        '--controller', 'arm_controller']) == 0
    assert 'trajectory points written' in capsys.readouterr().out
    with Reader(tmp_path / 'plan_bag') as reader:
        rows = list(reader.messages())
    assert len(rows) == 1 and rows[0][0].topic == '/arm_controller/joint_trajectory'
    msg = trajectory_from_msg(TYPESTORE.deserialize_cdr(rows[0][2], rows[0][0].msgtype))
    assert msg['joint_names'] == data['joint_names']
    assert np.allclose(msg['positions'], [p['positions'] for p in data['points']])

    assert cli.main(PLAN_ARGS + ['--out', str(tmp_path / 'plan.csv')]) == 0
    with open(tmp_path / 'plan.csv', newline='') as handle:
        table = list(csv.DictReader(handle))
    speeds = np.abs([float(r['velocity_rad_s']) for r in table]) * 150.0
    for speed in (2.1, 28.5, 35.1, 41.7):
        assert np.sum(np.abs(speeds - speed) < 1e-6) >= 2 * 50  # both passes' plateaus
    assert float(table[1]['time_s']) == pytest.approx(1 / 250)


def test_cli_plans_the_designed_speeds(capsys):
    args = list(PLAN_ARGS)
    i = args.index('--speeds')
    del args[i:i + 2]
    assert cli.main(args + ['--n', '4', '--grid', '2.1,8.7,15.3,21.9,28.5,35.1,41.7',
                            '--json']) == 0
    assert json.loads(capsys.readouterr().out)['speeds_rad_s'] == list(SPEEDS)
