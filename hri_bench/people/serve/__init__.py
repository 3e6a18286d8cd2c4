"""``hri-bench serve``: a person plays the human in a browser; every session is recorded.

==============  ====================================================================
module          contents
==============  ====================================================================
``design``      :class:`ServeConfig` (the server's settings), the counterbalanced design
``access``      who may call: the ``Host`` it answers to, the ``Origin`` that may join, the
                page's token
``session``     a participant's session: the benchmark loop in a thread, the person in the
                human's seat, the messages a page may send
``store``       the dataset folder: one server at a time, sessions a killed server left
                running marked interrupted, recordings private to the user
``robot``       the robot's calls, made in a thread of their own with a time limit: an
                agent that raises, exits or hangs ends its session only
``app``         the FastAPI app: the page, joining, the websocket (the pictures:
                :mod:`hri_bench.core.pictures`)
``static/``     the page (HTML, JavaScript, CSS; no external resources)
==============  ====================================================================

Run it with ``hri-bench serve hanger --data out/datasets`` and open the printed address;
docs/people.md has the rest. Needs the ``web`` extra.
"""

from __future__ import annotations

import os
import socket
import sys
from collections.abc import Callable
from typing import Any

from agents.learning import algorithm1
from hri_bench.people.serve.design import ServeConfig
from hri_envs.errors import MissingExtraError

__all__ = ["ServeConfig", "require_web", "serve"]


def require_web(what: str) -> None:
    """Raise :class:`~hri_envs.errors.MissingExtraError` (one line: the install command)
    unless the ``web`` extra's server and data packages are installed.
    """
    MissingExtraError.require(["fastapi", "uvicorn", "pyarrow", "minari"], what)


def _bind(host: str, port: int) -> socket.socket:
    """A listening socket on ``host``:``port`` (IPv6 when the host is one)."""
    family = socket.AF_INET6 if ":" in host else socket.AF_INET
    sock = socket.socket(family, socket.SOCK_STREAM)
    sock.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
    sock.bind((host, port))
    sock.listen(128)
    return sock


def serve(config: ServeConfig, *, announce: Callable[[str], None] | None = None) -> None:
    """Serve the study until interrupted (Ctrl-C, SIGTERM); every session is stopped and
    recorded as such on the way out.

    Args:
        config: The settings.
        announce: Told what it is doing (loading the kernels) and the address once the
            server listens (default: printed).

    Raises:
        MissingExtraError: The ``web`` extra is not installed.
        OSError: The address cannot be bound.
        ConfigError: Another server records into the dataset (``field="dataset"``), or
            its folder cannot be used (``field="data"``).
    """
    require_web("hri-bench serve")
    import uvicorn  # the web extra, as the app (FastAPI) below

    from hri_bench.people.serve.app import create_app

    say = announce or (lambda text: print(text, flush=True))
    umask = os.umask(0o077)  # recordings are the user's only (store.py), from their start
    try:
        _serve(config, say, uvicorn, create_app)
    finally:
        os.umask(umask)


def _serve(config: ServeConfig, say: Callable[[str], None], uvicorn: Any,
           create_app: Callable[..., Any]) -> None:
    """:func:`serve` once the web extra is loaded."""
    if config.agent in ("learner", "maxent") and not config.physical:
        # the first participant does not wait for the kernels; compiling them the first
        # time (numba caches them on disk) takes a minute or more
        say("hri-bench serve: loading the robot's compiled kernels (the first time after "
            "installing, they are compiled: a minute or more)")
        algorithm1.preload()
    if config.spec.layout is None and not config.physical:
        # one view per state for all (MuJoCo draws them: the mujoco extra, which make serve
        # installs; imported here so that the CLI runs without it)
        from hri_bench.people.serve.scenes import graph_view  # noqa: PLC0415

        graph = config.graph
        for state in range(graph.n_states):
            graph_view(graph, None, state, max(0, int(graph.support[state])))
    sock = _bind(config.host, config.port)
    host, port = sock.getsockname()[:2]
    try:
        app = create_app(config, port=port)  # it answers to the port it listens on
    except BaseException:
        sock.close()
        raise
    shown = f"[{host}]" if ":" in host else host
    url = f"http://{shown}:{port}/"
    remote = ("" if config.local_only else
              "  (reachable from other machines: plain HTTP, unencrypted)\n"
              "answering to " + ", ".join(app.state.access.allowed()) +
              " (name others with --allow-host)")
    marked = app.state.sessions.interrupted
    ready = (
        f"hri-bench serve: {config.scenario}, robot {config.agent}, {config.episodes} episodes "
        f"per session; recording to {app.state.sessions.dataset.path} (private to you)\n"
        + (f"marked {len(marked)} session(s) that a stopped server left running as "
           f"interrupted: {', '.join(marked)}\n" if marked else "")
        + f"serving on {url}" + remote)

    class Server(uvicorn.Server):
        """Says where it serves once it does, and once Ctrl-C stops it: uvicorn handles the
        signals by then. Said earlier, a Ctrl-C right after the address could reach asyncio's
        own handler before uvicorn's, and cancel the start-up without stopping the server.
        """

        async def startup(self, sockets: list[Any] | None = None) -> None:
            await super().startup(sockets=sockets)
            say(ready)

    server = Server(uvicorn.Config(app, log_level="warning", ws_max_size=4096,
                                   access_log=False, lifespan="on"))
    try:
        server.run(sockets=[sock])
    finally:
        sock.close()
        sys.stdout.flush()

