"""A webhook receiver on 127.0.0.1 for the notification tests: the JSON bodies it was sent."""

from contextlib import contextmanager
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer
import json
import threading
from typing import Iterator


@contextmanager
def webhook_receiver() -> Iterator[tuple[str, list]]:
    """Yield (URL, list of received JSON bodies) of a receiver that answers 200 to a POST."""
    received: list = []

    class Hook(BaseHTTPRequestHandler):

        def do_POST(self):  # noqa: N802 - http.server's name
            length = int(self.headers.get('Content-Length', '0'))
            received.append(json.loads(self.rfile.read(length)))
            self.send_response(200)
            self.end_headers()

        def log_message(self, *args):
            pass

    server = ThreadingHTTPServer(('127.0.0.1', 0), Hook)
    thread = threading.Thread(target=server.serve_forever, daemon=True)
    thread.start()
    try:
        yield f'http://127.0.0.1:{server.server_address[1]}/hook', received
    finally:
        server.shutdown()
        server.server_close()
