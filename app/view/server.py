"""The web server of ``mcl view``: Python's own ``http.server`` on the loopback interface
(``mcl run --view HOST:PORT`` may choose another).

It serves one page (``static/view.html``, shipped as package data with its script and style:
nothing is fetched from elsewhere, no build step), with the page's data embedded in it so that
the first paint shows the mission at once; ``data.json`` (the same data, which the page polls
while a run is live); and the pictures found beside the run log. Every other path is 404.
"""

from __future__ import annotations

import json
import socket
import threading
from collections.abc import Callable
from http import HTTPStatus
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer
from importlib import resources
from pathlib import Path
from typing import Any
from urllib.parse import urlsplit

STATIC = {"view.js": "text/javascript; charset=utf-8", "view.css": "text/css; charset=utf-8"}
PICTURE_TYPES = {".png": "image/png", ".svg": "image/svg+xml"}
HOST = "127.0.0.1"  # loopback only: the view shows a mission, it takes no orders

Provider = Callable[[], dict[str, Any]]  # the page's data now


def static(name: str) -> bytes:
    """A file shipped with the page (package data)."""
    return resources.files("app.view").joinpath("static", name).read_bytes()


def page(data: dict[str, Any]) -> bytes:
    """The page with ``data`` embedded (``</`` escaped so that no string ends the script)."""
    text = json.dumps(data, separators=(",", ":")).replace("</", "<\\/")
    return static("view.html").decode("utf-8").replace("/*DATA*/", text).encode("utf-8")


class ViewServer(ThreadingHTTPServer):
    """The server: ``provider`` gives the data, ``pictures`` maps a picture's name to its
    file; ``url`` is where a browser opens the page."""

    # An answer under way is finished before server_close returns (the process may exit right
    # after: a page fetching as a run ended got a cut reply); Handler.timeout bounds the wait.
    daemon_threads = False
    block_on_close = True

    def __init__(self, provider: Provider, pictures: dict[str, Path], port: int = 0,
                 host: str = HOST):
        if ":" in host:  # an IPv6 address (``mcl run --view [::1]:8080``)
            self.address_family = socket.AF_INET6
        super().__init__((host.strip("[]"), port), Handler)
        self.provider = provider
        self.pictures = pictures
        self.host = host

    @property
    def url(self) -> str:
        host = f"[{self.host.strip('[]')}]" if ":" in self.host else self.host
        return f"http://{host}:{self.server_address[1]}/"

    def start(self) -> threading.Thread:
        """Serve on a thread of its own (for tests and live runs); ``shutdown()`` ends it."""
        thread = threading.Thread(target=self.serve_forever, name="mcl-view", daemon=True)
        thread.start()
        return thread


class Handler(BaseHTTPRequestHandler):
    """GET only: the page, its script and style, data.json, the pictures."""

    server: ViewServer
    timeout = 5.0  # s a connection may stay silent: the server's close waits for no longer

    def do_GET(self) -> None:  # noqa: N802 (http.server's name)
        path = urlsplit(self.path).path.lstrip("/")
        if path in ("", "index.html"):
            self.reply(page(self.server.provider()), "text/html; charset=utf-8")
        elif path in STATIC:
            self.reply(static(path), STATIC[path])
        elif path == "data.json":
            self.reply(json.dumps(self.server.provider()).encode("utf-8"),
                       "application/json")
        elif path.startswith("pictures/") and path[9:] in self.server.pictures:
            file = self.server.pictures[path[9:]]
            self.reply(file.read_bytes(), PICTURE_TYPES.get(file.suffix,
                                                            "application/octet-stream"))
        else:
            self.send_error(HTTPStatus.NOT_FOUND, "not part of mcl view")

    def reply(self, body: bytes, kind: str) -> None:
        self.send_response(HTTPStatus.OK)
        self.send_header("Content-Type", kind)
        self.send_header("Content-Length", str(len(body)))
        self.send_header("Cache-Control", "no-store")
        self.end_headers()
        self.wfile.write(body)

    def log_message(self, format: str, *args: Any) -> None:  # noqa: A002 (the base's name)
        """Quiet: the terminal shows the address and nothing per request."""
