"""
Time to identify the nominal model (5) on 500 and on 50 000 friction levels (prints only).

The levels come from the packaged set's model (5) at the 12 speeds of eq. (27), one temperature
and load per experiment, plus N(0, 4.23e-3) noise.  ``identify`` = the multi-start variable
projection fit, the standard errors and the 5-fold held-out error by experiment.
"""

import time

import numpy as np
from robot_wear_monitor.audit.fitting import AuditTable
from robot_wear_monitor.audit.identification import identify_nominal
from robot_wear_monitor.model.friction import nominal_friction
from robot_wear_monitor.model.params import load_parameter_set

GRID = np.array([2.1, 8.7, 15.3, 21.9, 28.5, 35.1, 41.7, 82.2, 133.5, 184.7, 236.2, 287.1])


def levels(n_levels: int, seed: int = 0) -> AuditTable:
    """Return about n simulated baseline friction levels, whole experiments of 12 speeds."""
    params = load_parameter_set()
    rng = np.random.default_rng(seed)
    n_experiments = -(-n_levels // GRID.size)
    experiment = np.repeat(np.arange(n_experiments), GRID.size).astype(float)
    temperature = np.repeat(rng.uniform(30, 50, n_experiments), GRID.size)
    load = np.repeat(rng.uniform(0.1, 0.9, n_experiments), GRID.size)
    speed = np.tile(GRID, n_experiments)
    friction = nominal_friction(speed, load, temperature, params.model)
    friction = friction + rng.normal(0, 4.23e-3, speed.size)
    columns = {'speed': speed, 'friction': friction, 'temperature': temperature, 'load': load,
               'experiment': experiment}
    return AuditTable({k: v[:n_levels] for k, v in columns.items()}, {}, 'bench')


def main() -> None:
    """Identify (5) on 500 and 50 000 levels; print the time and the held-out error."""
    start_model = load_parameter_set().model
    for n in (500, 50_000):
        table = levels(n)
        runs = 5 if n <= 1000 else 1
        start = time.perf_counter()
        for _ in range(runs):
            result = identify_nominal(table=table, start=start_model)
        elapsed = (time.perf_counter() - start) / runs
        print(f'{table.n_rows:>6} levels: identify (5) in {elapsed:.3f} s '
              f'({result.starts} starts ranked, held-out sigma {result.held_out_std:.3e})')


if __name__ == '__main__':
    main()
