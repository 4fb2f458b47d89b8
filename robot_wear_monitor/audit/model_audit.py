"""Former single-module audit, kept so that old imports keep working.

The audit is now the package :mod:`robot_wear_monitor.audit`: reading the data (:mod:`.data`),
fitting (:mod:`.fitting`), candidate bases (:mod:`.candidates`), tests (:mod:`.significance`),
naming the shape (:mod:`.shapes`), cross-validation (:mod:`.cross_validation`), noise floor
(:mod:`.noise`), the loop (:mod:`.run`), result and report (:mod:`.result`, :mod:`.report`),
parameter export (:mod:`.export`) and the T/w estimates before and after (:mod:`.estimates`).
"""

from robot_wear_monitor.audit.candidates import candidate_columns
from robot_wear_monitor.audit.data import (is_bag, load_audit_data, MODELS, read_level_table,
                                           REQUIRED_COLUMNS, table_from_bag, table_from_columns,
                                           table_from_levels, table_from_raw_runs)
from robot_wear_monitor.audit.fitting import AuditTable
from robot_wear_monitor.audit.noise import noise_floor
from robot_wear_monitor.audit.result import AuditResult, Effect
from robot_wear_monitor.audit.run import _enough_speeds, MIN_SPEEDS, run_audit
from robot_wear_monitor.audit.shapes import Term

__all__ = ['AuditResult', 'AuditTable', 'candidate_columns', 'Effect', 'is_bag',
           'load_audit_data', 'MIN_SPEEDS', 'MODELS', 'noise_floor', 'read_level_table',
           'REQUIRED_COLUMNS', 'run_audit', 'table_from_bag', 'table_from_columns',
           'table_from_levels', 'table_from_raw_runs', 'Term', '_enough_speeds']
