"""
The estimator's starting grids: equidistant in the arc length of the whitened model.

Shared by the N >= 2 estimate (:mod:`.estimator`, its batched form :mod:`.batch`) and the
N = 1 marginal estimate (:mod:`.single_level`).
"""

import numpy as np
from robot_wear_monitor.array_types import FloatArray

# Starting grids: equidistant in the whitened model (steps of at most GRID_SPACING_SIGMA noise
# standard deviations) and at most the given steps of T [degC] and w [-].
GRID_SPACING_SIGMA = 0.5
GRID_MAX_STEP_DEGC = 2.0
GRID_MAX_STEP_WEAR = 2.0
GRID_MAX_POINTS = 400  # per axis (a very small sigma would ask for more)
# samples of the model curve whose arc length places the grid (2.5 per grid point at the most)
ARC_SAMPLES = 1001


def arc_length_grid(curve, lower: float, upper: float, *, spacing: float,
                    max_step: float) -> FloatArray:
    """
    Return a grid on [lower, upper] whose image under ``curve`` has steps <= ``spacing``.

    ``curve(x)`` (shape (K,) -> (K, N)) is the whitened model along one parameter; the grid is
    equidistant in the arc length of the curve, so that every model point is within about
    spacing/2 noise standard deviations of a grid point however steep the model is.  Steps in
    the parameter are also at most ``max_step``.
    """
    fine = np.linspace(lower, upper, ARC_SAMPLES)
    points = curve(fine)
    arc = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(points, axis=0), axis=1))])
    arc = arc + (fine - lower) * (spacing / max_step)  # the parameter step bound
    count = min(int(np.ceil(arc[-1] / spacing)) + 1, GRID_MAX_POINTS)
    return np.interp(np.linspace(0.0, arc[-1], max(count, 2)), arc, fine)
