"""
The threshold a fleet row was judged by: the one stored with it, or the parameter set's, assumed.

Since history schema version 8 every estimate stores the alarm threshold and the warning level
[w] the estimator judged it by: its node parameters ``wear_threshold`` and ``wear_warning``,
which win over the parameter set's ``alarm.wear_threshold`` and ``alarm.wear_warning`` (those
are only their defaults; the node logs a warning once when they differ).  The rows of an older
history hold none: :func:`judged_levels` gives them the levels of the parameter set they name
(:class:`ParameterSets`) and marks them as assumed, which ``fleet --json``, ``/api/fleet`` and
the dashboard's pages say (``threshold_assumed``).
"""

from __future__ import annotations

from dataclasses import replace
import math
from pathlib import Path
import threading
from typing import Iterable, Optional

from robot_wear_monitor.history import FleetRow
from robot_wear_monitor.model.params import (default_parameter_file, load_parameter_set,
                                             ParameterSet)


class ParameterSets:
    """
    The parameter sets the estimates name: the packaged ones and those given by file.

    The history stores the set's name (``parameter_set``), not its file: a name is looked up
    among the files given (``--params``) and the packaged ``config/*.yaml``; an unknown name
    falls back to the packaged default set, and :meth:`resolve` says so.
    """

    def __init__(self, files: Iterable[str | Path] = ()) -> None:
        """Load the packaged sets and ``files`` (a file that does not load is an error)."""
        self._lock = threading.Lock()
        self._by_name: dict[str, ParameterSet] = {}
        self.default = load_parameter_set()
        packaged: list[str | Path] = sorted(default_parameter_file().parent.glob('*.yaml'))
        for path in packaged:
            try:
                params = load_parameter_set(path)
            except Exception:  # noqa: BLE001 - not a parameter set (e.g. a node config)
                continue
            self._by_name.setdefault(params.name, params)
        for path in files:
            params = load_parameter_set(path)  # ParameterError names the file and field
            self._by_name[params.name] = params

    def resolve(self, name: str) -> tuple[ParameterSet, str]:
        """Return the set named ``name`` and '' (or the default set and why it stands in)."""
        with self._lock:
            found = self._by_name.get(name)
        if found is not None:
            return found, ''
        return self.default, (f'parameter set {name!r} is not known here (give its file with '
                              f'--params); the model curve uses the packaged '
                              f'{self.default.name!r} ({Path(self.default.source).name})')


_PACKAGED: Optional[ParameterSets] = None
_PACKAGED_LOCK = threading.Lock()


def packaged_parameter_sets() -> ParameterSets:
    """Return the packaged parameter sets, loaded once (only a row without levels needs them)."""
    global _PACKAGED
    with _PACKAGED_LOCK:
        if _PACKAGED is None:
            _PACKAGED = ParameterSets()
        return _PACKAGED


def judged_levels(state: FleetRow, parameter_sets: Optional[ParameterSets] = None
                  ) -> tuple[FleetRow, bool]:
    """
    Return ``state`` with the threshold and warning level it was judged by, and if assumed.

    A row that stores its threshold is returned as it is (False).  A row of an older history
    (threshold NaN: not stored) gets the ``alarm.wear_threshold`` and ``alarm.wear_warning`` of
    the parameter set it names (the packaged default set when that name is not known;
    ``parameter_sets`` None: the packaged sets) and True: assumed, not known.  A stored
    threshold without a warning level keeps the threshold and takes the set's warning level.
    """
    if math.isfinite(state.threshold) and math.isfinite(state.warning_level):
        return state, False
    params, _ = (parameter_sets or packaged_parameter_sets()).resolve(state.parameter_set)
    if math.isfinite(state.threshold):
        return replace(state, warning_level=params.wear_warning), False
    return replace(state, threshold=params.wear_threshold,
                   warning_level=params.wear_warning), True


def threshold_words(threshold: float, *, assumed: bool) -> str:
    """Return a threshold [w] as people read it: '30', or '35 (assumed)' when not stored."""
    text = f'{threshold:g}' if math.isfinite(threshold) else '-'
    return f'{text} (assumed)' if assumed else text
