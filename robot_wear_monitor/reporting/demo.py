"""
The demo: simulate an accelerated wear test, replay it through the service, write a report.

``robot-wear-monitor demo`` needs no arguments and no data: it simulates about a hundred
friction experiments of joint 2 (Table V's N = 4 speeds) with wear rising past 35 at the end and
temperature and load varying as in the paper's Sec. V, writes them as a ROS 2 bag with the truth
beside it, replays the bag through the same service the nodes run and writes into one folder:
``scenario_bag/`` (+ ``scenario_bag.truth.json``), ``monitor_bag/`` (every node output),
``summary.json``, ``wear_trend.png``, ``friction_curves.png`` and ``report.md``.
"""

from __future__ import annotations

import os
from pathlib import Path
import shutil
import time
from typing import Any, Callable, Optional

from robot_wear_monitor.atomic_files import write_json_atomic
from robot_wear_monitor.errors import InputError
from robot_wear_monitor.experiment.simulation import (accelerated_wear_scenario, simulate_scenario,
                                                      truth_path_for, write_truth_json)
from robot_wear_monitor.model.params import load_parameter_set
from robot_wear_monitor.monitoring.monitor_config import MonitorConfig
from robot_wear_monitor.monitoring.replay import replay_bag
from robot_wear_monitor.recordings.bags import write_joint_state_bag
from robot_wear_monitor.reporting.replay_report import (plot_friction_curves, plot_wear_trend,
                                                        write_report)


def run_demo(*, out_dir: str | os.PathLike = 'wear_demo', n_experiments: int = 100,
             seed: int = 0, progress: bool = False,
             log: Callable[[str], Any] = lambda text: None) -> dict[str, Any]:
    """
    Run the demo into ``out_dir`` (replacing the demo files there); return the summary.

    :raises InputError: ``out_dir`` exists and is not a folder, or a step fails with bad input.

    """
    started = time.perf_counter()
    folder = Path(out_dir)
    if folder.exists() and not folder.is_dir():
        raise InputError(f'{folder}: exists and is not a folder')
    folder.mkdir(parents=True, exist_ok=True)
    scenario_bag = folder / 'scenario_bag'
    monitor_bag = folder / 'monitor_bag'
    history = folder / 'wear_history.sqlite3'
    for old in (scenario_bag, monitor_bag):
        if old.exists():
            shutil.rmtree(old)
    for suffix in ('', '-wal', '-shm'):
        Path(f'{history}{suffix}').unlink(missing_ok=True)

    log(f'simulating {n_experiments} friction experiments (seed {seed}) ...')
    config = accelerated_wear_scenario(n_experiments=n_experiments, seed=seed)
    scenario = simulate_scenario(config=config, seed=seed)
    write_joint_state_bag(scenario_bag, stamps_s=scenario.time_s, names=scenario.joint_names,
                          position=scenario.position_rad, velocity=scenario.velocity_rad_s,
                          effort=scenario.effort, name_order=scenario.name_order)
    write_truth_json(truth_path_for(scenario_bag), scenario)
    log(f'wrote {scenario.n_samples} JointState messages to {scenario_bag}')

    joint = scenario.config
    configuration = MonitorConfig.load(
        joint=joint.joint, gear_ratio=joint.gear_ratio,
        torque_scale=joint.torque_scale).with_experiment_speeds(config.speeds_rad_s)
    log('replaying it through the monitoring service ...')
    result = replay_bag(scenario_bag, out_bag=monitor_bag, configuration=configuration,
                        progress=progress, truth=scenario.truth, history_file=history)
    threshold = configuration.alarm_policy().threshold
    summary = result.summary()
    truth_crossing = next((t.k for t in scenario.truth if t.wear >= threshold), None)
    summary['truth_first_k_at_threshold'] = truth_crossing
    summary['seed'] = seed
    write_json_atomic(folder / 'summary.json', summary)
    params = load_parameter_set(configuration.parameter_set_file())
    plot_wear_trend(result, folder / 'wear_trend.png', threshold=threshold,
                    title='Wear estimate vs truth, accelerated wear test (like Fig. 11)')
    plot_friction_curves(result, folder / 'friction_curves.png', params=params,
                         threshold=threshold)
    elapsed = time.perf_counter() - started
    extra = (f'{n_experiments} simulated friction experiments of {joint.joint} at '
             f'{", ".join(f"{v:g}" for v in config.speeds_rad_s)} rad/s (Table V, N = 4), '
             f'temperature 30-50 degC and load 0.5 (std 0.1) varying per experiment (Sec. V); '
             f'{scenario.n_samples} JointState messages at {joint.sample_rate_hz:g} Hz, '
             f'replayed through the monitoring service.  Bags: `scenario_bag/` (input, '
             f'truth in `scenario_bag.truth.json`) and `monitor_bag/` (every node output).')
    write_report(result, folder, threshold=threshold,
                 figures={'Wear estimate with its 95 % interval and the wear trend with its '
                          '95 % interval, against the truth, threshold and alarm':
                          'wear_trend.png',
                          'Friction levels of every experiment': 'friction_curves.png'},
                 extra=extra, elapsed_s=elapsed)
    summary['elapsed_s'] = elapsed
    return summary


def describe(summary: dict[str, Any], folder: str | os.PathLike) -> str:
    """Return the few lines the CLI prints after the demo."""
    first: Optional[dict] = summary.get('first_alarm')
    alarm = ('no alarm' if first is None else
             f'alarm at experiment {first["index"]} (w-hat {first["wear"]:.1f})')
    crossing = summary.get('truth_first_k_at_threshold')
    truth = '' if crossing is None else f'; true wear reaches the threshold at experiment ' \
                                        f'{crossing + 1}'
    return (f'{len(summary["experiments"])} experiments, {alarm}{truth}.\n'
            f'report: {Path(folder) / "report.md"} (figures, summary.json and bags beside it)')
