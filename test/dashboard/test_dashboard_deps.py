"""
The dashboard's structure: routers that take what they need by dependency, documented shapes.

The routers import nothing from ``app`` (the package had its one import circle there); the
history is lent to one request at a time; the CSRF check runs before the role check; and every
JSON route names a response model in ``/openapi.json`` that the live answers satisfy key for key.
"""

import ast
from pathlib import Path

from fastapi import testclient
import jsonschema
import pytest
from robot_wear_monitor.dashboard.app import create_app, DashboardSettings
from robot_wear_monitor.dashboard.state import HistoryPool
from robot_wear_monitor.dashboard.views import joint_url
from robot_wear_monitor.history import open_history
from wear_testing.fleet_history import csrf_of, login, make_fleet, ORDER
from wear_testing.paths import REPO_ROOT

DASHBOARD = REPO_ROOT / 'robot_wear_monitor' / 'dashboard'
#: The modules that may import the app: those that start a server (``workers``: the app
#: factory uvicorn's workers import, ``dashboard --workers N``;
#: ``robot_wear_monitor.cli.dashboard`` is outside the package).
ENTRY_POINTS = {'server', 'workers'}


def _imports(path: Path) -> list[tuple[str, bool]]:
    """Return the package modules ``path`` imports, and whether inside a function."""
    tree = ast.parse(path.read_text(encoding='utf-8'))
    package = 'robot_wear_monitor.dashboard'
    found = []

    def visit(node: ast.AST, in_function: bool) -> None:
        for child in ast.iter_child_nodes(node):
            inner = in_function or isinstance(child, (ast.FunctionDef, ast.AsyncFunctionDef,
                                                      ast.Lambda))
            if isinstance(child, ast.Import):
                found.extend((alias.name, inner) for alias in child.names)
            elif isinstance(child, ast.ImportFrom):
                base = child.module or ''
                if child.level:  # a relative import: from the package (or below)
                    base = package + ('.' + base if base else '')
                found.append((base, inner))
                found.extend((f'{base}.{alias.name}', inner) for alias in child.names)
            visit(child, inner)
    visit(tree, False)
    return found


def _dashboard_graph() -> dict[str, set[str]]:
    """Return each dashboard module's imports of dashboard modules (function level too)."""
    modules = {p.stem for p in DASHBOARD.glob('*.py')}
    graph = {}
    for name in modules:
        targets = set()
        for imported, _ in _imports(DASHBOARD / f'{name}.py'):
            parts = imported.split('.')
            if parts[:2] == ['robot_wear_monitor', 'dashboard'] and len(parts) > 2 \
                    and parts[2] in modules:
                targets.add(parts[2])
        graph[name] = targets - {name}
    return graph


def test_no_dashboard_module_imports_the_app_but_an_entry_point():
    graph = _dashboard_graph()
    # the parser sees the imports that are there: the app builds itself from both routers,
    # and the routers take their dependencies from deps
    assert {'api', 'pages', 'state', 'auth', 'notifier'} <= graph['app']
    assert 'deps' in graph['api'] and 'deps' in graph['pages']
    importers = {name for name, targets in graph.items() if 'app' in targets}
    assert importers <= ENTRY_POINTS, f'{sorted(importers)} import dashboard.app'
    # function-level imports count too: none of the package's own modules inside functions
    late = {(p.stem, m) for p in DASHBOARD.glob('*.py') for m, inner in _imports(p)
            if inner and m.startswith('robot_wear_monitor.dashboard')}
    assert not late, f'function-level imports of the dashboard: {sorted(late)}'


def test_the_dashboard_modules_import_each_other_without_a_circle():
    graph = _dashboard_graph()
    done: set[str] = set()

    def visit(name: str, path: tuple[str, ...]) -> None:
        assert name not in path, 'import circle: ' + ' -> '.join(path + (name,))
        if name in done:
            return
        for target in sorted(graph[name]):
            visit(target, path + (name,))
        done.add(name)
    for name in sorted(graph):
        visit(name, ())
    assert len(done) == len(graph) >= 10


def test_the_pool_lends_a_history_to_one_borrower_at_a_time(tmp_path):
    pool = HistoryPool(make_fleet(str(tmp_path / 'fleet.sqlite3')))
    try:
        with pool.borrow() as first, pool.borrow() as second:
            assert first is not second  # two requests at once: two connections
            assert first.robots() == second.robots() == tuple(sorted({r for r, _ in ORDER}))
        with pool.borrow() as again:
            assert again in (first, second)  # given back, lent again: not opened anew
    finally:
        pool.close()


@pytest.fixture()
def client(tmp_path):
    path = make_fleet(str(tmp_path / 'fleet.sqlite3'))
    with open_history(path) as history:  # an acknowledgement, so that every event kind shows
        latched = history.fleet()[0]
        history.acknowledge_alarm(robot=latched.robot, joint=latched.joint, user='mia',
                                  owner='Bea', comment='gearbox ordered',
                                  planned_maintenance='2031-02-03')
    with testclient.TestClient(create_app(DashboardSettings(history=path))) as test_client:
        yield test_client


