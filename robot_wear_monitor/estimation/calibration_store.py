"""
The store of interval calibrations: keys, the shipped table, the cache folder.

A calibration (:class:`CutoffCalibration`) is the simulated cutoff c(w) of the
likelihood-ratio statistic of one design (speeds rounded to :data:`CALIBRATION_SPEED_STEP`),
parameter set, level, run count and seed; :func:`calibration_key` hashes everything its
numbers depend on.  It is read from the table that ships with the package
(:data:`SHIPPED_CALIBRATIONS`, ``calibrations.json``) or from the cache folder
(:func:`calibration_cache_dir`, one JSON file per calibration, named by its key and a hash of
the code it comes from, written atomically).  The calibration itself (the simulation) is
:func:`robot_wear_monitor.estimation.intervals.calibrate_cutoffs`; the shipped table is
rebuilt by :func:`robot_wear_monitor.estimation.intervals.write_shipped_calibrations`.
"""

from __future__ import annotations

from dataclasses import dataclass, fields
from functools import lru_cache
import hashlib
import json
import os
from pathlib import Path

import numpy as np
from numpy.typing import ArrayLike
from robot_wear_monitor.array_types import FloatArray
from robot_wear_monitor.atomic_files import write_json_atomic
from robot_wear_monitor.input_files import MAX_JSON_BYTES, read_text_file
from robot_wear_monitor.model.params import ParameterSet


#: Wear values [-] at which the cutoff of the likelihood-ratio statistic is calibrated.
CALIBRATION_WEAR = (0.0, 3.0, 7.0, 11.0, 15.0, 20.0, 27.0, 35.0, 50.0, 75.0, 110.0, 150.0)
#: Simulated experiments per calibrated wear value.
CALIBRATION_RUNS = 1500
#: Seed of the calibration (fixed: the same speeds and parameters give the same intervals).
CALIBRATION_SEED = 20211
#: Speeds are rounded to this step [rad/s] for the calibration (measured speeds vary by a few
#: mrad/s between experiments; the cutoffs vary slowly with the speeds, so one calibration per
#: design serves them all).
CALIBRATION_SPEED_STEP = 0.1


@dataclass(frozen=True)
class CutoffCalibration:
    """
    Cutoffs c(w) of the likelihood-ratio statistic 2 (l_max - l_p(w)) for one design.

    The interval is {w >= 0 : 2 (l_max - l_p(w)) <= c(w)}, c interpolated linearly in w between
    the calibrated values and held constant beyond the last one.

    :ivar wear: calibrated wear values [-], shape (C,), increasing.
    :ivar cutoff: the ``level`` quantile of the statistic at the true wear, shape (C,).
    :ivar chi2_cutoff: chi2_1^-1(level), the asymptotic value, for comparison.
    :ivar level: confidence level.
    :ivar runs: simulated experiments per wear value.

    """

    wear: FloatArray
    cutoff: FloatArray
    chi2_cutoff: float
    level: float
    runs: int

    def at(self, wear: ArrayLike) -> FloatArray:
        """Return c(w) at ``wear`` [-] (any shape)."""
        return np.interp(np.asarray(wear, dtype=float), self.wear, self.cutoff)


def rounded_speeds(speeds: FloatArray) -> tuple:
    """Return the speeds rounded to the calibration step (at least one step), a tuple."""
    key = tuple(round(float(v) / CALIBRATION_SPEED_STEP) * CALIBRATION_SPEED_STEP
                for v in speeds)
    return tuple(max(v, CALIBRATION_SPEED_STEP) for v in key)


#: Version of the calibration's computation; part of every stored calibration's key.
CALIBRATION_VERSION = 1
#: Calibrations shipped with the package (the packaged parameter set at the default design).
SHIPPED_CALIBRATIONS = Path(__file__).with_name('calibrations.json')
#: Designs whose calibration ships for the packaged parameter set: Table V, N = 4 (the default
#: experiment of the node configuration and the simulator).
SHIPPED_DESIGNS = ((2.1, 28.5, 35.1, 41.7),)
#: Environment variable naming the calibration cache folder ('' disables the cache).
CACHE_ENV = 'ROBOT_WEAR_MONITOR_CACHE'


def calibration_key(speeds_t: tuple, params: ParameterSet, level: float, runs: int,
                    seed: int) -> str:
    """
    Return the key of a calibration: a hash of everything its numbers depend on.

    The parameter set enters by its values (model, sigma, load, temperature range, wear
    range), not its name, file or identification notes, so a copy of a set elsewhere shares
    the calibration; nor by its per-direction terms, which eq. (3) levels do not see.
    """
    values = [(f.name, repr(getattr(params, f.name))) for f in fields(params)
              if f.name not in ('name', 'source', 'not_identified', 'friction_unit',
                                'direction_model')]
    text = json.dumps([CALIBRATION_VERSION, [repr(float(v)) for v in speeds_t], values,
                       repr(float(level)), int(runs), int(seed), list(CALIBRATION_WEAR)])
    return hashlib.sha256(text.encode()).hexdigest()[:32]


