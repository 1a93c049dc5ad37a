"""``mcl view``: a run of a mission in a browser, served by the package itself.

``command.py`` (the command), ``data.py`` (what the page shows, from the run log),
``live.py`` (the same from the mission status a live run publishes over Zenoh),
``server.py`` (Python's http.server on 127.0.0.1), ``static/`` (the page, its script and its
style, shipped as package data: no build step, nothing loaded from elsewhere).
"""
