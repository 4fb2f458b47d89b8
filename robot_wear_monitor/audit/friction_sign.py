"""
The refusal of a speed model (4) whose friction is negative or zero where it was measured.

Friction opposes the motion: the levels of eq. (3) are positive.  A fit of model (4) (F_c,
F_s, F_v >= 0) to levels whose friction is negative comes out all zero (or negative where a
term is free to be); a set written from it would monitor nothing.  The likely cause is the
sign of the torque: :func:`check_speed_fit_friction` says so, and what to do.
"""

from __future__ import annotations

import math
from typing import Mapping

import numpy as np
from robot_wear_monitor.audit.fitting import AuditTable
from robot_wear_monitor.errors import InputError
from robot_wear_monitor.experiment.levels import against_the_motion

#: A fitted friction within this fraction of the levels' largest |friction| counts as zero.
ZERO_FRACTION = 1e-6


def speed_model_friction(values: Mapping[str, float], speed: np.ndarray) -> np.ndarray:
    """Return model (4) at ``speed``: F_c + F_s exp(-|v/phi_s|^alpha) + F_v |v| (table's unit)."""
    v = np.abs(np.asarray(speed, dtype=float))
    phi, alpha = values['phi_s'], values['alpha']
    decay = np.exp(-np.abs(v / phi) ** alpha) if phi > 0 else np.zeros_like(v)
    return values['F_c'] + values['F_s'] * decay + values['F_v'] * v


def check_speed_fit_friction(values: Mapping[str, float], table: AuditTable) -> None:
    """
    Raise InputError when model (4) with ``values`` is negative or all zero at the levels.

    :param values: the fitted F_c, F_s, phi_s, alpha, F_v (the table's units).
    :param table: the levels fitted (speed, friction).
    :raises InputError: naming the likely cause (the torque's sign) and what to do.

    """
    speed = table.numeric['speed']
    fitted = speed_model_friction(values, speed)
    friction = table.numeric['friction']
    scale = float(np.max(np.abs(friction))) if friction.size else 0.0
    zero = ZERO_FRACTION * scale if scale > 0 else 0.0
    negative = bool(np.any(fitted < -zero))
    if not negative and float(np.max(fitted)) > zero and all(
            math.isfinite(float(x)) for x in fitted):
        return
    against, median = against_the_motion(friction)
    what = 'negative' if negative else 'zero at every measured speed'
    sign = 'negative' if against else 'not positive'
    raise InputError(
        f'{table.source}: the speed model (4) fitted is {what} '
        f'({float(np.min(fitted)):.4g} to {float(np.max(fitted)):.4g} at speeds '
        f'{float(np.min(speed)):.4g}-{float(np.max(speed)):.4g}); no set is written.  Friction '
        f"opposes the motion, but the levels' friction is {sign} (median {median:.4g}): the "
        'likely cause is the sign of the torque (raw runs read with --raw-sign keep a torque '
        'recorded against the motion: drop --raw-sign and the data decide; a level table '
        "whose friction column has the torque's sign: negate it, or give signed speeds, "
        'which are folded)')