def calibration_cache_dir() -> Path | None:
    """
    Return the folder of stored calibrations, or None when the cache is disabled.

    ``$ROBOT_WEAR_MONITOR_CACHE`` if set ('' disables), else
    ``$XDG_CACHE_HOME/robot_wear_monitor`` (default ``~/.cache/robot_wear_monitor``).  A file
    is named by the calibration's key and a hash of the code it comes from.
    """
    folder = os.environ.get(CACHE_ENV)
    if folder is not None:
        return Path(folder) if folder else None
    base = os.environ.get('XDG_CACHE_HOME') or os.path.join(os.path.expanduser('~'), '.cache')
    return Path(base) / 'robot_wear_monitor'


def calibration_from_json(item: dict) -> CutoffCalibration:
    """Return the calibration of a JSON object written by :func:`calibration_to_json`."""
    return CutoffCalibration(wear=np.asarray(item['wear'], dtype=float),
                             cutoff=np.asarray(item['cutoff'], dtype=float),
                             chi2_cutoff=float(item['chi2_cutoff']), level=float(item['level']),
                             runs=int(item['runs']))


def calibration_to_json(calibration: CutoffCalibration) -> dict:
    """Return the calibration as a JSON object (exact floats)."""
    return {'wear': calibration.wear.tolist(), 'cutoff': calibration.cutoff.tolist(),
            'chi2_cutoff': calibration.chi2_cutoff, 'level': calibration.level,
            'runs': calibration.runs}


@lru_cache(maxsize=1)
def code_fingerprint() -> str:
    """
    Return a hash of the code a calibration's numbers come from (the cache's key part).

    A stored calibration is used only by the same estimator, likelihood and model code, so a
    change of that code never reads a calibration an older version stored (the shipped table
    is checked against a fresh calibration by a test instead).
    """
    package = Path(__file__).resolve().parents[1]
    digest = hashlib.sha256()
    sources = [package / 'estimation' / 'estimator.py', package / 'estimation' / 'intervals.py',
               package / 'estimation' / 'calibration_store.py',
               *sorted((package / 'model').glob('*.py'))]
    for source in sources:
        try:
            digest.update(source.read_bytes())
        except OSError:
            digest.update(source.name.encode())
    return digest.hexdigest()[:12]


def stored_calibration(key: str) -> CutoffCalibration | None:
    """Return the calibration of ``key`` from the shipped table or the cache, if there."""
    sources = [SHIPPED_CALIBRATIONS]
    folder = calibration_cache_dir()
    if folder is not None:
        sources.append(folder / f'cutoffs-{key}-{code_fingerprint()}.json')
    for source in sources:
        try:
            table = json.loads(read_text_file(source, what='calibration',
                                              limit_bytes=MAX_JSON_BYTES))
            item = table.get(key) if source == SHIPPED_CALIBRATIONS else table
            if item is not None:
                return calibration_from_json(item)
        except (ValueError, KeyError, TypeError, AttributeError):  # InputError: a ValueError
            continue  # absent, unreadable, too large or damaged: calibrate anew
    return None


def store_calibration(key: str, calibration: CutoffCalibration) -> None:
    """Write the calibration to the cache (atomically); skip a cache that cannot be written."""
    folder = calibration_cache_dir()
    if folder is None:
        return
    try:
        folder.mkdir(parents=True, exist_ok=True)
        write_json_atomic(folder / f'cutoffs-{key}-{code_fingerprint()}.json',
                          calibration_to_json(calibration))
    except OSError:
        pass


def write_calibration_table(path: str | os.PathLike,
                            entries: list[tuple[tuple, ParameterSet, CutoffCalibration]]
                            ) -> Path:
    """
    Write a table of calibrations at the shipped table's format (atomically).

    :param path: the file to write, e.g. :data:`SHIPPED_CALIBRATIONS`.
    :param entries: (rounded speeds [rad/s], parameter set, calibration) per design; each is
        keyed by :func:`calibration_key` of its speeds, parameter set, level, runs and
        :data:`CALIBRATION_SEED`.

    :return: The path written.

    """
    table = {}
    for rounded, params, calibration in entries:
        key = calibration_key(rounded, params, calibration.level, calibration.runs,
                              CALIBRATION_SEED)
        table[key] = {'speeds_rad_s': list(rounded), 'parameter_set': params.name,
                      **calibration_to_json(calibration)}
    return write_json_atomic(path, table)
