"""
The fleet's joints per stable state, kept on write: the fleet page's counts without a scan.

Schema version 14 adds ``fleet_state_counts``: how many ``joint_summary`` rows hold each pair
(``state_base``, ``warn_fixed``), the stable parts of a joint's state
(:mod:`~robot_wear_monitor.history.fleet_index`).  Triggers on ``joint_summary`` keep it in
the transaction of every write that adds, removes or moves a joint between pairs (an
estimate or an alarm event that changes the joint's stable state; an estimate that leaves it
as it was writes nothing here).  PostgreSQL spreads the counts of concurrent writers over
:data:`STRIPES` rows per pair, chosen by the writer's server process, so that writers of
different joints do not wait on one counter row; a count is the sum of its stripes.

A bulk load (:func:`fleet_index.rebuild`, the migration) switches the PostgreSQL triggers off
for its transaction (:func:`pause`) and counts every row at once at its end
(:func:`recount`); SQLite's triggers stay on (in process, they cost little).

What moves with the clock (stale, a forecast crossing within the horizon, a re-escalation) is
counted at read time from the indexed times (:meth:`FleetIndex.counts`).
"""

from __future__ import annotations

from typing import Any, Protocol, Sequence


class CountingBackend(Protocol):
    """What this module asks of a history backend (``backends.py``, which imports this one)."""

    @property
    def kind(self) -> str:
        """Return 'sqlite' or 'postgresql'."""

    def execute(self, sql: str, params: Sequence[Any] = ()) -> list[tuple[Any, ...]]:
        """Run one statement (``?`` placeholders); return its rows."""


#: PostgreSQL: counter rows per (state_base, warn_fixed), one per writer process modulo this.
STRIPES = 16
#: PostgreSQL's transaction-local setting that pauses the triggers during a bulk load.
PAUSE_SETTING = 'robot_wear_monitor.fleet_counts_paused'

_TABLE = """CREATE TABLE fleet_state_counts (
    stripe INTEGER NOT NULL,
    state_base TEXT NOT NULL,
    warn_fixed INTEGER NOT NULL,
    joints BIGINT NOT NULL,
    PRIMARY KEY (stripe, state_base, warn_fixed))"""

_COUNT_ALL = (
    'DELETE FROM fleet_state_counts',
    'INSERT INTO fleet_state_counts (stripe, state_base, warn_fixed, joints) '
    'SELECT 0, state_base, warn_fixed, COUNT(*) FROM joint_summary '
    'GROUP BY state_base, warn_fixed',
)


def _sqlite_add(row: str, sign: str) -> str:
    return ('INSERT INTO fleet_state_counts (stripe, state_base, warn_fixed, joints) '
            f'VALUES (0, {row}.state_base, {row}.warn_fixed, {sign}1) '
            'ON CONFLICT (stripe, state_base, warn_fixed) DO UPDATE SET '
            f'joints = joints {sign} 1;')


_MOVED = ('OLD.state_base IS NOT NEW.state_base OR OLD.warn_fixed IS NOT NEW.warn_fixed')

#: SQLite: the table, its triggers (row by row, a move only when the pair changes), the count.
SQLITE_STEPS = (
    _TABLE,
    'CREATE TRIGGER joint_summary_count_insert AFTER INSERT ON joint_summary BEGIN '
    + _sqlite_add('NEW', '+') + ' END',
    'CREATE TRIGGER joint_summary_count_delete AFTER DELETE ON joint_summary BEGIN '
    + _sqlite_add('OLD', '-') + ' END',
    'CREATE TRIGGER joint_summary_count_update AFTER UPDATE OF state_base, warn_fixed ON '
    f'joint_summary WHEN {_MOVED} BEGIN ' + _sqlite_add('OLD', '-') + ' '
    + _sqlite_add('NEW', '+') + ' END',
    *_COUNT_ALL,
)


def _postgresql_add(row: str, sign: str) -> str:
    return ('INSERT INTO fleet_state_counts (stripe, state_base, warn_fixed, joints) '
            f'VALUES (writer_stripe, {row}.state_base, {row}.warn_fixed, {sign}1) '
            'ON CONFLICT (stripe, state_base, warn_fixed) DO UPDATE SET '
            f'joints = fleet_state_counts.joints {sign} 1;')


#: PostgreSQL: the table, the trigger function, its triggers, the count.
POSTGRESQL_STEPS = (
    _TABLE,
    'CREATE FUNCTION wear_fleet_state_count() RETURNS trigger LANGUAGE plpgsql AS $body$ '
    f'DECLARE writer_stripe INTEGER := pg_backend_pid() % {STRIPES}; BEGIN '
    f"IF current_setting('{PAUSE_SETTING}', true) = 'on' THEN RETURN NULL; END IF; "
    f"IF TG_OP <> 'INSERT' THEN {_postgresql_add('OLD', '-')} END IF; "
    f"IF TG_OP <> 'DELETE' THEN {_postgresql_add('NEW', '+')} END IF; "
    'RETURN NULL; END $body$',
    'CREATE TRIGGER joint_summary_count_rows AFTER INSERT OR DELETE ON joint_summary '
    'FOR EACH ROW EXECUTE FUNCTION wear_fleet_state_count()',
    'CREATE TRIGGER joint_summary_count_update AFTER UPDATE OF state_base, warn_fixed ON '
    'joint_summary FOR EACH ROW WHEN (OLD.state_base IS DISTINCT FROM NEW.state_base OR '
    'OLD.warn_fixed IS DISTINCT FROM NEW.warn_fixed) EXECUTE FUNCTION wear_fleet_state_count()',
    *_COUNT_ALL,
)


def pause(backend: CountingBackend, *, paused: bool = True) -> None:
    """Pause (or resume) the PostgreSQL triggers until the transaction ends (a bulk load)."""
    if backend.kind == 'postgresql':
        backend.execute('SELECT set_config(?, ?, true)',
                        (PAUSE_SETTING, 'on' if paused else 'off'))


def recount(backend: CountingBackend) -> None:
    """Count every joint per (state_base, warn_fixed) anew (after a bulk load)."""
    for step in _COUNT_ALL:
        backend.execute(step)


def stable_counts(backend: CountingBackend) -> list[tuple[str, int, int]]:
    """Return (state_base, warn_fixed, joints) of every pair that holds joints."""
    return [(r[0], int(r[1]), int(r[2])) for r in backend.execute(
        'SELECT state_base, warn_fixed, SUM(joints) FROM fleet_state_counts '
        'GROUP BY state_base, warn_fixed') if int(r[2])]
