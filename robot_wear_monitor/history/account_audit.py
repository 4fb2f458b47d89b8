"""
The audit of the dashboard's accounts, kept in the wear history (schema version 10).

Every change of a user, a role, a password or an API token is recorded in the same
transaction as the change itself (:func:`record`, called by ``users`` and ``tokens``): when
(``time_s``, s since the epoch), who (``user``: the dashboard user who made it on the page, or
``cli:<login name>`` for the command line), from where (``source``: one of :data:`SOURCES`),
what (``action``: one of :data:`ACTIONS`) and to whom (``target``: the user changed), with a
``detail`` that is never a secret (a role's old and new value, a token's id and label; never a
password, a hash or a token).  A change that was refused leaves no record.  :func:`audit_log`
lists the records, newest first.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass
import getpass
import time
from typing import Any, Optional

from robot_wear_monitor.history.backends import HistoryBackend

#: Where a change came from: the dashboard's pages, the command line, or a program that
#: called the library directly.
SOURCES = ('web', 'cli', 'library')
#: What was changed.
ACTIONS = ('user_added', 'user_removed', 'role_changed', 'password_changed', 'token_added',
           'tokens_removed')
#: The longest detail kept [characters].
MAX_DETAIL_CHARS = 200


@dataclass(frozen=True)
class Actor:
    """Who makes a change: ``user`` (a dashboard user, or ``cli:<login>``) and ``source``."""

    user: str
    source: str

    @classmethod
    def command_line(cls) -> 'Actor':
        """Return the actor of the command line: ``cli:<login name>`` (``cli:unknown``)."""
        return cls(user=f'cli:{_login()}', source='cli')

    @classmethod
    def web(cls, user: str) -> 'Actor':
        """Return the dashboard user ``user`` acting on the pages."""
        return cls(user=str(user), source='web')


def _login() -> str:
    try:
        return getpass.getuser()[:64] or 'unknown'
    except (KeyError, OSError):  # no name for this uid (a container)
        return 'unknown'


@dataclass(frozen=True)
class AuditRecord:
    """One recorded change of an account (see the module's description)."""

    id: int  # noqa: A003 - the history's column name
    time_s: float
    user: str
    source: str
    action: str
    target: str
    detail: str

    def as_dict(self) -> dict[str, Any]:
        """Return the record as a dict (the keys of ``dashboard audit --json``)."""
        return asdict(self)


def record(backend: HistoryBackend, *, by: Optional[Actor], action: str, target: str,
           detail: str = '', now_s: Optional[float] = None) -> None:
    """
    Record one change (inside the caller's transaction, so that it stands or falls with it).

    ``by``: who (None: a program calling the library, ``library`` with the login name).
    """
    if action not in ACTIONS:
        raise ValueError(f'unknown account action {action!r}')
    actor = by if by is not None else Actor(user=f'local:{_login()}', source='library')
    if actor.source not in SOURCES:
        raise ValueError(f'unknown source {actor.source!r}')
    backend.execute('INSERT INTO account_audit (time_s, user_name, source, action, target, '
                    'detail) VALUES (?, ?, ?, ?, ?, ?)',
                    (time.time() if now_s is None else float(now_s), actor.user[:80],
                     actor.source, action, str(target)[:64], str(detail)[:MAX_DETAIL_CHARS]))


def audit_log(backend: HistoryBackend, *, limit: Optional[int] = None) -> list[AuditRecord]:
    """Return the recorded changes of accounts, newest first (the last ``limit`` of them)."""
    query = ('SELECT id, time_s, user_name, source, action, target, detail FROM account_audit '
             'ORDER BY time_s DESC, id DESC')
    params: tuple[Any, ...] = ()
    if limit is not None:
        query += ' LIMIT ?'
        params = (max(int(limit), 0),)
    return [AuditRecord(id=int(r[0]), time_s=float(r[1]), user=r[2], source=r[3], action=r[4],
                        target=r[5], detail=r[6]) for r in backend.execute(query, params)]
