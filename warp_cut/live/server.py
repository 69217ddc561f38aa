"""The local web server of ``warp-cut live`` and ``warp-cut view`` (viser), and waiting for Ctrl-C.

The server binds 127.0.0.1 unless asked otherwise; port 0 lets the system choose a free port.
A port that is taken is an error (viser would silently move to the next one).
"""

from __future__ import annotations

import ipaddress
import signal
import socket
import sys
import threading

from ..errors import InputError

__all__ = ["start_server", "check_port", "server_url", "wait_for_interrupt", "import_viser",
           "is_loopback", "warn_if_exposed"]


def is_loopback(host: str) -> bool:
    """Whether ``host`` keeps the server on this machine (localhost, 127.0.0.0/8, ::1)."""
    if host == "localhost":
        return True
    try:
        return ipaddress.ip_address(host).is_loopback
    except ValueError:
        return False


def warn_if_exposed(host: str) -> bool:
    """Print a warning on stderr if ``host`` is not a loopback address; returns whether it did."""
    if is_loopback(host):
        return False
    print(f"warp-cut: warning: serving on {host}, reachable from other machines; the page "
          "lets anyone who reaches it drive the simulation and write files here", file=sys.stderr)
    return True


def import_viser():
    """The viser module, or InputError saying how to install it (an optional dependency)."""
    try:
        import viser  # noqa: PLC0415 - needs viser, an optional dependency (live extra)
    except ImportError as exc:
        raise InputError("the browser viewer needs the optional 'live' extra: "
                         "pip install -e '.[live]' (or: make live)") from exc
    return viser


def check_port(host: str, port: int) -> None:
    """InputError unless ``port`` is an integer in [0, 65535] that is free on ``host``."""
    if isinstance(port, bool) or not isinstance(port, int) or not 0 <= port <= 65535:
        raise InputError(f"--port must be an integer in [0, 65535] (0: any free port), got {port!r}")
    if port == 0:
        return
    try:
        infos = socket.getaddrinfo(host, port, type=socket.SOCK_STREAM)
    except socket.gaierror as exc:
        raise InputError(f"--host {host}: not an address of this machine ({exc})") from None
    family, _, _, _, address = infos[0]
    with socket.socket(family, socket.SOCK_STREAM) as probe:
        try:
            probe.bind(address)
        except OSError as exc:
            raise InputError(f"--port {port}: cannot listen on {host}:{port} ({exc.strerror}); "
                             "choose another port, or --port 0 for any free one") from None


def start_server(host: str = "127.0.0.1", port: int = 0, *, label: str = "warp_cut"):
    """A running viser server on host:port. Raises InputError if the port is taken or viser
    is not installed; warns on stderr when the host is not a loopback address."""
    viser = import_viser()
    check_port(host, port)
    warn_if_exposed(host)
    server = viser.ViserServer(host=host, port=port, label=label, verbose=False)
    if port and server.get_port() != port:  # taken between the check and the bind
        server.stop()
        raise InputError(f"--port {port}: taken by another program; choose another port")
    return server


def server_url(server) -> str:
    """The page's address."""
    host = server.get_host()
    return f"http://{f'[{host}]' if ':' in host else host}:{server.get_port()}"


def wait_for_interrupt(ready=None) -> None:
    """Block until Ctrl-C (SIGINT) or SIGTERM (main thread only). ``ready`` (no arguments) is
    called once the signals are caught, e.g. to print the address a user will then interrupt:
    printed before, a Ctrl-C right after it would land outside and end in a traceback."""
    stop = threading.Event()
    handler = lambda signum, frame: stop.set()  # noqa: E731
    previous = {s: signal.signal(s, handler) for s in (signal.SIGINT, signal.SIGTERM)}
    try:
        if ready is not None:
            ready()
        while not stop.wait(0.5):
            pass
    finally:
        for s, old in previous.items():
            signal.signal(s, old)
