"""The viewer's local web server (standard library ``http.server``): a static page and a JSON API.

Routes (all GET):

* ``/`` the page, ``/static/<file>`` its script and style;
* ``/api/summary``; ``/api/videos?scene=&template=&category=&answer=``; ``/api/video/<vi>``;
  ``/api/trace/<vi>/<qi>``; ``/api/counterfactual/<vi>/<object id>``;
* ``/media/video/<vi>.mp4``, ``/media/counterfactual/<vi>/<object id>.mp4``, ``/media/frame/<vi>/<first|last>.png``.

Errors are JSON ``{"error": message}`` with status 404 (unknown thing, missing media) or 400 (bad request).
Media responses honour single byte ranges, so the browser's player can seek.
"""

from __future__ import annotations

import contextlib
import json
import re
import threading
from collections.abc import Callable
from http import HTTPStatus
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer
from pathlib import Path
from typing import Any
from urllib.parse import parse_qs, urlsplit

from ..errors import CraftError
from .data import FILTERS, ViewerData, ViewerError

STATIC = Path(__file__).parent / "static"
_TYPES = {".html": "text/html; charset=utf-8", ".js": "text/javascript; charset=utf-8",
          ".css": "text/css; charset=utf-8", ".mp4": "video/mp4", ".png": "image/png"}
_RANGE = re.compile(r"bytes=(\d*)-(\d*)\Z")


def _routes(data: ViewerData) -> list[tuple[re.Pattern[str], Callable[..., Any]]]:
    def media(kind: str) -> Callable[..., tuple[str, bytes]]:
        def serve(*groups: str) -> tuple[str, bytes]:
            if kind == "video":
                return ".mp4", data.video_mp4(int(groups[0]))
            if kind == "cf":
                return ".mp4", data.counterfactual_mp4(int(groups[0]), int(groups[1]))
            return ".png", data.frame_png(int(groups[0]), groups[1])
        return serve

    return [
        (re.compile(r"/api/summary"), lambda q: data.summary()),
        (re.compile(r"/api/videos"), lambda q: data.videos(q)),
        (re.compile(r"/api/video/(\d+)"), lambda q, vi: data.video(int(vi), q)),
        (re.compile(r"/api/trace/(\d+)/(\d+)"), lambda q, vi, qi: data.trace(int(vi), int(qi))),
        (re.compile(r"/api/counterfactual/(\d+)/(\d+)"), lambda q, vi, o: data.counterfactual(int(vi), int(o))),
        (re.compile(r"/media/video/(\d+)\.mp4"), lambda q, vi: media("video")(vi)),
        (re.compile(r"/media/counterfactual/(\d+)/(\d+)\.mp4"), lambda q, vi, o: media("cf")(vi, o)),
        (re.compile(r"/media/frame/(\d+)/(first|last)\.png"), lambda q, vi, w: media("frame")(vi, w)),
    ]


def make_handler(data: ViewerData, log: Callable[[str], None] | None = None) -> type[BaseHTTPRequestHandler]:
    routes = _routes(data)

    class Handler(BaseHTTPRequestHandler):
        server_version = "craft-dsl-viewer"

        def log_message(self, format: str, *args: Any) -> None:  # noqa: A002 - the base class's name
            if log is not None:
                log(format % args)

        def _send(self, status: int, body: bytes, content_type: str) -> None:
            start, end = 0, len(body)
            match = _RANGE.fullmatch(self.headers.get("Range", "")) if status == 200 else None
            if match and (match.group(1) or match.group(2)):
                if match.group(1):
                    start = int(match.group(1))
                    end = min(len(body), int(match.group(2)) + 1) if match.group(2) else len(body)
                else:
                    start = max(0, len(body) - int(match.group(2)))
                if start >= len(body):
                    self.send_response(HTTPStatus.REQUESTED_RANGE_NOT_SATISFIABLE)
                    self.send_header("Content-Range", f"bytes */{len(body)}")
                    self.end_headers()
                    return
                status = HTTPStatus.PARTIAL_CONTENT
            self.send_response(status)
            self.send_header("Content-Type", content_type)
            self.send_header("Content-Length", str(end - start))
            self.send_header("Cache-Control", "no-store")
            if content_type in ("video/mp4", "image/png"):
                self.send_header("Accept-Ranges", "bytes")
            if status == HTTPStatus.PARTIAL_CONTENT:
                self.send_header("Content-Range", f"bytes {start}-{end - 1}/{len(body)}")
            self.end_headers()
            # the browser may drop a request (e.g. a video element changed its source): nothing to do then
            with contextlib.suppress(BrokenPipeError, ConnectionResetError):
                self.wfile.write(body[start:end])

        def _json(self, status: int, value: Any) -> None:
            self._send(status, json.dumps(value).encode("utf-8"), "application/json")

        def do_GET(self) -> None:  # noqa: N802 - the base class's name
            url = urlsplit(self.path)
            path = url.path
            if path in ("/", "/index.html"):
                path = "/static/index.html"
            if path.startswith("/static/"):
                target = STATIC / path.removeprefix("/static/")
                if target.parent != STATIC or not target.is_file():
                    self._json(404, {"error": f"no such file {path}"})
                    return
                self._send(200, target.read_bytes(), _TYPES.get(target.suffix, "application/octet-stream"))
                return
            query = {k: v[-1] for k, v in parse_qs(url.query).items() if k in FILTERS}
            for pattern, handler in routes:
                match = pattern.fullmatch(path)
                if match is None:
                    continue
                try:
                    result = handler(query, *match.groups())
                except ViewerError as err:
                    self._json(404, {"error": str(err)})
                except CraftError as err:
                    self._json(400, {"error": str(err)})
                else:
                    if isinstance(result, tuple):
                        self._send(200, result[1], _TYPES[result[0]])
                    else:
                        self._json(200, result)
                return
            self._json(404, {"error": f"no such page {path}"})

    return Handler


class Viewer:
    """A running viewer: ``Viewer(folder).start()`` serves in a background thread (tests), ``serve_forever()``
    in the foreground (the command)."""

    def __init__(self, root: str, host: str = "127.0.0.1", port: int = 0,
                 log: Callable[[str], None] | None = None) -> None:
        self.data = ViewerData(root)
        self.httpd = ThreadingHTTPServer((host, port), make_handler(self.data, log))
        self.httpd.daemon_threads = True
        self._thread: threading.Thread | None = None

    @property
    def url(self) -> str:
        host, port = self.httpd.server_address[:2]
        return f"http://{host!s}:{port}/"

    def start(self) -> Viewer:
        self._thread = threading.Thread(target=self.httpd.serve_forever, name="craft-viewer", daemon=True)
        self._thread.start()
        return self

    def serve_forever(self) -> None:
        self.httpd.serve_forever()

    def stop(self) -> None:
        self.httpd.shutdown()
        self.httpd.server_close()
        if self._thread is not None:
            self._thread.join(timeout=5)


__all__ = ["STATIC", "Viewer", "make_handler"]