def test_the_csrf_check_comes_before_the_maintainer_check(client):
    assert login(client, 'vic').status_code == 303
    url = joint_url(*ORDER[0]) + '/reset'
    wrong = client.post(url, data={'reason': 'new gearbox', 'csrf_token': 'nonsense'})
    assert wrong.status_code == 403 and 'CSRF token' in wrong.json()['detail']
    token = csrf_of(client.get(joint_url(*ORDER[0])).text)
    viewer = client.post(url, data={'reason': 'new gearbox', 'csrf_token': token})
    assert viewer.status_code == 403
    assert viewer.json()['detail'] == 'only a maintainer or an admin may acknowledge or ' \
        'reset an alarm'
    scripted = client.post(url, data={'reason': 'new gearbox'},
                           headers={'X-CSRF-Token': client.get('/api/me').json()['csrf_token']})
    assert scripted.status_code == 403 and 'maintainer' in scripted.json()['detail']


def _schema(openapi: dict, path: str) -> dict:
    """Return the 200 answer's JSON schema of ``path``, resolvable in the document."""
    answers = openapi['paths'][path]['get']['responses']
    schema = answers['200']['content']['application/json']['schema']
    return {**schema, 'components': openapi['components']}


def _component(openapi: dict, schema: dict) -> dict:
    name = (schema.get('items') or schema)['$ref'].rsplit('/', 1)[1]
    return openapi['components']['schemas'][name]


def test_openapi_names_the_shapes_of_the_json_routes_and_the_answers_fit_them(client):
    assert client.get('/openapi.json').status_code == 401
    assert login(client, 'mia').status_code == 303
    openapi = client.get('/openapi.json').json()
    fleet = client.get('/api/fleet').json()
    row = fleet['rows'][0]
    fleet_schema = _component(openapi, _schema(openapi, '/api/fleet'))
    assert set(fleet_schema['properties']) == set(fleet) == set(fleet_schema['required'])
    row_schema = _component(openapi, fleet_schema['properties']['rows'])
    # the fleet row's keys: those of `fleet --json` and what the page shows, all documented
    assert set(row_schema['properties']) == set(row) == set(row_schema['required'])
    assert {'robot', 'joint', 'wear', 'wear_low', 'wear_high', 'state', 'arrow', 'bar',
            'text'} <= set(row_schema['properties'])
    assert row_schema['properties']['state']['enum'] == list(fleet['counts'])
    assert row_schema['additionalProperties'] is False
    for path in ('/api/fleet', '/api/robots/{robot}/joints/{joint}'):
        assert '304' in openapi['paths'][path]['get']['responses']  # the ETag's answer

    answers = {'/api/fleet': [fleet, client.get('/api/fleet?state=alarm').json()],
               '/api/alarms': [client.get('/api/alarms').json()],
               '/api/me': [client.get('/api/me').json()],
               '/api/robots/{robot}/joints/{joint}': [
                   client.get('/api' + joint_url(robot, joint)).json()
                   for robot, joint in ORDER]}
    for path, bodies in answers.items():
        validator = jsonschema.Draft202012Validator(_schema(openapi, path))
        for body in bodies:
            errors = [f'{list(e.absolute_path)}: {e.message}'
                      for e in validator.iter_errors(body)]
            assert not errors, f'{path}: ' + '; '.join(errors[:5])
    joints = answers['/api/robots/{robot}/joints/{joint}']
    # the answers exercise the optional parts: a forecast cone, friction curves, a state
    assert any(j['forecast'] for j in joints) and all(j['friction'] for j in joints)
    assert {e['event'] for e in answers['/api/alarms'][0]} == {'raised', 'acknowledged'}
    # a key the model does not name is refused (the schema is not open-ended)
    extra = {**row, 'surprise': 1}
    validator = jsonschema.Draft202012Validator({**row_schema,
                                                 'components': openapi['components']})
    assert not validator.is_valid(extra)


def test_a_reset_event_fits_the_alarm_model_too(client):
    assert login(client, 'mia').status_code == 303
    robot, joint = ORDER[0]
    token = csrf_of(client.get(joint_url(robot, joint)).text)
    assert client.post(joint_url(robot, joint) + '/reset',
                       data={'reason': 'gearbox replaced', 'csrf_token': token,
                             'confirm': 'yes'}, follow_redirects=False).status_code == 303
    events = client.get('/api/alarms', params={'robot': robot, 'joint': joint}).json()
    assert [e['event'] for e in events][:2] == ['reset', 'acknowledged']
    assert events[0]['user'] == 'mia' and events[0]['note'] == 'gearbox replaced'
    openapi = client.get('/openapi.json').json()
    jsonschema.validate(events, _schema(openapi, '/api/alarms'),
                        cls=jsonschema.Draft202012Validator)
