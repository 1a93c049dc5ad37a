"""The view's web server (app/view/server.py): the page with its data embedded, its script
and style from the package, data.json, the pictures beside the log, 404 for anything else."""

from __future__ import annotations

import json
import urllib.error
import urllib.request
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest

from app.view.server import ViewServer, page


def get(url: str) -> tuple[int, str, bytes]:
    try:
        with urllib.request.urlopen(url, timeout=10) as reply:
            return reply.status, reply.headers["Content-Type"], reply.read()
    except urllib.error.HTTPError as exc:
        return exc.code, "", b""


@pytest.fixture
def served(tmp_path: Path) -> Iterator[tuple[ViewServer, dict[str, Any]]]:
    picture = tmp_path / "r.mosaic.png"
    picture.write_bytes(b"\x89PNG fake")
    data: dict[str, Any] = {"mission": "m", "note": "</script><b>"}
    server = ViewServer(lambda: data, {"mosaic": picture})
    server.start()
    try:
        yield server, data
    finally:
        server.shutdown()
        server.server_close()


def test_what_it_serves(served: tuple[ViewServer, dict[str, Any]]) -> None:
    server, data = served
    assert server.url.startswith("http://127.0.0.1:") and not server.url.endswith(":0/")
    status, kind, body = get(server.url + "?t=12")
    assert (status, kind) == (200, "text/html; charset=utf-8")
    text = body.decode()
    assert "/*DATA*/" not in text and text.count("</script>") == 2  # the note is escaped
    embedded = text.split('type="application/json">')[1].split("</script>")[0]
    assert json.loads(embedded) == data
    assert get(server.url + "view.js")[:2] == (200, "text/javascript; charset=utf-8")
    assert b".block" in get(server.url + "view.css")[2]
    data["mission"] = "changed"  # data.json asks the provider each time (a live run)
    assert json.loads(get(server.url + "data.json")[2])["mission"] == "changed"
    assert get(server.url + "pictures/mosaic") == (200, "image/png", b"\x89PNG fake")
    for path in ("pictures/coverage", "../etc/passwd", "view.html", "static/view.js",
                 "pictures/../r.mosaic.png"):
        assert get(server.url + path)[0] == 404, path


def test_the_page_loads_nothing_from_elsewhere() -> None:
    text = page({}).decode()
    assert "http" not in text.replace("http-equiv", "")
    assert 'src="view.js"' in text and 'href="view.css"' in text
