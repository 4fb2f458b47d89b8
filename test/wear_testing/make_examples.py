"""
Write the example level tables under ``examples/``.

Run: ``PYTHONPATH=test python3 -m wear_testing.make_examples``.

The tables come from the independent generator's model functions (``independent_robot.py``,
which shares no code with the package) for a joint that differs from the packaged set, with
its truth, so that ``identify`` and ``audit --model nominal`` have something to run on as the
README shows.  ``test/test_examples.py`` checks that the shipped files are what this writes.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
from wear_testing import independent_robot as robot

EXAMPLES = Path(__file__).resolve().parents[2] / 'examples'
#: Motor-side speeds of every experiment [rad/s]: Table V's grid and beyond.
GRID = (2.1, 8.7, 15.3, 21.9, 28.5, 35.1, 41.7, 82.2, 133.5, 184.7, 236.2, 287.1)
#: The example joint: the paper's coefficients with a stronger load effect and wear profile.
JOINT = {**robot.PAPER_PARAMETERS, 'F_ctl': 0.05, 'F_stl': 0.2, 'phi_stl': 12.0,
         'F_sw': 1.1e-3, 'phi_sw': 2.6}
#: std of the friction-level error [normalised torque].
SIGMA = 4.23e-3
#: The critical experiment of the wear test (w = 35 there).
CRITICAL = 15


def _table(*, seed: int, wears: np.ndarray, temperature: tuple[float, float],
           loads: tuple[float, float]) -> str:
    rng = np.random.default_rng(seed)
    speeds = np.asarray(GRID)
    lines = ['experiment,speed,friction,temperature,load,true_wear']
    for k, wear in enumerate(wears):
        t, load = rng.uniform(*temperature), rng.uniform(*loads)
        friction = robot.friction_model(speeds, load, t, wear, JOINT) + rng.normal(
            0.0, SIGMA, speeds.size)
        lines += [f'{k},{v:g},{f:.6f},{t:.3f},{load:.4f},{wear:.3f}'
                  for v, f in zip(speeds, friction)]
    return '\n'.join(lines) + '\n'


def example_files() -> dict[str, str]:
    """Return the example files' names and texts (deterministic)."""
    wears = 35.0 * (np.arange(20) / CRITICAL) ** 2
    truth = ['# The truth of the example tables (test/wear_testing/make_examples.py, '
             'independent generator).',
             '# Friction model (8) = (5) + (7) with these coefficients (paper notation):']
    truth += [f'{name}: {value:g}' for name, value in JOINT.items()]
    truth += [f'sigma: {SIGMA:g}   # std of the friction-level error [normalised]',
              f'critical_experiment: {CRITICAL}   # w = 35 in wear_test.csv',
              'wear_per_experiment: [' + ', '.join(f'{w:.3f}' for w in wears) + ']']
    return {
        'baseline.csv': _table(seed=0, wears=np.zeros(30), temperature=(30.0, 50.0),
                               loads=(0.1, 0.9)),
        'wear_test.csv': _table(seed=1, wears=wears, temperature=(38.0, 42.0),
                                loads=(0.45, 0.55)),
        'truth.yaml': '\n'.join(truth) + '\n',
    }


#: The raw runs of ``examples/arm_runs/``: 8 joint speeds [rad/s] (gear ratio 100).
ARM_SPEEDS_RAD_S = tuple(float(v) for v in np.round(np.linspace(0.35, 1.05, 8), 4))
#: Every how many sweeps of a heat-up session a run is kept, and each visit's length [s].
ARM_EVERY_SWEEP, ARM_VISIT_S = 6, 16.0
#: The identification sessions (payload, room degC, warm degC) and the held-out session.
ARM_SESSIONS = ((False, 21.0, 44.0), (True, 22.0, 43.0), (False, 24.0, 45.0),
                (True, 23.0, 42.0))
ARM_MONITOR = (False, 22.0, 44.0)


def _arm_run_text(log: dict, rows: np.ndarray) -> str:
    """Return one raw run: t, q, dq, the motor current (the reader's effort column)."""
    lines = ['t_s,q_rad,dq_rad_s,tau_measured_Nm,temperature_degc,load_a']
    columns = [log[k][rows] for k in ('t_s', 'q_rad', 'dq_rad_s', 'current_a',
                                      'temperature_degc', 'load_a')]
    lines += [f'{t:.3f},{q:.4f},{dq:.4f},{i:.4f},{temp:.0f},{load:.3f}'
              for t, q, dq, i, temp, load in zip(*columns)]
    return '\n'.join(lines) + '\n'


def arm_run_files() -> dict[str, str]:
    """
    Return the 2 Hz raw runs of ``examples/arm_runs/`` (names and texts, deterministic).

    A lab's record of a 6-axis arm's joint (:mod:`wear_testing.real_arm_logger`, independent
    of the package): heat-up sessions with and without a payload, one sweep over the 8 speeds
    kept every ``ARM_EVERY_SWEEP`` sweeps as a run ``run_<session><k>.csv``; the held-out
    session's first and a late sweep as ``monitor_cold.csv`` and ``monitor_warm.csv``.
    Columns: time [s], joint position [rad], joint speed [rad/s], the motor current [A] (in
    the raw-run reader's effort column ``tau_measured_Nm``), the controller's temperature
    reading [degC, whole degrees] and the gravity current (load) [A].
    """
    from wear_testing import real_arm_logger as arm
    files = {}
    for index, (payload, room, warm) in enumerate(ARM_SESSIONS + (ARM_MONITOR,)):
        session = arm.Session(payload=payload, room_degc=room, warm_degc=warm,
                              duration_s=3600.0)
        log = arm.log_session(session, seed=500 + index, visit_s=ARM_VISIT_S,
                              speeds=ARM_SPEEDS_RAD_S, session_index=index)
        sweeps = np.unique(log['sweep'])[:-1]  # the last sweep may be cut short
        if index == len(ARM_SESSIONS):
            names = {int(sweeps[0]): 'monitor_cold.csv', int(sweeps[-1]): 'monitor_warm.csv'}
        else:
            names = {int(k): f'run_{index + 1}{j + 1}.csv'
                     for j, k in enumerate(sweeps[::ARM_EVERY_SWEEP])}
        for sweep, name in names.items():
            files[f'arm_runs/{name}'] = _arm_run_text(log, log['sweep'] == sweep)
    return files


def main() -> None:
    """Write the files under ``examples/``."""
    (EXAMPLES / 'arm_runs').mkdir(parents=True, exist_ok=True)
    for name, text in {**example_files(), **arm_run_files()}.items():
        (EXAMPLES / name).write_text(text, encoding='utf-8')


if __name__ == '__main__':
    main()
