"""
The tests' own helpers: generators, recordings, servers and process graphs.

Importable as ``wear_testing`` (setup.cfg's ``[tool:pytest] pythonpath = test``); the
folder is not named ``test`` because that is a standard-library package.
"""
