"""
Deprecated: the wear history moved to :mod:`robot_wear_monitor.history` (release 0.5.0).

``from robot_wear_monitor.monitoring.history import open_history`` keeps working for one
release, with a :class:`DeprecationWarning`; import from ``robot_wear_monitor.history``.
"""

import warnings

from robot_wear_monitor.history import *  # noqa: F401,F403
from robot_wear_monitor.history import __all__  # noqa: F401

warnings.warn('robot_wear_monitor.monitoring.history is deprecated and will be removed in the '
              'next release: import from robot_wear_monitor.history',
              DeprecationWarning, stacklevel=2)
