"""The web app: a page, a JSON endpoint to join, and one websocket per participant.

Routes:

* ``GET /`` — the page (``static/index.html``, carrying this server's page token;
  ``app.js``, ``app.css``);
* ``GET /api/study`` — the public settings: texts, the task's names, episodes;
* ``GET /api/scene/KEY`` — a 3D scene the page draws (:mod:`~hri_bench.people.serve.
  scenes`; public, the same for every participant), and ``/vendor/*.js`` the 3D library
  (``make web``);
* ``POST /api/sessions`` with ``{"consent": true}`` — join: a new session (and robot), whose
  secret token the page keeps in its ``localStorage``; 400 without consent, 503 when full;
* ``WS /ws`` — the session's channel. The first message is ``{"type": "hello", "session":
  TOKEN}``; the server answers with the current view and every new one; the page sends
  actions and ``continue`` (:mod:`hri_bench.people.serve.session`). A reload says hello again
  and resumes where the session is.

Nothing else is served: no route lists sessions or returns recordings, and a token is
needed for everything about a session. Only this server's own page can join
(:mod:`hri_bench.people.serve.access`): every request must name this server in ``Host``
(400 otherwise, against DNS rebinding); joining needs this page's ``Origin`` (403), the
page's token in ``X-HRI-Bench-Token`` (403), ``Content-Type: application/json`` (415) and
a body of at most 1 KiB (413, refused as it streams). Every refusal is a JSON body
``{"field", "error"}``. Every message is validated; a bad one gets ``{"type": "error",
"field", "error"}`` and changes nothing; a hello with an unknown token closes the
connection (code 4401). Websockets from another site's pages, or to another host, are
refused (code 4403).
"""

from __future__ import annotations

import asyncio
import contextlib
import json
import logging
from collections.abc import AsyncIterator, Awaitable, Callable
from pathlib import Path
from typing import Any

from fastapi import FastAPI, Request, WebSocket, WebSocketDisconnect
from fastapi.responses import FileResponse, JSONResponse, Response

from hri_bench.people.serve.access import TOKEN_HEADER, Access
from hri_bench.people.serve.design import ServeConfig
from hri_bench.people.serve.scenes import STORE, VENDOR, VENDOR_FILES, built
from hri_bench.people.serve.session import (
    EndedSession,
    MessageError,
    Session,
    SessionManager,
    load_json,
    parse_message,
)
from hri_envs.errors import ConfigError

__all__ = ["create_app"]

STATIC = Path(__file__).parent / "static"
log = logging.getLogger("hri_bench.serve")
#: The largest body ``POST /api/sessions`` reads, in bytes.
MAX_BODY = 1024
#: Seconds a new connection has to say hello.
HELLO_TIMEOUT_S = 10.0
#: Close codes: unknown session, bad first message, replaced by a newer connection.
CLOSE_UNKNOWN, CLOSE_BAD, CLOSE_REPLACED, CLOSE_ORIGIN = 4401, 4400, 4409, 4403

_HEADERS = {
    "Content-Security-Policy": "default-src 'self'; img-src 'self' data:; "
                               "connect-src 'self'; style-src 'self'; script-src 'self'; "
                               "frame-ancestors 'none'; base-uri 'none'; form-action 'none'",
    "X-Content-Type-Options": "nosniff",
    "Referrer-Policy": "no-referrer",
    "X-Frame-Options": "DENY",
    "Cache-Control": "no-store",
}


def _error(exc: ConfigError) -> str:
    return json.dumps({"type": "error", "field": exc.field, "error": str(exc)})


#: Where index.html carries the page token.
_TOKEN_SLOT = "{{page_token}}"


