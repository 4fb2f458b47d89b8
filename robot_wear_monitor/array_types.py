"""
The package's array type aliases, for annotations: one definition each.

``FloatArray``: a numpy array of float64 (the unit and shape are in each docstring).
"""

import numpy as np
from numpy.typing import NDArray

#: a numpy array of float64 values
FloatArray = NDArray[np.float64]
