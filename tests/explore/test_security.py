"""The explorer's server keeps other users out: it listens on 127.0.0.1 alone, refuses every
request without its token (the page, its websocket, a wrong token) and any file but the
one it was given."""

from __future__ import annotations

import socket
import urllib.error
import urllib.request

import pytest
from explore_server import server, small_file  # noqa: F401 (fixtures)

pytestmark = pytest.mark.slow


def test_the_server_keeps_others_out(server):
    """One server (one xdist worker), every check in turn."""
    the_page_needs_the_token(server)
    the_token_in_a_cookie_is_the_token(server)
    only_the_given_file_is_served(server)
    the_server_listens_on_loopback_alone(server)


def status(url, headers=None) -> int:
    req = urllib.request.Request(url, headers=headers or {})
    try:
        with urllib.request.urlopen(req, timeout=30) as r:
            return r.status
    except urllib.error.HTTPError as e:
        return e.code


def the_page_needs_the_token(server):
    assert status(server.url) == 200
    assert status(server.base) == 403
    assert status(server.base + "?token=" + "x" * len(server.token)) == 403
    assert status(server.base + "?token=") == 403
    # the websocket of a session: refused before any session is made
    assert status(server.base + "ws", {"Connection": "Upgrade", "Upgrade": "websocket"}) in (
        400, 403)


def the_token_in_a_cookie_is_the_token(server):
    assert status(server.base, {"Cookie": f"cornerbif_explore_{server.port}={server.token}"}) \
        == 200
    assert status(server.base, {"Cookie": f"cornerbif_explore_{server.port}=wrong"}) == 403


def only_the_given_file_is_served(server):
    assert status(server.url + "&file=fig06a_small.h5") == 200
    assert status(server.url + "&file=0") == 200
    for other in ("/etc/passwd", "../fig06a_small.h5", "1", "x.h5", "%2Fetc%2Fpasswd"):
        assert status(server.url + "&file=" + other) == 403, other
    # nor any path of the server's own
    for path in ("etc/passwd", "static/../../etc/passwd", "..%2f..%2fetc%2fpasswd"):
        assert status(server.base + path + "?token=" + server.token) in (403, 404), path


def _listening(port) -> list:
    """The local addresses of the sockets listening on ``port`` (Linux: /proc/net/tcp*)."""
    out = []
    for table, size in (("/proc/net/tcp", 8), ("/proc/net/tcp6", 32)):
        try:
            lines = open(table).read().splitlines()[1:]
        except OSError:
            continue
        for line in lines:
            local, state = line.split()[1], line.split()[3]
            addr, p = local.split(":")
            if state == "0A" and int(p, 16) == port:          # LISTEN
                out.append(addr if size == 32 else socket.inet_ntoa(bytes.fromhex(addr)[::-1]))
    return out


def _other_addresses() -> set:
    """This machine's IPv4 addresses that are not loopback."""
    found = set()
    try:
        for info in socket.getaddrinfo(socket.gethostname(), None, socket.AF_INET):
            found.add(info[4][0])
    except OSError:
        pass
    try:
        with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as s:
            s.connect(("10.255.255.255", 1))         # no packet is sent: the route's source
            found.add(s.getsockname()[0])
    except OSError:
        pass
    return {a for a in found if not a.startswith("127.")}


def the_server_listens_on_loopback_alone(server):
    listening = _listening(server.port)
    if listening:             # Linux: the listening sockets themselves
        assert listening == ["127.0.0.1"], listening
    others = _other_addresses()
    for addr in others:
        with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as s:
            s.settimeout(3)
            assert s.connect_ex((addr, server.port)) != 0, f"reachable on {addr}"
    assert listening or others, "no /proc/net/tcp and no other interface here to try"