def create_app(config: ServeConfig, manager: SessionManager | None = None, *,
               port: int | None = None) -> Any:
    """The FastAPI app of ``hri-bench serve`` for ``config`` (its sessions in ``manager``,
    made here by default; :meth:`SessionManager.close` runs on shutdown). ``port`` is
    the port the server listens on (default ``config.port``): the ``Host`` it answers to.
    """
    access = Access(config.host, config.port if port is None else port,
                    config.allowed_hosts)
    sessions = manager if manager is not None else _manager(config)
    public = config.public()
    page = (STATIC / "index.html").read_text(encoding="utf-8")
    if page.count(_TOKEN_SLOT) != 1:
        raise RuntimeError(f"static/index.html must hold {_TOKEN_SLOT} once")
    page = page.replace(_TOKEN_SLOT, access.token)

    @contextlib.asynccontextmanager
    async def lifespan(_: Any) -> AsyncIterator[None]:
        yield
        await asyncio.to_thread(sessions.close)

    app = FastAPI(title="hri-bench serve", docs_url=None, redoc_url=None, openapi_url=None,
                  lifespan=lifespan)
    app.state.sessions = sessions
    app.state.access = access

    async def guard(request: Request, call_next: Any) -> Response:
        """The Host check (:mod:`~hri_bench.people.serve.access`) and every response's
        security headers (:data:`_HEADERS`).
        """
        response: Response
        host = request.headers.get("host")
        if not access.host_ok(host):
            response = JSONResponse({"field": "host", "error": _wrong_host(host)}, 400)
        else:
            response = await call_next(request)
        for name, value in _HEADERS.items():  # a route may allow caching (the scenes)
            response.headers.setdefault(name, value)
        return response

    app.middleware("http")(guard)

    @app.get("/", include_in_schema=False)
    async def index() -> Response:
        return Response(page, media_type="text/html")

    for route, (name, media) in _FILES.items():
        app.get(route, include_in_schema=False)(_file_route(name, media))
    for name in VENDOR_FILES:
        app.get(f"/vendor/{name}", include_in_schema=False)(_vendor_route(name))

    @app.get("/api/scene/{key}", include_in_schema=False)
    async def scene(key: str, request: Request) -> Response:
        return _scene(key, request)

    @app.get("/api/study")
    async def study() -> dict[str, Any]:
        return public

    @app.post("/api/sessions")
    async def join(request: Request) -> JSONResponse:
        refused = _refuse_join(request, access)
        return refused if refused is not None else await _join(request, sessions)

    @app.websocket("/ws")
    async def channel(ws: WebSocket) -> None:
        headers = ws.headers
        if not (access.host_ok(headers.get("host"))
                and access.origin_ok(headers.get("origin"), headers.get("host"),
                                     required=False)):
            await ws.close(CLOSE_ORIGIN)
            return
        await _channel(ws, sessions)

    return app


#: The page's other files: route -> (file in :data:`STATIC`, media type).
_FILES = {"/app.js": ("app.js", "text/javascript"), "/app.css": ("app.css", "text/css"),
          "/view3d.js": ("view3d.js", "text/javascript"),
          "/lead.js": ("lead.js", "text/javascript")}


def _vendor_route(name: str) -> Callable[[], Awaitable[Response]]:
    """The route of one file of the 3D library (``make web``); 404 with how to build it."""
    async def serve_file() -> Response:
        if not built():
            return JSONResponse({"field": "vendor", "error": "the page's 3D view is not "
                                 "built: run make web (npm ci) in the repository"}, 404)
        return FileResponse(VENDOR / name, media_type="text/javascript",
                            headers={"Cache-Control": "no-cache"})

    return serve_file


def _scene(key: str, request: Request) -> Response:
    """A scene description (:mod:`~hri_bench.people.serve.scenes`), gzip-compressed when the
    browser takes it; cached by the browser (its key is its content's hash).
    """
    found = STORE.get(key)
    if found is None:
        return JSONResponse({"field": "scene", "error": "no such scene"}, 404)
    text, packed = found
    headers = {"Cache-Control": "private, max-age=86400, immutable", "Vary": "Accept-Encoding"}
    if "gzip" in request.headers.get("accept-encoding", ""):
        return Response(packed, media_type="application/json",
                        headers={**headers, "Content-Encoding": "gzip"})
    return Response(text, media_type="application/json", headers=headers)


