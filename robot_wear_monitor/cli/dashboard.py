"""
``robot-wear-monitor dashboard``: the maintenance team's web dashboard, and its users.

``dashboard --history URL [--host 127.0.0.1] [--port 8080] [--tls-cert F --tls-key F]
[--insecure-http] [--params FILE ...] [--notify CONFIG]`` serves the dashboard
(:mod:`robot_wear_monitor.dashboard`); ``dashboard user add NAME --role
viewer|maintainer|admin --history URL`` (the password from stdin when it is not a terminal,
else asked twice; never from argv), ``dashboard user passwd NAME`` (a new password, the same
way; the user's sessions end), ``dashboard user role NAME --role ROLE``, ``dashboard user
list`` and ``dashboard user remove NAME`` (their sessions and API tokens end) keep its users in
the history; ``dashboard token add USER [--label TEXT]`` makes an API token of a user (shown
once, only its hash stored), ``dashboard token list [USER]`` lists ids, labels, creation and
last use (never a token) and ``dashboard token remove USER --id N|--all`` removes them.
Every such change (and those of the Users page) is recorded in the history's account audit
(``cli:<login name>`` for the command line); ``dashboard audit [--json] [--limit N]`` lists it,
newest first.  Serving: ``--behind-tls`` (a TLS proxy in front: Secure cookie),
``--trusted-proxy ADDRESS`` (whose X-Forwarded-For names the client),
``--limit-concurrency N`` and ``--header-timeout-s S`` (slow and many clients, per worker);
``--workers N`` (N server processes on one PostgreSQL history, uvicorn's supervisor; an SQLite
history is served by one: see :mod:`robot_wear_monitor.dashboard.workers`).
"""

from __future__ import annotations

import argparse
import getpass
import json
import sys
from typing import Any

from robot_wear_monitor.cli.fleet_options import add_declared_options
from robot_wear_monitor.cli.options import add_display_timezone, PROG, shown_location
from robot_wear_monitor.dashboard.server_limits import ServerSettings
from robot_wear_monitor.errors import InputError
from robot_wear_monitor.history import is_postgresql_url, open_history
from robot_wear_monitor.history.account_audit import Actor
from robot_wear_monitor.history.users import ROLE_TEXTS, ROLES
from robot_wear_monitor.text import iso_time, shorten

_ROLE_HELP = '; '.join(f'{role} {text}' for role, text in ROLE_TEXTS.items())

HELP = ("web dashboard of a wear history: the fleet worst first, each joint's wear story, "
        'accountable acknowledge and reset (its users: dashboard user '
        'add|passwd|role|list|remove; API tokens: dashboard token add|list|remove; who changed '
        'them: dashboard audit)')


