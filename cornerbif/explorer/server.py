"""The explorer's server: Panel on a Bokeh server bound to 127.0.0.1 only, every request
(the page, its websocket) refused with 403 unless it carries the server's random token, in
the URL (``?token=``, as Jupyter's) or in the cookie the first such request sets.  The page
opens only the files the server was given (``?file=`` names one of them, by index or base
name; any other value is refused with 403), and the page sends no code: its widgets call
the page's methods (``app.Page``)."""

from __future__ import annotations

import hmac
import os
import secrets
import socket
import tempfile
import webbrowser

import panel as pn
from bokeh.server.auth_provider import AuthProvider
from tornado.web import HTTPError

from ..config import load
from ..outputs import default_output
from ..sweep import run_sweep
from .app import Files
from .session import page_for

ADDRESS = "127.0.0.1"


class TokenAuth(AuthProvider):
    """Bokeh's auth hook: a request is let in when its ``token`` argument or its cookie
    holds ``token`` (compared in constant time) and its ``file`` argument, if any, names
    one of ``files``; else 403."""

    def __init__(self, token: str, files: Files, cookie: str):
        self.token = token
        self.files = files
        self.cookie = cookie
        super().__init__()

    @property
    def get_user(self):
        def user(handler):
            given = handler.get_argument("token", None)
            ok = given is not None and hmac.compare_digest(given, self.token)
            if ok:
                handler.set_cookie(self.cookie, self.token, httponly=True, samesite="Strict")
            else:
                held = handler.get_cookie(self.cookie)
                ok = held is not None and hmac.compare_digest(held, self.token)
            if ok and self.files.index(handler.get_argument("file", None)) is None:
                raise HTTPError(403, "this server serves only the files it was given")
            return "explorer" if ok else None
        return user

    @property
    def get_login_url(self):
        def refused(handler):
            raise HTTPError(403, "a cornerbif explore server needs the token of its URL")
        return refused


def free_port() -> int:
    """A port free on 127.0.0.1 now."""
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as s:
        s.bind((ADDRESS, 0))
        return s.getsockname()[1]


def session_page(files: Files):
    """A new session's page: the file its URL names (``?file=``), else the first."""
    args = pn.state.session_args or {}
    name = (args.get("file") or [b""])[0]
    k = files.index(name.decode("utf-8", "replace") if isinstance(name, bytes) else name)
    return page_for(files, k or 0).view()


def make_server(paths, port: int = 0, side_dir: str | None = None, token: str | None = None):
    """A Bokeh server (not started) for ``paths`` on 127.0.0.1:``port`` (0: a free one):
    (server, url with the token, Files)."""
    side_dir = side_dir or tempfile.mkdtemp(prefix="cornerbif-explore-")
    files = Files(paths, side_dir)
    for k in range(len(files.paths)):
        files.get(k)                   # read before serving: a bad file is said at once
    token = token or secrets.token_urlsafe(24)
    port = port or free_port()
    auth = TokenAuth(token, files, f"cornerbif_explore_{port}")
    server = pn.serve({"/": lambda: session_page(files)}, port=port, address=ADDRESS,
                      websocket_origin=[f"{ADDRESS}:{port}", f"localhost:{port}"],
                      show=False, start=False, title="cornerbif explore",
                      auth_provider=auth, sign_sessions=True,
                      secret_key=secrets.token_urlsafe(32), generate_session_ids=True,
                      check_unused_sessions=10_000, unused_session_lifetime=60_000)
    return server, f"http://{ADDRESS}:{port}/?token={token}", files


def serve(paths, port: int = 0, browser: bool = True, echo=print, side_dir=None):
    """Serve ``paths`` until interrupted: the URL said (``echo``), the browser opened on it
    unless ``browser`` is false."""
    server, url, files = make_server(paths, port, side_dir)
    echo(f"cornerbif explore: {url}")
    echo(f"side files (refines, continuations, saved views) in {files.side_dir}")
    echo("Ctrl-C stops the server")
    server.start()
    if browser:
        server.io_loop.add_callback(lambda: webbrowser.open(url))
    try:
        server.io_loop.start()
    except KeyboardInterrupt:
        pass
    finally:
        server.stop()
    return files.side_dir


def sweep_first(scene_path: str, echo=print) -> str:
    """A scene swept for the explorer: its output beside the scene file (its default name),
    or in a temporary folder when that one cannot be written; an output of the same scene
    already there is reused (``--resume`` semantics)."""
    scene = load(scene_path)
    folder = os.path.dirname(os.path.abspath(scene_path))
    if not os.access(folder, os.W_OK):
        folder = tempfile.mkdtemp(prefix="cornerbif-explore-")
    out = os.path.join(folder, default_output(scene))
    echo(f"sweeping {scene_path} into {out} first")
    run_sweep(scene, out, resume=True, progress=True, inputs=(scene_path,),
              command=f"cornerbif explore {scene_path}", echo=echo)
    return out