def _manager(config: ServeConfig) -> SessionManager:
    """The sessions of a graph task, or of a physical one (:mod:`~hri_bench.people.serve.
    lead_session`).
    """
    if config.physical:
        from hri_bench.people.serve.lead_session import LeadSessionManager  # noqa: PLC0415

        return LeadSessionManager(config)
    return SessionManager(config)


def _wrong_host(host: str | None) -> str:
    shown = "none" if host is None else repr(host[:80])
    return (f"this server does not answer to the host {shown} (a page reached by another "
            "name is refused, against DNS rebinding); open the address serve printed, or "
            "start serve with --allow-host NAME for a name of this machine")


def _refuse_join(request: Request, access: Access) -> JSONResponse | None:
    """Why a join does not come from this server's page (a JSON refusal), or None."""
    headers = request.headers
    if not access.origin_ok(headers.get("origin"), headers.get("host"), required=True):
        origin = headers.get("origin")
        return JSONResponse({"field": "origin", "error": (
            "join from the study's page: this request has "
            + ("no Origin" if origin is None else f"the Origin {origin[:80]!r}")
            + ", not the page's")}, 403)
    if not access.token_ok(headers.get(TOKEN_HEADER)):
        return JSONResponse({"field": "token", "error": (
            f"join from the study's page: the {TOKEN_HEADER} header must carry the page's "
            "token (reload the page if the server restarted)")}, 403)
    kind = headers.get("content-type", "").split(";")[0].strip().lower()
    if kind != "application/json":
        return JSONResponse({"field": "content-type", "error": (
            f"the body must be application/json, got {kind[:60] or 'no Content-Type'!r}")},
            415)
    return None


def _file_route(name: str, media: str) -> Callable[[], Awaitable[FileResponse]]:
    """The route of one static file."""
    async def serve_file() -> FileResponse:
        return FileResponse(STATIC / name, media_type=media)

    return serve_file


async def _read_body(request: Request) -> bytes | JSONResponse:
    """The request's body, at most :data:`MAX_BODY` bytes; a 413 refusal for a longer one,
    told by its ``Content-Length`` before anything is read, else as soon as the streamed
    count passes the cap (the rest is never read).
    """
    def refuse(status: int, error: str) -> JSONResponse:
        return JSONResponse({"field": "body", "error": error}, status)

    too_long = f"the body is at most {MAX_BODY} bytes (send {{\"consent\": true}})"
    declared = request.headers.get("content-length")
    if declared is not None:
        if not declared.isdigit() or len(declared) > 18:
            return refuse(400, "Content-Length must be a whole number of bytes")
        if int(declared) > MAX_BODY:
            return refuse(413, too_long)
    body = bytearray()
    async for chunk in request.stream():
        body += chunk
        if len(body) > MAX_BODY:
            return refuse(413, too_long)
    return bytes(body)


async def _join(request: Request, sessions: SessionManager) -> JSONResponse:
    """``POST /api/sessions``: a new session with consent; 400 without, 503 when full."""
    body = await _read_body(request)
    if isinstance(body, JSONResponse):
        return body
    try:
        doc = load_json(body, "the body")
    except MessageError as exc:
        if exc.field == "message":
            doc = None
        else:  # a key given twice
            return JSONResponse({"field": exc.field, "error": str(exc)}, 400)
    if not isinstance(doc, dict) or set(doc) != {"consent"} or doc["consent"] is not True:
        return JSONResponse({"field": "consent", "error": "send {\"consent\": true} to "
                             "take part; nothing is recorded without it"}, 400)
    try:
        session = await asyncio.to_thread(sessions.create)
    except ConfigError as exc:
        return JSONResponse({"field": exc.field, "error": str(exc)}, 503)
    except OSError as exc:  # the session's folder cannot be written (a full disk, say)
        log.error("cannot record a new session: %s", exc)
        return JSONResponse({"field": "sessions", "error": "the study cannot record a new "
                             "session now; tell the experimenter"}, 503)
    return JSONResponse({"session": session.token}, 201)