def _history_option(parser: argparse.ArgumentParser, *, top: bool) -> None:
    parser.add_argument('--history', metavar='PATH|URL',
                        default=None if top else argparse.SUPPRESS,
                        help='the wear history (users live in it): an SQLite file, or '
                             'postgresql://USER@HOST:PORT/DB')


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Add the options of ``dashboard`` and its ``user`` subcommands."""
    _history_option(parser, top=True)
    # --host, --port, --limit-concurrency, --header-timeout-s, --notify-interval-s: declared
    add_declared_options(parser, 'dashboard')
    parser.add_argument('--tls-cert', metavar='PEM', help='TLS certificate: serve HTTPS')
    parser.add_argument('--tls-key', metavar='PEM', help='private key of --tls-cert')
    parser.add_argument('--insecure-http', action='store_true',
                        help='allow plain HTTP on a non-loopback --host (a TLS proxy in front)')
    parser.add_argument('--behind-tls', action='store_true',
                        help='a TLS proxy is in front: the session cookie is Secure (the '
                             'browser sends it over HTTPS only)')
    parser.add_argument('--trusted-proxy', action='append', default=[], metavar='ADDRESS',
                        help="a proxy's address whose X-Forwarded-For names the client (for "
                             'the login rate limit; none trusted by default); repeatable')
    parser.add_argument('--params', action='append', default=[], metavar='FILE',
                        help='a parameter set the estimates name (for the model curve; the '
                             'packaged sets are known already); repeatable')
    parser.add_argument('--notify', metavar='CONFIG',
                        help='send notifications in the server process (the configuration of '
                             '`notify`), one pass every --notify-interval-s')
    add_display_timezone(parser)
    users = parser.add_subparsers(dest='dashboard_command', metavar='user|token|audit')
    user = users.add_parser('user', help='add, list or remove dashboard users; a new password '
                                         'or role')
    actions = user.add_subparsers(dest='user_action', metavar='ACTION', required=True)
    add = actions.add_parser('add', help='add a user (password from stdin or asked twice)')
    add.add_argument('name', metavar='NAME', help='user name: 1-64 of A-Z a-z 0-9 _ . @ -')
    add.add_argument('--role', choices=ROLES, required=True, help=_ROLE_HELP)
    _history_option(add, top=False)
    passwd = actions.add_parser('passwd', help="a user's new password (from stdin or asked "
                                               'twice); their sessions end')
    passwd.add_argument('name', metavar='NAME')
    _history_option(passwd, top=False)
    role = actions.add_parser('role', help="change a user's role (counts at once)")
    role.add_argument('name', metavar='NAME')
    role.add_argument('--role', choices=ROLES, required=True, help=_ROLE_HELP)
    _history_option(role, top=False)
    listing = actions.add_parser('list', help='list the users and their roles')
    _history_option(listing, top=False)
    remove = actions.add_parser('remove', help='remove a user (their sessions and API tokens '
                                               'end)')
    remove.add_argument('name', metavar='NAME')
    _history_option(remove, top=False)
    token = users.add_parser('token', help="API tokens of users (the write API's "
                                           '`Authorization: Bearer TOKEN`)')
    token_actions = token.add_subparsers(dest='token_action', metavar='ACTION', required=True)
    token_add = token_actions.add_parser('add', help='make a token of USER; it is printed '
                                                     'once, only its hash is stored')
    token_add.add_argument('user', metavar='USER')
    token_add.add_argument('--label', default='', help='what the token is for (e.g. CMMS)')
    _history_option(token_add, top=False)
    token_list = token_actions.add_parser('list', help='the tokens (of USER): id, label, '
                                                       'created, last used; never the token')
    token_list.add_argument('user', metavar='USER', nargs='?')
    _history_option(token_list, top=False)
    token_remove = token_actions.add_parser('remove', help='remove a token of USER (or all '
                                                           'of theirs)')
    token_remove.add_argument('user', metavar='USER')
    which = token_remove.add_mutually_exclusive_group(required=True)
    which.add_argument('--id', type=int, dest='token_id', help='the id `token list` shows')
    which.add_argument('--all', action='store_true', help="all of the user's tokens")
    _history_option(token_remove, top=False)
    audit = users.add_parser('audit', help='who changed which account when (users, roles, '
                                           'passwords, tokens; page or command line), '
                                           'newest first')
    audit.add_argument('--json', action='store_true', dest='audit_json',
                       help='a JSON list of objects: user, time_s, action, target, source, '
                            'detail, id')
    audit.add_argument('--limit', type=int, default=None, metavar='N',
                       help='the newest N records only')
    _history_option(audit, top=False)


def read_password(*, name: str) -> str:
    """Return the new password: a line of stdin when it is not a terminal, else asked twice."""
    if not sys.stdin.isatty():
        line = sys.stdin.readline()
        return line[:-1] if line.endswith('\n') else line
    first = getpass.getpass(f'password of {name}: ')
    if getpass.getpass('again: ') != first:
        raise InputError('the two passwords differ; nothing stored')
    return first


def _users(args: argparse.Namespace) -> int:
    with open_history(args.history, init=None if args.user_action == 'add' else False) \
            as history:
        if args.user_action == 'add':
            password = read_password(name=args.name)
            user = history.add_user(name=args.name, role=args.role, password=password,
                                    by=_cli_actor())
            print(f'user {user.name} added ({user.role})')
        elif args.user_action == 'passwd':
            if args.name not in {u.name for u in history.users()}:
                raise InputError(f'{shown_location(args.history)}: no user {args.name[:64]!r}')
            ended = history.set_password(name=args.name, password=read_password(name=args.name),
                                         by=_cli_actor())
            print(f'new password of {args.name} stored; {ended} session(s) ended')
        elif args.user_action == 'role':
            user = history.set_role(name=args.name, role=args.role, by=_cli_actor())
            print(f'user {user.name} is now {user.role}')
        elif args.user_action == 'remove':
            history.remove_user(name=args.name, by=_cli_actor())
            print(f'user {args.name} removed; their sessions and API tokens ended')
        else:
            found = history.users()
            for user in found:
                print(f'{user.name}  {user.role}  created {iso_time(user.created_wall_time_s)}')
            if not found:
                print(f'no users yet: {PROG} dashboard user add NAME --role maintainer '
                      f'--history {shown_location(args.history)}')
    return 0


def _tokens(args: argparse.Namespace) -> int:
    with open_history(args.history, init=False) as history:
        if args.token_action == 'add':
            listed, token = history.add_token(user=args.user, label=args.label, by=_cli_actor())
            print(token)
            print(f'API token {listed.id} of {listed.user} made: it is shown this once (only '
                  f'its hash is stored); send it as `Authorization: Bearer TOKEN`',
                  file=sys.stderr)
        elif args.token_action == 'remove':
            removed = history.remove_tokens(user=args.user,
                                            token_id=None if args.all else args.token_id,
                                            by=_cli_actor())
            print(f'{removed} API token(s) of {args.user} removed')
        else:
            found = history.tokens(user=args.user)
            for item in found:
                used = iso_time(item.last_used_wall_time_s) \
                    if item.last_used_wall_time_s is not None else 'never'
                print(f'{item.id}  {item.user}  created {iso_time(item.created_wall_time_s)}  '
                      f'last used {used}  {shorten(item.label, 60)}'.rstrip())
            if not found:
                print('no API tokens' + (f' of {args.user}' if args.user else ''))
    return 0


def _cli_actor() -> Any:
    """Return the actor of a change made here: ``cli:<login name>``."""
    return Actor.command_line()


def _audit(args: argparse.Namespace) -> int:
    """List the account audit: a table, or ``--json``."""
    if args.limit is not None and args.limit < 1:
        raise InputError(f'--limit must be >= 1, got {args.limit}')
    with open_history(args.history, init=False) as history:
        found = history.account_audit(limit=args.limit)
    if args.audit_json:
        print(json.dumps([item.as_dict() for item in found], ensure_ascii=False, indent=1))
        return 0
    for item in found:
        print(shorten(f'{iso_time(item.time_s)}  {item.user}  ({item.source})  '
                      f'{item.action}  {item.target}  {item.detail}'.rstrip(), limit=400))
    if not found:
        print('no account changes recorded')
    return 0


def main(args: argparse.Namespace) -> int:
    """Run ``dashboard`` (serve), ``dashboard user|token ...`` or ``dashboard audit``."""
    if not args.history:
        raise InputError('--history PATH|URL is required (the wear history to show)')
    if args.dashboard_command == 'user':
        return _users(args)
    if args.dashboard_command == 'token':
        return _tokens(args)
    if args.dashboard_command == 'audit':
        return _audit(args)
    try:
        # deferred import: optional extra 'dashboard' (fastapi, uvicorn), not for --help
        from robot_wear_monitor.dashboard.app import (create_app, DashboardSettings,
                                                      environment_secret)
        from robot_wear_monitor.dashboard.server import bind_listener, check_listen, serve
    except ImportError as error:
        raise InputError(f'the dashboard needs {error.name}: pip install '
                         '"robot_wear_monitor[dashboard]"') from None
    # the options' types checked each value with its declared check; the dataclass again
    server = ServerSettings(host=args.host, port=args.port,
                            limit_concurrency=args.limit_concurrency,
                            header_timeout_s=args.header_timeout_s, workers=args.workers)
    check_listen(host=server.host, tls_cert=args.tls_cert, tls_key=args.tls_key,
                 insecure_http=args.insecure_http)
    _check_workers(args)  # the range by the option's type; SQLite serves one worker
    notifications = None
    if args.notify:
        # deferred import: start-up time (the notifier: not for --help)
        from robot_wear_monitor.dashboard.notifier import load_config
        notifications = load_config(args.notify)  # a bad file stops the start (exit 2)
    with open_history(args.history, init=False) as history:
        if not history.users():
            print(f'{PROG} dashboard: note: no users yet; add one with `{PROG} dashboard user '
                  f'add NAME --role maintainer --history {shown_location(args.history)}`',
                  file=sys.stderr)
    settings = DashboardSettings(
        history=args.history, params=tuple(args.params), secret_key=environment_secret(),
        https=bool(args.tls_cert), notifications=notifications,
        notify_interval_s=args.notify_interval_s, behind_tls=args.behind_tls,
        trusted_proxies=tuple(args.trusted_proxy), workers=server.workers,
        **({} if args.display_timezone is None else
           {'display_timezone': args.display_timezone}))
    app = create_app(settings) if server.workers == 1 else None
    scheme = 'https' if args.tls_cert else 'http'
    listener = bind_listener(host=args.host, port=args.port)  # a taken port: one line, exit 2
    workers = f'{args.workers} workers; ' if args.workers > 1 else ''
    print(f'dashboard of {shown_location(args.history)} on {scheme}://{args.host}:{args.port}/ '
          f'({workers}Ctrl-C stops)', file=sys.stderr)
    if app is not None:
        serve(app, host=server.host, port=server.port, tls_cert=args.tls_cert,
              tls_key=args.tls_key, listener=listener, limit_concurrency=server.limit_concurrency,
              header_timeout_s=server.header_timeout_s)
        return 0
    # deferred import: start-up time (uvicorn's supervisor: not for --help)
    from dataclasses import replace
    from robot_wear_monitor.dashboard.auth import new_secret_key
    from robot_wear_monitor.dashboard.workers import serve_workers
    # one session key for every worker: a cookie signed by one is good on the others
    serve_workers(replace(settings, secret_key=settings.secret_key or new_secret_key()),
                  workers=server.workers, host=server.host, port=server.port, listener=listener,
                  tls_cert=args.tls_cert, tls_key=args.tls_key,
                  limit_concurrency=server.limit_concurrency,
                  header_timeout_s=server.header_timeout_s)
    return 0


def _check_workers(args: argparse.Namespace) -> None:
    """Refuse more than one worker on an SQLite history (the range: the option's type)."""
    if args.workers > 1 and not is_postgresql_url(args.history):
        raise InputError(f'--workers {args.workers} needs a PostgreSQL history '
                         '(postgresql://USER@HOST:PORT/DB): an SQLite file is written by one '
                         'process at a time, so more workers would only wait on its lock; '
                         'serve an SQLite history with one worker (the default)')
