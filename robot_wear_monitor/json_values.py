"""
Numbers for JSON: a float that is finite, or null (JSON has no NaN or infinity).

The one place the package turns floats (and numpy values) into what ``json.dumps(...,
allow_nan=False)`` accepts: :func:`finite_or_none` for one number, :func:`json_clean` for a
nested structure of dicts, lists, tuples, numpy arrays and scalars.
"""

from __future__ import annotations

import math
from typing import Any, Optional


def finite_or_none(value: Optional[float]) -> Optional[float]:
    """Return ``value`` as a float when it is finite; None (JSON null) for None, NaN or inf."""
    if value is None:
        return None
    value = float(value)
    return value if math.isfinite(value) else None


def json_clean(value: Any) -> Any:
    """
    Return ``value`` with every float finite or None, numpy values as Python ones.

    Dict keys become strings; lists, tuples and numpy arrays become lists; numpy integers
    become ints; anything else is returned as it is.
    """
    # numpy is imported here, not with the module: the wear history (which the command line's
    # parser reaches for the dashboard's user roles) uses finite_or_none only, and the command
    # line must not load numpy before it has set one OpenBLAS thread (blas_threads.py)
    # deferred import: start-up time (numpy: the command line's parser reaches this module)
    import numpy as np
    return _clean(value, np)


def _clean(value: Any, np: Any) -> Any:
    if isinstance(value, dict):
        return {str(k): _clean(v, np) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_clean(v, np) for v in value]
    if isinstance(value, np.ndarray):
        return _clean(value.tolist(), np)
    if isinstance(value, (float, np.floating)):
        return finite_or_none(float(value))
    if isinstance(value, np.integer):
        return int(value)
    return value