async def _channel(ws: WebSocket, sessions: SessionManager) -> None:
    """``WS /ws`` (its Host and Origin checked): this site's page says hello with its
    session's token; then the session's views go out and the page's messages come in
    (:func:`_relay`).
    """
    await ws.accept()
    msg = await _hello(ws)
    if msg is None:
        return
    session = sessions.get(msg["session"])
    if session is None:
        await ws.send_text(_error(MessageError(
            "unknown session: join from the start page", field="session")))
        await ws.close(CLOSE_UNKNOWN)
        return
    await _relay(ws, session)


async def _hello(ws: WebSocket) -> dict[str, Any] | None:
    """The first message, a hello; None (the connection closed, code 4400) for anything
    else or nothing within :data:`HELLO_TIMEOUT_S`.
    """
    try:
        text = await asyncio.wait_for(ws.receive_text(), HELLO_TIMEOUT_S)
        msg = parse_message(text)
        if msg["type"] != "hello":
            raise MessageError("say hello first: {\"type\": \"hello\", \"session\": TOKEN}",
                               field="type")
    except (TimeoutError, MessageError, KeyError, WebSocketDisconnect) as exc:
        with contextlib.suppress(Exception):
            if isinstance(exc, MessageError):
                await ws.send_text(_error(exc))
            await ws.close(CLOSE_BAD)
        return None
    return msg


async def _relay(ws: WebSocket, session: Session | EndedSession) -> None:
    """Send the session's views and pass the page's messages on until the page leaves, a
    newer connection of the session replaces this one (told, code 4409), or the session's
    last view (``done``, ``ended``) is sent (closed, code 1000: the server keeps nothing
    of the session for the page).
    """
    loop = asyncio.get_running_loop()
    changed = asyncio.Event()
    replaced = asyncio.Event()
    send_lock = asyncio.Lock()

    def on_view() -> None:
        loop.call_soon_threadsafe(changed.set)

    def on_replaced() -> None:
        loop.call_soon_threadsafe(replaced.set)

    unsubscribe = session.subscribe(on_view)
    owner = session.connect(on_replaced)
    tasks = [asyncio.ensure_future(_send_views(ws, session, changed, send_lock)),
             asyncio.ensure_future(_receive(ws, session, send_lock)),
             asyncio.ensure_future(replaced.wait())]
    try:
        done, _ = await asyncio.wait(tasks, return_when=asyncio.FIRST_COMPLETED)
        if tasks[2] in done:
            with contextlib.suppress(Exception):
                await ws.send_text(json.dumps({"type": "replaced"}))
                await ws.close(CLOSE_REPLACED)
        elif tasks[0] in done and tasks[0].exception() is None:
            with contextlib.suppress(Exception):
                await ws.close(1000)
    finally:
        for t in tasks:
            t.cancel()
        unsubscribe()
        session.disconnect(owner)
        for t in tasks:
            with contextlib.suppress(BaseException):
                await t


async def _send_views(ws: WebSocket, session: Session | EndedSession, changed: asyncio.Event,
                      send_lock: asyncio.Lock) -> None:
    """Send each new view of the session once, waiting for ``changed`` in between; return
    once the last one (``done``, ``ended``) is sent.
    """
    sent = -1
    while True:
        seq, text = session.view()
        if seq != sent:
            async with send_lock:
                await ws.send_text(text)
            sent = seq
            if seq == session.final_seq:
                return
        changed.clear()
        if session.view()[0] == sent:
            await changed.wait()


async def _receive(ws: WebSocket, session: Session | EndedSession,
                   send_lock: asyncio.Lock) -> None:
    """Hand each message of the page to the session; a bad one is answered with an error."""
    while True:
        text = await ws.receive_text()
        try:
            session.handle(parse_message(text))
        except MessageError as exc:
            async with send_lock:
                await ws.send_text(_error(exc))
