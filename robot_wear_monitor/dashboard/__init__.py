"""
The maintenance team's web dashboard of a wear history (``robot-wear-monitor dashboard``).

FastAPI (an ASGI framework with its OpenAPI page) under uvicorn, Jinja2 pages with autoescape,
Plotly.js for the charts and Swagger UI for the API page, both served from their installed
Python packages (no CDN: the machines are offline).  Modules: ``app`` (the application and
its static files), ``state`` (the settings, the pool of open histories), ``deps`` (what the
routes take by dependency: the history, the user, the CSRF check, the maintainer role),
``auth`` (sessions, CSRF, the login rate limit), ``views`` (what the pages and the API show),
``schemas`` (the API's response models), ``pages`` (HTML and forms), ``api`` (JSON under
``/api/``), ``notifier`` (the notification loop of ``--notify``), ``server`` (uvicorn, the
host check, the header timeout), ``guards`` (request bodies bounded and checked before anything
reads them; the answers to bad values and to a history that cannot serve), ``accounts``
(the Users page and the account audit, for admins).  See docs/dashboard.md.
"""
