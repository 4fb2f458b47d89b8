"""
The dashboard server's limits, in a module of their own.

The command line reads them for its options' defaults without loading the server (asyncio,
uvicorn) at start-up.
"""

#: How long a request's headers may take to arrive, from their first byte [s].
HEADER_TIMEOUT_S = 10.0
#: The largest request head (request line and headers) h11 takes [bytes]; more is 400.
MAX_HEADER_BYTES = 16 * 1024
#: How many connections and requests at once the server takes (``--limit-concurrency``).
LIMIT_CONCURRENCY = 200
#: The most server processes ``dashboard --workers`` starts.
MAX_WORKERS = 64
