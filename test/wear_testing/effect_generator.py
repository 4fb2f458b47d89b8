"""
Friction levels of simulated experiments with one undeclared effect (test data generator).

Protocol of the paper's experiments, written here for the tests: each experiment runs the
discrete speeds of eq. (27) once at one operating point (temperature, load and the per-experiment
columns constant within it); the levels carry a Gaussian level error of std ``SIGMA`` (the model
error of (5), Sec. II-B1).  Friction values come from the model functions (the truth); the effect
is added on top.  Columns:

* ``speed`` [rad/s], ``friction``, ``temperature`` [degC], ``load``, ``experiment`` (its index,
  in time order), ``wear`` (with ``wear=True``);
* per experiment: ``humidity`` [%], ``supply_voltage`` [V], ``pressure`` [hPa] (never matters),
  ``oil_hours`` [h] (rises with the experiment index plus scatter: a decoy of drift),
  ``lubricant`` (text: A, B, C);
* per level: ``position`` [rad] (centre of the level's window), ``shift`` (never matters).
"""

import numpy as np
from robot_wear_monitor.model.friction import friction, nominal_friction
from robot_wear_monitor.model.params import load_parameter_set

PARAMS = load_parameter_set()
SPEEDS = np.array([2.1, 8.7, 15.3, 21.9, 28.5, 35.1, 41.7, 82.2, 133.5, 184.7, 236.2, 287.1])
SIGMA = 4.23e-3
DECOYS = ('pressure', 'shift', 'oil_hours')


def model_friction(columns: dict, params=PARAMS) -> np.ndarray:
    """Return the model's friction at the levels: (8) with a ``wear`` column, else (5)."""
    if 'wear' in columns:
        return friction(columns['speed'], columns['load'], columns['temperature'],
                        columns['wear'], params.model)
    return nominal_friction(columns['speed'], columns['load'], columns['temperature'],
                            params.model)


def levels(*, seed: int, n_experiments: int = 42, wear: bool = False,
           params=PARAMS) -> dict:
    """Return the columns of ``n_experiments`` x 12 friction levels without any effect."""
    rng = np.random.default_rng(seed)
    k = np.arange(n_experiments)
    e = np.repeat(k, SPEEDS.size)
    per_experiment = {
        'temperature': rng.uniform(30, 50, n_experiments),
        'load': rng.uniform(0.2, 0.8, n_experiments),
        'humidity': rng.uniform(20, 80, n_experiments),
        'supply_voltage': rng.normal(48, 1.5, n_experiments),
        'pressure': rng.normal(1000, 10, n_experiments),
        'oil_hours': 10.0 * k + rng.normal(0, 60.0, n_experiments),
    }
    if wear:
        per_experiment['wear'] = rng.uniform(0, 60, n_experiments)
    columns = {name: values[e] for name, values in per_experiment.items()}
    columns['lubricant'] = np.array(['A', 'B', 'C'])[rng.integers(0, 3, n_experiments)][e]
    columns['speed'] = np.tile(SPEEDS, n_experiments)
    columns['experiment'] = e.astype(float)
    columns['position'] = rng.uniform(-1.5, 1.5, e.size)
    columns['shift'] = rng.uniform(0, 100, e.size)
    clean = model_friction(columns, params)
    columns['clean'] = clean
    columns['friction'] = clean + rng.normal(0, SIGMA, clean.size)
    return columns


def with_effect(columns: dict, effect, size_sigma: float | None = None) -> dict:
    """
    Add ``effect(columns)`` to the friction; scaled to RMS ``size_sigma`` x SIGMA if given.

    The effect is centred (its mean over the table removed: a constant is no effect).
    """
    out = dict(columns)
    values = np.asarray(effect(columns), dtype=float)
    values = values - values.mean()
    if size_sigma is not None:
        values = values * size_sigma * SIGMA / np.sqrt(np.mean(values ** 2))
    out['friction'] = columns['friction'] + values
    out.pop('clean', None)
    return out


def _z(x):
    return (x - x.mean()) / x.std()


#: Effect kinds of the tests: name -> (effect of the columns, variables to be named).
EFFECTS = {
    'temperature offset (quadratic)': (
        lambda c: _z(c['temperature']) ** 2, {'temperature'}),
    'viscous slope varies with load': (lambda c: (c['load'] - 0.5) * c['speed'], {'load'}),
    'speed bump': (lambda c: np.exp(-np.log(c['speed'] / 30.0) ** 2 / 0.3), {'speed'}),
    'run-in: decays with wear (complete model)': (lambda c: np.exp(-c['wear'] / 8.0), {'wear'}),
    'drift over experiments': (lambda c: np.sqrt(c['experiment'] + 1.0), {'experiment'}),
    'torque constant varies with supply voltage': (
        lambda c: c['clean'] * _z(c['supply_voltage']), {'supply_voltage'}),
    'humidity x temperature': (
        lambda c: _z(c['humidity']) * _z(c['temperature']), {'humidity', 'temperature'}),
    'lubricant (categorical)': (
        lambda c: np.select([c['lubricant'] == 'B', c['lubricant'] == 'C'], [1.0, -0.8], 0.0),
        {'lubricant'}),
    'periodic in position': (lambda c: np.sin(2 * np.pi * c['position'] / 0.6), {'position'}),
}
