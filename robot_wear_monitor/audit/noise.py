"""The noise floor: the std of the level error that no model of the table's columns removes.

Compared with the held-out error, it tells whether structure is left (held-out error well above
the floor) or the model is as good as the data allow.
"""

from __future__ import annotations

import math
from typing import Sequence

import numpy as np
from numpy.typing import NDArray
from scipy import spatial

from robot_wear_monitor.audit.fitting import as_text, AuditTable

FloatArray = NDArray[np.float64]


def noise_floor(*, table: AuditTable, residual: FloatArray, n_parameters: int,
                variables: Sequence[str]) -> tuple[float, str]:
    """Estimate the std of the level-to-level error that no model of these columns removes.

    1. ``replicates``: rows that agree in every column except the friction ones repeat one
       condition; the pooled within-group std of friction is model-free (used when they give
       at least 10 degrees of freedom and 10 % of the rows).
    2. ``nearest neighbour``: otherwise, half the mean squared difference of the final residuals
       between each level and its nearest neighbour in the space of all variables (each scaled
       to [0, 1], categories kept apart), corrected for the fitted parameters.  Structure the
       model missed is largely differenced out between neighbours.

    Returns (noise floor in friction units, method).
    """
    y = table.numeric['friction']
    n = len(y)
    keys = [k for k in table.columns if k not in ('friction', 'friction_std_error')]
    matrix = np.column_stack(
        [table.numeric[k] if k in table.numeric else
         np.unique(table.text[k], return_inverse=True)[1].astype(float) for k in keys])
    _, inverse, counts = np.unique(matrix, axis=0, return_inverse=True, return_counts=True)
    inverse = inverse.ravel()
    dof = int(np.sum(counts - 1))
    if dof >= max(10, n // 10):
        means = np.bincount(inverse, weights=y) / counts
        within = float(np.sum((y - means[inverse]) ** 2))
        return math.sqrt(within / dof), f'replicates ({dof} degrees of freedom)'
    cols = []
    for k in variables:
        if k in table.text or (k in table.numeric and len(np.unique(table.numeric[k])) <= 8):
            codes = np.unique(as_text(table, k), return_inverse=True)[1]
            cols.append(codes * 100.0)
        elif k in table.numeric:
            x = table.numeric[k]
            if k == 'speed':
                x = np.log(x)
            span = float(x.max() - x.min())
            cols.append((x - x.min()) / span if span > 0 else np.zeros(n))
    points = np.column_stack(cols) if cols else np.zeros((n, 1))
    points = points + 1e-9 * np.arange(n)[:, None]  # break exact ties deterministically
    _, index = spatial.cKDTree(points).query(points, k=2)
    diff = residual - residual[index[:, 1]]
    correction = n / max(n - n_parameters, 1)
    return math.sqrt(0.5 * float(np.mean(diff ** 2)) * correction), 'nearest neighbour'
