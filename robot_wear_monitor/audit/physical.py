"""
Fitted friction terms that no friction can have: a negative Coulomb, Stribeck or viscous term.

The models mean their Coulomb level, Stribeck amplitude and viscous slope to be >= 0 (eq. (4):
F_c, F_s, F_v >= 0; in (5) and (8) the same terms at the data's load and temperature, and the
wear terms of (7) for w >= 0).  A fit that makes one negative matches the data's shape with a
model that is no friction (a torque offset, a missing direction, a sign convention, terms that
trade against each other); the audit reports each such value, as ``identify`` reports values
on a bound.
"""

from __future__ import annotations

import math
from typing import Any, Mapping

import numpy as np
from robot_wear_monitor.audit.fitting import AuditTable

#: The speed model's terms that are >= 0, and what they are.
SPEED_TERMS = (('F_c', 'Coulomb level'), ('F_s', 'Stribeck rise'),
               ('F_v', 'viscous slope'))


def _ends(table: AuditTable, column: str) -> tuple[float, ...]:
    """Return the lowest and highest value of a column (one value when constant)."""
    values = table.numeric[column]
    low, high = float(np.min(values)), float(np.max(values))
    return (low,) if low == high else (low, high)


def impossible_values(model: str, described: Mapping[str, Mapping[str, Any]],
                      table: AuditTable) -> list[dict]:
    """
    Return the fitted terms with a sign friction cannot have, one dict each.

    :param model: 'speed', 'nominal' or 'complete'.
    :param described: group -> parameter name -> value (the base model's ``describe``).
    :param table: the levels fitted (their load and temperature range).
    :return: dicts {'group', 'parameter', 'value', 'meaning', 'where'}: ``parameter`` names
        the fitted parameter or the expression evaluated, ``where`` the conditions ('' for a
        parameter of its own).

    """
    out: list[dict] = []

    def flag(group: str, parameter: str, value: float, meaning: str, where: str = '') -> None:
        if math.isfinite(value) and value < 0:
            out.append({'group': group, 'parameter': parameter, 'value': float(value),
                        'meaning': meaning, 'where': where})

    for group, values in described.items():
        if model == 'speed':
            for name, meaning in SPEED_TERMS:
                flag(group, name, float(values[name]), meaning)
            continue
        loads, temperatures = _ends(table, 'load'), _ends(table, 'temperature')
        for load in loads:
            flag(group, 'f_c0 + f_c_load tau_l', values['f_c0'] + values['f_c_load'] * load,
                 'Coulomb level', f'at load {load:.4g}')
        if max(loads) > 0:
            flag(group, 'f_s_load', float(values['f_s_load']), 'load Stribeck amplitude')
        for temp in temperatures:
            at = f'at {temp:.4g} degC'
            flag(group, 'f_s0 + f_s_temp T', values['f_s0'] + values['f_s_temp'] * temp,
                 'temperature Stribeck amplitude', at)
            slope = values['f_v0'] + values['f_v_temp'] * math.exp(-temp / values['t_v0'])
            flag(group, 'f_v0 + f_v_temp exp(-T/t_v0)', slope, 'viscous slope', at)
        if model == 'complete':
            flag(group, 'f_s_wear', float(values['f_s_wear']), 'wear Stribeck amplitude')
            flag(group, 'f_v_wear', float(values['f_v_wear']), 'wear viscous slope')
    return out


def flag_text(entry: Mapping[str, Any], several_groups: bool) -> str:
    """Return one impossible value as the audit's FLAG sentence."""
    where = f' ({entry["group"]})' if several_groups else ''
    at = f' {entry["where"]}' if entry['where'] else ''
    return (f'{entry["parameter"]}{where} = {entry["value"]:.4g}{at} < 0: a negative '
            f'{entry["meaning"]} is no friction (check the sign convention, a direction effect '
            'or a torque offset)')
