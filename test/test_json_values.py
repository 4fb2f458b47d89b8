"""The one JSON-number helper: finite floats pass, NaN and inf become null, numpy goes Python."""

import json
import math

import numpy as np
from robot_wear_monitor.json_values import finite_or_none, json_clean


def test_finite_or_none():
    assert finite_or_none(1.5) == 1.5 and isinstance(finite_or_none(np.float32(2.0)), float)
    assert [finite_or_none(v) for v in (math.nan, math.inf, -math.inf, None)] == [None] * 4


def test_json_clean_gives_what_strict_json_accepts():
    value = {1: np.array([1.0, np.nan]), 'b': (np.int64(3), [np.float64(np.inf), 'x', True])}
    clean = json_clean(value)
    assert clean == {'1': [1.0, None], 'b': [3, [None, 'x', True]]}
    assert json.loads(json.dumps(clean, allow_nan=False)) == clean
