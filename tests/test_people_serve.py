"""``hri-bench serve`` without a browser: the app through Starlette's test client. Whole
sessions, reloads, isolation between participants, and bad or forged messages, each of
which must get a clear error and change nothing."""

import json
import os
import re
import threading
import time

import numpy as np
import pytest

pytest.importorskip("fastapi")
pytest.importorskip("pyarrow")

from fastapi.testclient import TestClient  # noqa: E402
from starlette.websockets import WebSocketDisconnect  # noqa: E402

from hri_bench.cli import main  # noqa: E402
from hri_bench.data.datasets import open_dataset  # noqa: E402
from hri_bench.data.replay import replay  # noqa: E402
from hri_bench.people.serve.app import create_app  # noqa: E402
from hri_bench.people.serve.design import (  # noqa: E402
    ServeConfig,
    assignment,
    describe_preference,
    pair_circuit,
)
from hri_bench.people.serve.launch import start_serve, stop_serve  # noqa: E402
from hri_bench.people.serve.scenes import built  # noqa: E402
from hri_bench.people.serve.session import parse_message  # noqa: E402
from hri_bench.run.isolation import IN_PROCESS  # noqa: E402
from hri_envs.errors import ConfigError  # noqa: E402
from hri_envs.humans.scripted import preference_human  # noqa: E402
from hri_envs.task.scenarios import scenario_graph, scenario_spec  # noqa: E402
from tests.helpers_agents import AlwaysWait  # noqa: E402

pytestmark = pytest.mark.xdist_group("people-serve")


def _client(tmp_path, **kw):
    """A server whose page is reached as the test client's ``http://testserver``."""
    cfg = ServeConfig(kw.pop("scenario", "hanger"), data=tmp_path, max_steps=40,
                      **{"episodes": 2, "allowed_hosts": ("testserver",), **kw})
    return cfg, TestClient(create_app(cfg))


def _page_headers(client):
    """What the served page sends with its join: its Origin, its token, JSON."""
    page = client.get("/")
    token = re.search(r'<meta name="hri-bench-token" content="([^"]+)">', page.text).group(1)
    return {"origin": "http://testserver", "x-hri-bench-token": token,
            "content-type": "application/json"}


def _post(client, body, **headers):
    return client.post("/api/sessions", content=json.dumps(body).encode(),
                       headers={**_page_headers(client), **headers})


def _join(client):
    r = _post(client, {"consent": True})
    assert r.status_code == 201, r.text
    return r.json()["session"]


def _hello(ws, token):
    ws.send_text(json.dumps({"type": "hello", "session": token}))
    return _next_view(ws)


def _next_view(ws):
    while True:
        m = json.loads(ws.receive_text())
        if m["type"] != "wait":
            return m


def _answer(ws, m, scenario="hanger"):
    """The scripted human's answer to a view: its preferred action, or continue."""
    if m["type"] == "frame":
        human = preference_human(scenario_graph(scenario), None)
        a = int(human.preferred_action(m["state"], m["start"], m["goal"]))
        ws.send_text(json.dumps({"type": "action", "seq": m["seq"], "action": a, "rt_ms": 250}))
    elif m["type"] == "outcome" and not m["last"]:
        ws.send_text(json.dumps({"type": "continue", "seq": m["seq"]}))


def _play(ws, m, scenario="hanger", steps=10_000):
    while m["type"] not in ("done", "ended") and steps > 0:
        _answer(ws, m, scenario)
        m = _next_view(ws)
        steps -= 1
    return m


@pytest.mark.parametrize("scenario", ["hanger", "wheel"])
def test_a_whole_session_is_played_recorded_and_replays(tmp_path, scenario):
    cfg, client = _client(tmp_path, scenario=scenario)
    with client:
        token = _join(client)
        with client.websocket_connect("/ws") as ws:
            first = _hello(ws, token)
            assert first["type"] == "frame"
            if built():  # the 3D view: the scene's description by key, the bodies' poses
                scene = client.get(f"/api/scene/{first['scene']}").json()
                assert len(first["poses"]) == 7 * len(scene["bodies"])
                assert {"eye", "target", "labels", "seats"} <= set(first["camera"])
            else:  # the 2D picture, and the page says how to build the 3D view
                assert first["picture"].startswith("data:image/png")
            assert first["episode"] == 1 and first["goal_name"] in ("A", "B", "C")
            assert [o["key"] for o in first["options"]] == ["1", "2"]
            done = _play(ws, first, scenario)
    assert done["type"] == "done" and len(done["outcomes"]) == 2
    assert all(o["success"] for o in done["outcomes"])
    dataset = open_dataset(cfg.dataset_id, tmp_path)
    assert not dataset.synthetic and dataset.participants() == [done["participant"]]
    meta = dataset.sessions()[0]
    assert meta["status"] == "complete" and meta["source"] == "web" and meta["agent"] == "learner"
    assert meta["serve_settings"]["consent_sha256"] == cfg.text_hashes()["consent_sha256"]
    assert meta["serve_settings"]["episodes"] == 2
    text = json.dumps(meta)
    assert token not in text and "127.0.0.1" not in text and "testclient" not in text
    table = dataset.steps()
    assert set(table.column("client_response_ms").to_pylist()) == {250.0}
    assert all(len(b) == 3 for b in table.column("belief").to_pylist())
    results = replay(dataset)
    assert len(results) == 2 and all(r.agrees for r in results)
    assert [float(r.recorded.sum()) for r in results] == pytest.approx(
        [o["reward"] for o in done["outcomes"]], abs=1e-4)
    if scenario == "wheel":
        assert len(table.column("layout").to_pylist()[0]) == 4


BAD = [
    ("not json", "message"),
    ("[1, 2]", "message"),
    ('{"type": "fly"}', "type"),
    ("x" * 5000, "message"),
    ('{"type": "action", "seq": SEQ, "action": 99, "rt_ms": null}', "action"),
    ('{"type": "action", "seq": SEQ, "action": 3, "rt_ms": null}', "action"),
    ('{"type": "action", "seq": SEQ, "action": -1, "rt_ms": null}', "action"),
    ('{"type": "action", "seq": SEQ, "action": true, "rt_ms": null}', "action"),
    ('{"type": "action", "seq": SEQ, "action": 1.0, "rt_ms": null}', "action"),
    ('{"type": "action", "seq": SEQ, "action": "1", "rt_ms": null}', "action"),
    ('{"type": "action", "seq": SEQ, "action": 1, "rt_ms": -5}', "rt_ms"),
    ('{"type": "action", "seq": SEQ, "action": 1, "rt_ms": "fast"}', "rt_ms"),
    ('{"type": "action", "seq": SEQ, "action": 1, "rt_ms": 1, "who": "me"}', "who"),
    ('{"type": "action", "seq": 99999, "action": 1, "rt_ms": null}', "seq"),
    ('{"type": "action", "seq": -1, "action": 1, "rt_ms": null}', "seq"),
    ('{"type": "continue", "seq": SEQ}', "type"),
    ('{"type": "hello", "session": "OTHER"}', "type"),
    # every field is required (rt_ms may be null, but not left out), and given once
    ('{"type": "action", "seq": SEQ, "action": 1}', "rt_ms"),
    ('{"type": "action", "action": 1, "rt_ms": null}', "seq"),
    ('{"type": "action", "seq": SEQ, "action": 3, "action": 1, "rt_ms": null}', "action"),
    ('{"type": "action", "seq": SEQ, "seq": SEQ, "action": 1, "rt_ms": null}', "seq"),
    ('{"type": "fly", "type": "action", "seq": SEQ, "action": 1, "rt_ms": null}', "type"),
]


def test_bad_and_forged_messages_get_an_error_and_change_nothing(tmp_path):
    cfg, client = _client(tmp_path, episodes=1)
    with client:
        other = _join(client)
        token = _join(client)
        with client.websocket_connect("/ws") as ws:
            first = _hello(ws, token)
            for text, field in BAD:
                ws.send_text(text.replace("SEQ", str(first["seq"])).replace("OTHER", other))
                reply = json.loads(ws.receive_text())
                assert reply["type"] == "error" and reply["field"] == field, (text, reply)
                assert reply["error"]
            # nothing changed: the same view answers, and the session plays on from it
            ws.send_text(json.dumps({"type": "action", "seq": first["seq"], "action": 1,
                                     "rt_ms": None}))
            second = _next_view(ws)
            assert second["type"] == "frame" and second["seq"] == first["seq"] + 1
            assert second["step"] == 2
            done = _play(ws, second)
    assert done["type"] == "done"
    dataset = open_dataset(cfg.dataset_id, tmp_path)
    steps = dataset.steps(participants=[done["participant"]])
    assert steps.column("human_action").to_pylist()[0] == 1  # the first valid answer
    assert steps.num_rows == done["outcomes"][0]["steps"]
    # the other participant's session never moved: never played, it left no folder
    assert dataset.participants() == [done["participant"]]


@pytest.mark.parametrize("first, code", [
    ({"type": "hello", "session": "x" * 43}, 4401),        # a forged token
    ({"type": "hello", "session": "short"}, 4400),          # not even a token
    ({"type": "action", "seq": 1, "action": 1, "rt_ms": None}, 4400),  # no hello first
])
def test_a_forged_or_missing_session_is_refused(tmp_path, first, code):
    _, client = _client(tmp_path)
    with client:
        _join(client)
        with client.websocket_connect("/ws") as ws:
            ws.send_text(json.dumps(first))
            reply = json.loads(ws.receive_text())
            assert reply["type"] == "error" and reply["field"] in ("session", "type")
            with pytest.raises(WebSocketDisconnect) as closed:
                ws.receive_text()
            assert closed.value.code == code


def test_participants_cannot_reach_each_other(tmp_path):
    cfg, client = _client(tmp_path, episodes=1)
    with client:
        a, b = _join(client), _join(client)
        assert a != b
        with client.websocket_connect("/ws") as wa, client.websocket_connect("/ws") as wb:
            fa, fb = _hello(wa, a), _hello(wb, b)
            sessions = client.app.state.sessions
            sa, sb = sessions.get(a), sessions.get(b)
            assert sa.agent is not sb.agent and sa.participant != sb.participant
            assert sa.design.index != sb.design.index
            # b answers with a's sequence number: judged against b's own view only
            _answer(wb, fb)
            fb2 = _next_view(wb)
            assert fb2["seq"] == fb["seq"] + 1
            assert sa.view()[0] == fa["seq"]  # a did not move
            _play(wa, fa)
        for path in ("/api/sessions", f"/api/sessions/{a}", "/data", "/api/datasets"):
            assert client.get(path).status_code in (404, 405)
    dataset = open_dataset(cfg.dataset_id, tmp_path)
    assert len(dataset.episode_paths([sa.participant])) == 1
    assert len(dataset.episode_paths([sb.participant])) == 0


def test_a_reload_resumes_and_a_second_tab_takes_over(tmp_path):
    _, client = _client(tmp_path, episodes=1)
    with client:
        token = _join(client)
        with client.websocket_connect("/ws") as ws:
            m = _hello(ws, token)
            _answer(ws, m)
            m = _next_view(ws)
        with client.websocket_connect("/ws") as ws:  # the page reloaded
            again = _hello(ws, token)
            assert again == m
            with client.websocket_connect("/ws") as tab:
                assert _hello(tab, token) == m
                assert json.loads(ws.receive_text())["type"] == "replaced"
                done = _play(tab, m)
    assert done["type"] == "done"


def test_a_crashed_session_loses_no_step_of_the_others(tmp_path, monkeypatch):
    """Two participants; the second one's robot raises in its second episode. That session
    ends (``failed``, its first episode kept); the first participant's episode already
    written stays as it was, and the session plays on to the end. (The agent counts its
    instances in a class attribute: it is made in the server's process, where that count is
    shared; in processes of their own, each session's would start at 0.)"""
    from tests.helpers_agents import SecondMadeCrashes

    monkeypatch.setenv(IN_PROCESS, "1")
    SecondMadeCrashes.made = 0
    cfg, client = _client(tmp_path, agent="tests.helpers_agents:SecondMadeCrashes")
    with client:
        a, b = _join(client), _join(client)
        with client.websocket_connect("/ws") as wa, client.websocket_connect("/ws") as wb:
            ma, mb = _hello(wa, a), _hello(wb, b)
            while ma["type"] == "frame":  # a's first episode
                _answer(wa, ma)
                ma = _next_view(wa)
            assert ma["type"] == "outcome"
            dataset = open_dataset(cfg.dataset_id, tmp_path)
            pa_, pb_ = (client.app.state.sessions.get(t).participant for t in (a, b))
            deadline = time.monotonic() + 10  # a's first episode is written meanwhile
            while not dataset.episode_paths([pa_]) and time.monotonic() < deadline:
                time.sleep(0.01)
            (first,) = dataset.episode_paths([pa_])
            written = first.read_bytes()
            ended = _play(wb, mb)  # b's robot crashes as b's second episode starts
            assert ended["type"] == "ended" and ended["reason"] == "failed"
            done = _play(wa, ma)
    assert done["type"] == "done" and SecondMadeCrashes.made == 2
    assert first.read_bytes() == written
    assert len(dataset.episode_paths([pa_])) == 2 and len(dataset.episode_paths([pb_])) == 1
    assert {s["participant"]: s["status"] for s in dataset.sessions()} == {
        pa_: "complete", pb_: "failed"}
    assert not [p for p in tmp_path.rglob("*") if ".tmp" in p.name]
    rows = dataset.steps()
    assert rows.num_rows == sum(o["steps"] for o in done["outcomes"]) + len(
        dataset.steps(participants=[pb_]))
    assert all(r.agrees for r in replay(dataset))


class HangsInAct(AlwaysWait):
    """Never returns from its first decision (until the test releases it)."""

    release = threading.Event()
    entered = threading.Event()

    def act(self, observation):
        HangsInAct.entered.set()
        HangsInAct.release.wait(60)
        return 0


class ExitsWhenMade(AlwaysWait):
    def __init__(self):
        raise SystemExit(4)


class RaisesInLearning(AlwaysWait):
    def end_episode(self, trace, intention):
        raise KeyboardInterrupt


@pytest.mark.parametrize("agent, call, error", [
    ("tests.helpers_agents:ExitsInAct", "act()", "SystemExit"),
    ("tests.test_people_serve:ExitsWhenMade", "making the agent", "SystemExit"),
    ("tests.test_people_serve:RaisesInLearning", "end_episode()", "KeyboardInterrupt"),
    ("tests.test_people_serve:HangsInAct", "act()", "did not answer in time"),
])
def test_a_robot_that_exits_raises_or_hangs_ends_its_session_with_a_named_error(
        tmp_path, agent, call, error):
    """An agent calling sys.exit() once killed the session's thread silently, and a hung
    one left the page waiting: the session stayed 'running' for ever. Now the session
    ends (failed), the page is told why, and the record says so; the server goes on."""
    HangsInAct.release.clear()
    cfg, client = _client(tmp_path, agent=agent, agent_timeout_s=1.0, episodes=1)
    try:
        with client:
            token = _join(client)
            session = client.app.state.sessions.get(token)
            assert call == "end_episode()" or session.finished.wait(30)
            with client.websocket_connect("/ws") as ws:
                m = _hello(ws, token)
                if m["type"] == "frame":  # it fails when it learns after the episode
                    m = _play(ws, m)
            assert m["type"] == "ended" and m["reason"] == "failed", m
            assert error in m["error"] and call in m["error"], m
            assert _join(client)  # the server goes on
        meta = open_dataset(cfg.dataset_id, tmp_path).sessions()[0]
        assert meta["status"] == "failed" and error.split()[0] in meta["error"] or (
            "did not return" in meta["error"]), meta
    finally:
        HangsInAct.release.set()


def test_the_page_shows_why_a_session_ended():
    from pathlib import Path

    script = (Path(__file__).parents[1] / "hri_bench/people/serve/static/app.js").read_text()
    assert "m.error" in script[script.index("function onEnded"):]


@pytest.mark.parametrize("body", [{}, {"consent": False}, {"consent": "yes"}, {"consent": 1},
                                  {"consent": True, "name": "Ada"}, [True], "consent"])
def test_joining_needs_consent_and_takes_nothing_else(tmp_path, body):
    cfg, client = _client(tmp_path)
    with client:
        r = _post(client, body)
        assert r.status_code == 400 and r.json()["field"] == "consent"
    assert open_dataset(cfg.dataset_id, tmp_path).session_dirs() == []


def test_joining_refuses_a_key_given_twice(tmp_path):
    cfg, client = _client(tmp_path)
    with client:
        r = client.post("/api/sessions", content=b'{"consent": false, "consent": true}',
                        headers=_page_headers(client))
        assert r.status_code == 400, r.text
        assert r.json()["field"] == "consent" and "twice" in r.json()["error"]
    assert open_dataset(cfg.dataset_id, tmp_path).session_dirs() == []


def _post_raw(app, headers, chunks):
    """POST /api/sessions straight to the ASGI app, the body in ``chunks`` handed out as
    the app asks for them; (status, JSON body, how many chunks it asked for)."""
    import asyncio

    asked = []

    async def receive():
        asked.append(1)
        i = len(asked) - 1
        if i < len(chunks):
            return {"type": "http.request", "body": chunks[i], "more_body": i + 1 < len(chunks)}
        return {"type": "http.disconnect"}

    out = {"body": b""}

    async def send(message):
        if message["type"] == "http.response.start":
            out["status"] = message["status"]
        elif message["type"] == "http.response.body":
            out["body"] += message.get("body", b"")

    scope = {"type": "http", "asgi": {"version": "3.0"}, "http_version": "1.1",
             "method": "POST", "scheme": "http", "path": "/api/sessions", "raw_path":
             b"/api/sessions", "query_string": b"", "root_path": "",
             "headers": [(k.lower().encode(), v.encode()) for k, v in headers.items()],
             "client": ("127.0.0.1", 5000), "server": ("127.0.0.1", 8000)}
    asyncio.run(app(scope, receive, send))
    return out["status"], json.loads(out["body"]), len(asked)


@pytest.mark.parametrize("declared", [True, False])
def test_a_big_body_is_refused_as_it_streams(tmp_path, declared):
    """A body over 1 KiB is refused (413) without reading the rest: by its Content-Length
    when it has one, else as soon as the streamed count passes the cap. It once was read
    whole first (a 200 MB body cost 147 MB)."""
    cfg, client = _client(tmp_path)
    chunk = b" " * 65536
    chunks = [chunk] * 200
    headers = {"host": "testserver", "content-type": "application/json",
               **_page_headers(client)}
    if declared:
        headers["content-length"] = str(len(chunk) * len(chunks))
    status, body, asked = _post_raw(client.app, headers, chunks)
    assert status == 413 and body["field"] == "body" and "1024" in body["error"]
    assert asked <= (0 if declared else 1), asked
    # at the cap it is read and judged
    ok = json.dumps({"consent": True}).encode().ljust(1024)
    status, body, _ = _post_raw(client.app, {**headers, "content-length": "1024"}, [ok])
    assert status == 201, body
    client.app.state.sessions.stop_all()


def test_a_session_that_cannot_be_recorded_is_refused_with_json(tmp_path, monkeypatch):
    from hri_bench.people.serve import session as session_module

    def full(*args, **kwargs):
        raise OSError(28, "No space left on device")

    _, client = _client(tmp_path)
    with client:
        monkeypatch.setattr(session_module, "SessionWriter", full)
        r = _post(client, {"consent": True})
        assert r.status_code == 503 and r.json()["field"] == "sessions", r.text
        monkeypatch.undo()
        _join(client)
        (meta,) = open_dataset("hanger-people-v0", tmp_path).sessions()
        assert meta["session_index"] == 0  # the design's row was not used up


def test_the_server_is_full_at_max_sessions_and_stops_them_on_shutdown(tmp_path):
    cfg, client = _client(tmp_path, max_sessions=1)
    with client:
        token = _join(client)
        r = _post(client, {"consent": True})
        assert r.status_code == 503 and "full" in r.json()["error"]
        with client.websocket_connect("/ws") as ws:  # played: recorded when stopped
            _answer(ws, _hello(ws, token))
            assert _next_view(ws)["step"] == 2
    assert [s["status"] for s in open_dataset(cfg.dataset_id, tmp_path).sessions()] == [
        "stopped"]


def test_an_idle_session_is_abandoned(tmp_path, clock):
    cfg, client = _client(tmp_path, idle_timeout_s=60.0)
    with client:
        token = _join(client)
        with client.websocket_connect("/ws") as ws:
            _answer(ws, _hello(ws, token))
            assert _next_view(ws)["step"] == 2
            clock.advance(60.5)
            ended = _next_view(ws)
    assert ended["type"] == "ended" and ended["reason"] == "abandoned"
    assert open_dataset(cfg.dataset_id, tmp_path).sessions()[0]["status"] == "abandoned"


class FakeClock:
    """The clock of the sessions' and the robot calls' time limits, moved by the test only
    (time stands still otherwise: no limit is reached by a slow machine)."""

    def __init__(self):
        self.now = 1000.0

    def __call__(self):
        return self.now

    def advance(self, seconds):
        self.now += seconds


@pytest.fixture
def clock(monkeypatch):
    from hri_bench.people.serve import robot as robot_module
    from hri_bench.people.serve import session as session_module

    fake = FakeClock()
    monkeypatch.setattr(session_module, "_clock", fake)
    monkeypatch.setattr(robot_module, "_clock", fake)
    return fake


def _until(condition, timeout=30.0):
    """Whether ``condition()`` holds within ``timeout`` seconds (a bound, not a margin)."""
    deadline = time.monotonic() + timeout
    while not condition():
        if time.monotonic() > deadline:
            return False
        time.sleep(0.02)
    return True


def test_a_hung_robot_is_shown_on_the_page_and_the_idle_timeout_ends_it(
        tmp_path, clock, monkeypatch):
    """A robot that hung left the page on "Preparing the robot..." and, with an
    --agent-timeout above --idle-timeout, ran past the idle timeout. Now the page says the
    robot is thinking after 3 s, and the session ends (failed, named) at the idle timeout."""
    from hri_bench.people.serve.robot import SLOW_S

    monkeypatch.setenv(IN_PROCESS, "1")  # the agent in this process: the test releases it
    HangsInAct.release.clear()
    HangsInAct.entered.clear()
    cfg, client = _client(tmp_path, agent="tests.test_people_serve:HangsInAct",
                          agent_timeout_s=3600.0, idle_timeout_s=600.0, episodes=1)
    try:
        with client:
            token = _join(client)
            session = client.app.state.sessions.get(token)
            with client.websocket_connect("/ws") as ws:
                ws.send_text(json.dumps({"type": "hello", "session": token}))
                assert HangsInAct.entered.wait(30)
                clock.advance(SLOW_S)
                assert _until(lambda: "thinking" in session.view()[1])
                while "message" not in (m := json.loads(ws.receive_text())):
                    assert m["type"] == "wait", m
                assert m["message"] == "The robot is thinking (act)...", m
                clock.advance(600.0 - SLOW_S - 1.0)
                assert not session.finished.wait(0.5)  # not before the idle timeout
                clock.advance(1.0)
                assert session.finished.wait(30)
                m = json.loads(ws.receive_text())
            assert m["type"] == "ended" and m["reason"] == "failed", m
            assert "did not answer in time (act() took over 600 s)" in m["error"], m
        (meta,) = open_dataset(cfg.dataset_id, tmp_path).sessions()
        assert meta["status"] == "failed" and "(--idle-timeout)" in meta["error"], meta
    finally:
        HangsInAct.release.set()


def test_joins_nobody_plays_do_not_keep_the_study_full(tmp_path, clock):
    """A local client that read the page's token could join up to --max-sessions and hold
    them until the idle timeout (30 min). Now a session nobody has played is closed once no
    page has been connected to it for CLAIM_TIMEOUT_S; a page that is connected keeps it."""
    from hri_bench.people.serve.session import CLAIM_TIMEOUT_S

    cfg, client = _client(tmp_path, max_sessions=3)
    with client:
        manager = client.app.state.sessions
        never, left, watched = _join(client), _join(client), _join(client)
        with client.websocket_connect("/ws") as ws:  # says hello, then leaves
            assert _hello(ws, left)["type"] == "frame"
        assert _until(lambda: manager.get(left)._owner is None)
        assert _post(client, {"consent": True}).status_code == 503
        with client.websocket_connect("/ws") as ws:
            first = _hello(ws, watched)  # the page shows the first step, unanswered
            clock.advance(CLAIM_TIMEOUT_S - 1)
            assert not manager.get(never).finished.wait(0.5)
            clock.advance(2)
            assert manager.get(never).finished.wait(30) and manager.get(left).finished.wait(30)
            assert manager.running() == 1 and _join(client)  # room again
            _answer(ws, first)  # the watched session plays on
            assert _next_view(ws)["step"] == 2
        played = manager.get(watched).participant
    assert [s["participant"] for s in open_dataset(cfg.dataset_id, tmp_path).sessions()
            ] == [played]


def test_joins_never_played_leave_no_folder_and_give_their_place_on(tmp_path, clock):
    """Every join that was never played left a session folder (300 joins, 300 folders).
    Now such a session, closed without its page, stopped or abandoned before its first
    answer, leaves nothing, and its row of the design goes to the next participant, also
    after a restart."""
    from hri_bench.people.serve.session import CLAIM_TIMEOUT_S

    cfg, client = _client(tmp_path, episodes=1)
    with client:
        manager = client.app.state.sessions
        tokens = [_join(client) for _ in range(6)]
        dataset = open_dataset(cfg.dataset_id, tmp_path)
        assert len(dataset.session_dirs()) == 6  # recorded while they run
        clock.advance(CLAIM_TIMEOUT_S + 1)
        assert all(manager.get(t).finished.wait(30) for t in tokens)
        assert dataset.session_dirs() == [] and manager.running() == 0
        token = _join(client)
        with client.websocket_connect("/ws") as ws:
            assert _play(ws, _hello(ws, token))["type"] == "done"
        _join(client)  # stopped at shutdown, unplayed: nothing left
    (meta,) = dataset.sessions()
    assert meta["status"] == "complete" and meta["session_index"] == 0

    # a server started again numbers on from the sessions on disk, filling the gaps
    from hri_bench.data.datasets import SessionWriter

    SessionWriter(dataset, "p0123456789ab", {"session_index": 3}).finish("complete")
    cfg, client = _client(tmp_path)
    with client:
        indices = [client.app.state.sessions.get(_join(client)).design.index
                   for _ in range(4)]
    assert indices == [1, 2, 4, 5]


def test_ended_sessions_are_freed_and_a_reload_still_shows_the_end(tmp_path):
    """Every session once stayed in memory for good (about 120 KiB each, the robot and the
    recorder). Now a session that ended, once recorded, leaves its last view only: the
    robot, the recorder and the thread are freed, the page is closed (code 1000), and a
    reload still shows the end with the participant's code."""
    import gc
    import weakref

    cfg, client = _client(tmp_path, episodes=1, max_sessions=2)
    with client:
        manager = client.app.state.sessions
        tokens, refs, ends = [], [], []
        for _ in range(4):  # more than max_sessions one after the other
            token = _join(client)
            session = manager.get(token)
            refs += [weakref.ref(session), weakref.ref(session.worker)]
            with client.websocket_connect("/ws") as ws:
                m = _hello(ws, token)
                refs += [weakref.ref(manager.get(token).agent),
                         weakref.ref(manager.get(token).agent.inner)]
                done = _play(ws, m)
                with pytest.raises(WebSocketDisconnect) as closed:
                    ws.receive_text()  # the server closes the page's channel at the end
                assert closed.value.code == 1000
            assert done["type"] == "done"
            tokens.append(token)
            ends.append(done)
            del session, m
        deadline = time.monotonic() + 10  # the last session's thread records and ends itself
        while manager.running() and time.monotonic() < deadline:
            time.sleep(0.01)
        assert manager.running() == 0
        gc.collect()
        alive = [r() for r in refs if r() is not None]
        assert not alive, [type(a).__name__ for a in alive]
        with client.websocket_connect("/ws") as ws:  # a reload after the end
            again = _hello(ws, tokens[0])
            assert again == ends[0]
            ws.send_text(json.dumps({"type": "continue", "seq": again["seq"]}))
        kept = [len(manager.get(t).text) for t in tokens]
        assert max(kept) < 2048, kept  # what stays of a session: its last view
    assert [s["status"] for s in open_dataset(cfg.dataset_id, tmp_path).sessions()] == [
        "complete"] * 4


def test_the_last_views_kept_are_bounded(tmp_path, monkeypatch):
    from hri_bench.people.serve import session as session_module

    monkeypatch.setattr(session_module, "ENDED_KEEP_BYTES", 1)
    _, client = _client(tmp_path, episodes=1)
    with client:
        manager = client.app.state.sessions
        first, second = _join(client), _join(client)
        for token in (first, second):
            manager.get(token).stop("stopped")
        deadline = time.monotonic() + 20
        while manager.running() and time.monotonic() < deadline:
            time.sleep(0.01)
        assert manager.get(first) is None  # dropped: over the byte budget
        with client.websocket_connect("/ws") as ws:
            ws.send_text(json.dumps({"type": "hello", "session": first}))
            assert json.loads(ws.receive_text())["field"] == "session"


def test_a_token_that_is_not_ascii_is_unknown(tmp_path):
    _, client = _client(tmp_path)
    with client:
        _join(client)
        with client.websocket_connect("/ws") as ws:
            ws.send_text(json.dumps({"type": "hello", "session": "é" * 43}))
            assert json.loads(ws.receive_text())["field"] == "session"
            with pytest.raises(WebSocketDisconnect) as closed:
                ws.receive_text()
            assert closed.value.code == 4401


def _modes(root):
    """{path relative to root: permission bits} of root and everything under it."""
    import os
    import stat

    return {str(p.relative_to(root)): stat.S_IMODE(os.lstat(p).st_mode)
            for p in [root, *root.rglob("*")]}


def test_recordings_are_private_to_the_user(tmp_path):
    """Recordings were world-readable (0644 files in 0755 folders): now the dataset's
    folders are 0700 and its files 0600, those there before the server started too."""
    from hri_bench.data.datasets import create_dataset

    # the dataset exists, made with the usual umask
    data = create_dataset("hanger-people-v0", "hanger", synthetic=False, root=tmp_path).path
    data.chmod(0o755)
    (data / "dataset.json").chmod(0o644)
    (data / "notes.txt").write_text("the experimenter's")
    outside = tmp_path / "outside.txt"
    outside.write_text("not the dataset's")
    outside.chmod(0o644)
    os.symlink(outside, data / "link")
    _, client = _client(tmp_path, episodes=1)
    with client:
        token = _join(client)
        with client.websocket_connect("/ws") as ws:
            assert _play(ws, _hello(ws, token))["type"] == "done"
    modes = _modes(data)
    assert any(name.endswith(".parquet") for name in modes)
    for name, mode in modes.items():
        if name == "link":
            continue  # a link's own mode means nothing; its target is not changed
        assert mode == (0o700 if (data / name).is_dir() else 0o600), (name, oct(mode))
    assert oct(outside.stat().st_mode & 0o777) == "0o644"  # the link was not followed


def test_one_server_per_dataset_and_a_killed_servers_sessions_are_interrupted(tmp_path):
    """A server killed mid-session left the session 'running' for good. Now a server holds
    the dataset (a second one is refused, naming the process), and the next server marks
    what a killed one left running as 'interrupted', episodes on disk kept."""
    from hri_bench.data.datasets import SessionWriter, create_dataset

    dataset = create_dataset("hanger-people-v0", "hanger", synthetic=False, root=tmp_path)
    left = SessionWriter(dataset, "p0123456789ab", {"session_index": 0})  # running
    done = SessionWriter(dataset, "p0123456789ac", {"session_index": 1})
    done.finish("complete")
    cfg, client = _client(tmp_path)
    with client:
        with pytest.raises(ConfigError, match="another hri-bench serve") as err:
            create_app(cfg)
        assert err.value.field == "dataset" and str(os.getpid()) in str(err.value)
        assert client.app.state.sessions.interrupted == ["p0123456789ab"]
    statuses = {s["participant"]: s for s in open_dataset(cfg.dataset_id, tmp_path).sessions()}
    assert statuses["p0123456789ab"]["status"] == "interrupted"
    assert statuses["p0123456789ab"]["interrupted_noticed_utc"]
    assert statuses["p0123456789ac"]["status"] == "complete"
    assert left.meta["status"] == "running"
    with TestClient(create_app(cfg)):  # the first released the dataset when it stopped
        pass


def test_serve_killed_and_started_again(tmp_path):
    """The whole story with real processes: ``kill -9`` mid-session, a second server on the
    same dataset refused (exit 2, --dataset) while the first runs, the next one marks the
    session interrupted; files are private from the start (umask 077)."""
    import signal
    import urllib.request

    data = tmp_path / "data"

    def start(*extra):
        return start_serve(["hanger", "--agent", "passive", "--port", "0", "--data",
                            str(data), *extra], timeout=300)

    first, url, _ = start()
    try:
        assert url
        page = urllib.request.urlopen(url, timeout=30).read().decode()
        token = re.search(r'"hri-bench-token" content="([^"]+)"', page).group(1)
        request = urllib.request.Request(
            url + "api/sessions", data=b'{"consent": true}', method="POST",
            headers={"Origin": url.rstrip("/"), "X-HRI-Bench-Token": token,
                     "Content-Type": "application/json"})
        assert urllib.request.urlopen(request, timeout=30).status == 201
        second, url2, lines = start()
        assert url2 is None and second.returncode == 2, "".join(lines)
        assert "argument --dataset" in "".join(lines) and str(first.pid) in "".join(lines)
    finally:
        first.send_signal(signal.SIGKILL)
        first.wait(30)
    (meta,) = open_dataset("hanger-people-v0", data).sessions()
    assert meta["status"] == "running"
    assert {oct(m) for n, m in _modes(data / "hanger-people-v0").items()
            if n.startswith("sessions/p")} == {"0o700", "0o600"}
    third, url3, lines = start()
    try:
        assert url3 and "marked 1 session(s)" in "".join(lines), "".join(lines)
    finally:
        # it must end on Ctrl-C (a loaded machine once took over 30 s)
        assert stop_serve(third, 120)
    (meta,) = open_dataset("hanger-people-v0", data).sessions()
    assert meta["status"] == "interrupted" and meta["participant"] in "".join(lines)


def test_headers_origin_and_public_settings(tmp_path):
    cfg, client = _client(tmp_path)
    with client:
        page = client.get("/")
        assert page.status_code == 200 and "app.js" in page.text
        assert "default-src 'self'" in page.headers["content-security-policy"]
        assert page.headers["x-frame-options"] == "DENY"
        assert client.get("/app.js").status_code == 200
        study = client.get("/api/study").json()
        assert set(study) == {"scenario", "object", "supports", "episodes", "consent",
                              "instructions", "physical"}
        assert "clothes hanger" in study["instructions"] and "{object}" not in study[
            "instructions"]
        token = _join(client)
        with pytest.raises(WebSocketDisconnect) as closed, client.websocket_connect(
                "/ws", headers={"origin": "http://evil.example"}) as ws:
            ws.send_text(json.dumps({"type": "hello", "session": token}))
            ws.receive_text()
        assert closed.value.code == 4403


def test_object_and_supports_are_filled_in_the_consent_text_too(tmp_path):
    cfg = ServeConfig("hanger", consent="You will carry the {object} between {supports}.",
                      instructions="Carry the {object}.")
    public = cfg.public()
    assert public["consent"] == "You will carry the clothes hanger between A, B, C."
    assert public["instructions"] == "Carry the clothes hanger."
    # the recorded hashes are of the texts as given
    import hashlib

    assert cfg.text_hashes()["consent_sha256"] == hashlib.sha256(cfg.consent.encode()).hexdigest()


FOREIGN = [  # (what a page elsewhere, or a script, sends) -> (status, field)
    ({"origin": "http://evil.example", "content-type": "text/plain"}, 403, "origin"),
    ({"origin": "http://evil.example"}, 403, "origin"),
    ({"origin": None}, 403, "origin"),                      # a browser always sends one
    ({"origin": "null"}, 403, "origin"),                    # a sandboxed frame, a file
    ({"origin": "http://testserver.evil.example"}, 403, "origin"),
    ({"x-hri-bench-token": None}, 403, "token"),           # not from the page
    ({"x-hri-bench-token": "x" * 43}, 403, "token"),
    ({"content-type": "text/plain"}, 415, "content-type"),
    ({"content-type": "application/x-www-form-urlencoded"}, 415, "content-type"),
    ({"content-type": None}, 415, "content-type"),
    ({"host": "evil.example"}, 400, "host"),                # DNS rebinding
    ({"host": "evil.example", "origin": "http://evil.example"}, 400, "host"),
]


@pytest.mark.parametrize("change, status, field", FOREIGN)
def test_only_the_served_page_can_join(tmp_path, change, status, field):
    """Any page the lab machine's browser visited could once fill the study (a foreign
    Origin with text/plain got 201): now joining needs this server's Host, its page's
    Origin and token, and JSON; each refusal is a JSON body naming the problem."""
    cfg, client = _client(tmp_path, max_sessions=1)
    with client:
        headers = {k: v for k, v in {**_page_headers(client), **change}.items()
                   if v is not None}
        r = client.post("/api/sessions", content=b'{"consent": true}', headers=headers)
        assert r.status_code == status and r.json()["field"] == field, r.text
        assert r.json()["error"]
        _join(client)  # the study was not filled: the page's own request still gets in
        assert len(open_dataset(cfg.dataset_id, tmp_path).session_dirs()) == 1


def test_every_route_answers_only_to_this_servers_host(tmp_path):
    """A page whose name is rebound to 127.0.0.1 reaches the server with its own name in
    Host: it can read neither the page (and its token) nor anything else."""
    cfg, client = _client(tmp_path)
    with client:
        for path in ("/", "/app.js", "/api/study", "/nowhere"):
            r = client.get(path, headers={"host": "rebind.evil.example:8000"})
            assert r.status_code == 400 and r.json()["field"] == "host", path
            assert r.headers["x-frame-options"] == "DENY"
            assert "{{" not in r.text
        token = _join(client)
        for headers in ({"host": "rebind.evil.example"},
                        {"origin": "http://evil.example"}):
            with pytest.raises(WebSocketDisconnect) as closed, client.websocket_connect(
                    "/ws", headers=headers) as ws:
                ws.send_text(json.dumps({"type": "hello", "session": token}))
                ws.receive_text()
            assert closed.value.code == 4403


def test_the_page_carries_a_token_of_its_own_server(tmp_path):
    _, one = _client(tmp_path / "a")
    _, two = _client(tmp_path / "b")
    with one, two:
        a, b = _page_headers(one), _page_headers(two)
        assert a["x-hri-bench-token"] != b["x-hri-bench-token"]
        assert len(a["x-hri-bench-token"]) >= 43
        assert _page_headers(one) == a  # the same for every load of the page
        r = one.post("/api/sessions", content=b'{"consent": true}', headers=b)
        assert r.status_code == 403 and r.json()["field"] == "token"


@pytest.mark.parametrize("bind, named, host, ok", [
    ("127.0.0.1", (), "127.0.0.1:8000", True),
    ("127.0.0.1", (), "localhost:8000", True),
    ("127.0.0.1", (), "LOCALHOST:8000", True),
    ("127.0.0.1", (), "[::1]:8000", True),
    ("127.0.0.1", (), "localhost:8001", False),
    ("127.0.0.1", (), "127.0.0.1", False),                  # port 80
    ("127.0.0.1", (), "evil.example:8000", False),
    ("127.0.0.1", (), "127.0.0.1.nip.io:8000", False),
    ("127.0.0.1", (), "10.0.0.5:8000", False),
    ("127.0.0.1", (), "", False),
    ("127.0.0.1", (), None, False),
    ("127.0.0.1", (), "127.0.0.1:8000/x", False),
    ("::1", (), "[::1]:8000", True),
    ("0.0.0.0", (), "192.168.1.5:8000", True),              # an address: no rebinding
    ("0.0.0.0", (), "[fe80::1]:8000", True),
    ("0.0.0.0", (), "localhost:8000", True),
    ("0.0.0.0", (), "labpc:8000", False),                   # a name: only when given
    ("0.0.0.0", ("labpc",), "labpc:8000", True),
    ("0.0.0.0", ("labpc",), "labpc", True),                 # behind a proxy
    ("0.0.0.0", ("labpc",), "labpc:9000", False),
    ("0.0.0.0", ("study.example:443",), "study.example:443", True),
    ("0.0.0.0", ("study.example:443",), "study.example:8000", False),
    ("192.168.1.5", (), "192.168.1.5:8000", True),
    ("192.168.1.5", (), "192.168.1.6:8000", False),
])
def test_the_hosts_a_server_answers_to(bind, named, host, ok):
    from hri_bench.people.serve.access import Access

    assert Access(bind, 8000, named).host_ok(host) is ok


@pytest.mark.parametrize("origin, host, ok", [
    ("http://127.0.0.1:8000", "127.0.0.1:8000", True),
    ("http://localhost:8000", "localhost:8000", True),
    ("http://localhost:8000", "127.0.0.1:8000", False),     # another origin
    ("http://127.0.0.1:8001", "127.0.0.1:8000", False),
    ("https://127.0.0.1:8000", "127.0.0.1:8000", True),
    ("https://study.example", "127.0.0.1:8000", True),      # named: a TLS proxy's
    ("https://study.example", "study.example", True),
    ("http://evil.example", "127.0.0.1:8000", False),
    ("null", "127.0.0.1:8000", False),
    ("file://", "127.0.0.1:8000", False),
    ("http://127.0.0.1:8000/path", "127.0.0.1:8000", False),
    (None, "127.0.0.1:8000", False),
])
def test_the_origins_that_may_join(origin, host, ok):
    from hri_bench.people.serve.access import Access

    access = Access("127.0.0.1", 8000, ("study.example",))
    assert access.origin_ok(origin, host, required=True) is ok


def test_counterbalanced_design():
    circuit = pair_circuit(3)
    assert sorted(circuit) == [(a, b) for a in range(3) for b in range(3) if a != b]
    assert all(circuit[i][1] == circuit[(i + 1) % 6][0] for i in range(6))
    cfg = ServeConfig("hanger", episodes=6, preferences=("down-over-rotate/over-rotate-up",
                                                         "over-down-rotate/up-over-rotate"))
    designs = [assignment(cfg, i) for i in range(6)]
    for position in range(6):  # a Latin square: every pair once per position
        assert sorted(d.pairs[position] for d in designs) == sorted(circuit)
    assert [d.preference for d in designs[:3]] == [cfg.preferences[0], cfg.preferences[1],
                                                    cfg.preferences[0]]
    assert all(d.pairs[e][1] == d.pairs[e + 1][0] for d in designs for e in range(5))
    assert pair_circuit(4)[0][0] == 0 and len(pair_circuit(4)) == 12


def test_a_preference_reads_in_its_scenarios_words_or_by_its_name():
    hanger, wheel = scenario_spec("hanger"), scenario_spec("wheel")
    assert describe_preference(hanger, "down-over-rotate/over-rotate-up") == (
        "Between the rail and the peg, carry it this way: to the peg A, move down, then move "
        "over, then rotate; to the rail (B, C), move over, then rotate, then move up.")
    assert describe_preference(wheel, "detour") == (
        "Carry it this way: turn the wheel horizontal at the first opportunity, then carry it "
        "over at carrying height.")
    assert describe_preference(wheel, "sideways") == "Carry it the way called 'sideways'."
    from tests import scenario_box  # a scenario with no words of its own: the default

    assert scenario_box.SPEC.preference_wording is None
    assert describe_preference(scenario_box.SPEC, "over-first") == (
        "Carry it the way called 'over-first'.")


@pytest.mark.parametrize("kw, field", [
    ({"agent": "oracle"}, "agent"), ({"agent": "nobody"}, "agent"),
    ({"scenario": "kitchen"}, "scenario"), ({"episodes": 0}, "episodes"),
    ({"preferences": ("sideways",)}, "preferences"), ({"host": ""}, "host"),
    ({"consent": "  "}, "consent"), ({"dataset": "../x"}, "dataset"),
    ({"port": 70000}, "port"), ({"idle_timeout_s": 0.0}, "idle_timeout_s"),
    ({"allowed_hosts": ("http://x",)}, "allowed_hosts"),
    ({"allowed_hosts": ["x"]}, "allowed_hosts"),
    ({"agent_timeout_s": 0.0}, "agent_timeout_s"),
])
def test_serve_config_errors_name_the_field(kw, field):
    with pytest.raises(ConfigError) as err:
        ServeConfig(**kw)
    assert err.value.field == field


def test_no_agent_that_plans_for_the_humans_model_faces_a_person():
    """Every built-in that reads the human's policy (the oracle, the references, the bracket's
    QMDP) is refused, including ones added to the benchmark later."""
    from hri_bench.people.serve.design import UNSUITED_AGENTS
    from hri_bench.run.agents import BRACKET_AGENTS, REFERENCE_AGENTS

    for name in ("oracle", *REFERENCE_AGENTS, *BRACKET_AGENTS):
        assert name in UNSUITED_AGENTS
        with pytest.raises(ConfigError, match="cannot face a person"):
            ServeConfig(agent=name)


@pytest.mark.parametrize("argv, flag", [
    (["serve", "--agent", "oracle"], "--agent"),
    (["serve", "--agent", "informed"], "--agent"),
    (["serve", "--agent", "qmdp"], "--agent"),
    (["serve", "wheel", "--preferences", "down-over-rotate/over-rotate-up"], "--preferences"),
    (["serve", "--dataset", "a/b"], "--dataset"),
    (["serve", "--consent", "/nonexistent/consent.txt"], "--consent"),
    (["serve", "--port", "-1"], "--port"),
    (["serve", "--idle-timeout", "nan"], "--idle-timeout"),
    (["serve", "--allow-host", "evil.example/x"], "--allow-host"),
    (["serve", "--allow-host", "a b"], "--allow-host"),
    (["serve", "--agent-timeout", "0"], "--agent-timeout"),
])
def test_serve_flags_exit_2(argv, flag, tmp_path, capsys):
    with pytest.raises(SystemExit) as exit_:
        main([*argv, "--data", str(tmp_path)])
    assert exit_.value.code == 2
    assert f"argument {flag}" in capsys.readouterr().err


@pytest.mark.parametrize("flag", ["--consent", "--instructions"])
@pytest.mark.parametrize("kind", ["fifo", "device", "folder"])
def test_a_text_flag_takes_a_regular_file_only(flag, kind, tmp_path, capsys):
    """A FIFO once blocked serve for ever (waiting for a writer); a device or a folder is
    refused as well, naming the flag (exit 2)."""
    import os
    import threading

    path = {"fifo": tmp_path / "consent.fifo", "device": "/dev/zero", "folder": tmp_path}[kind]
    if kind == "fifo":
        os.mkfifo(path)
    result = {}

    def run():
        try:
            main(["serve", flag, str(path), "--data", str(tmp_path / "data")])
        except SystemExit as exc:
            result["code"] = exc.code

    thread = threading.Thread(target=run, daemon=True)
    thread.start()
    thread.join(20)
    if thread.is_alive() and kind == "fifo":  # release it: a writer that closes at once
        os.close(os.open(path, os.O_WRONLY | os.O_NONBLOCK))
        thread.join(20)
    assert result.get("code") == 2, "serve blocked on the file"
    err = capsys.readouterr().err
    assert f"argument {flag}" in err and "regular file" in err, err


def test_serve_without_the_web_extra_says_how_to_install_it(monkeypatch, capsys):
    from hri_envs import errors

    monkeypatch.setattr(errors, "_installed", lambda m: m not in ("fastapi", "uvicorn"))
    assert main(["serve"]) == 1
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1
    assert "fastapi" in err and "pip install" in err and ".[web]" in err


def test_message_schema():
    assert parse_message('{"type": "continue", "seq": 3}') == {"type": "continue", "seq": 3}
    with pytest.raises(ConfigError, match="rt_ms") as err:
        parse_message('{"type": "action", "seq": 3, "action": 1}')
    assert "missing" in str(err.value) and err.value.field == "rt_ms"
    with pytest.raises(ConfigError, match="twice") as err:
        parse_message('{"type": "continue", "seq": 3, "seq": 4}')
    assert err.value.field == "seq"
    with pytest.raises(ConfigError, match="twice"):  # nested objects too
        parse_message('{"type": "continue", "seq": {"a": 1, "a": 2}}')
    with pytest.raises(ConfigError, match="JSON"):
        parse_message("{")
    with pytest.raises(ConfigError):
        parse_message("[" * 10_000)


def test_response_times_are_recorded_per_step(tmp_path):
    cfg, client = _client(tmp_path, episodes=1)
    with client:
        token = _join(client)
        with client.websocket_connect("/ws") as ws:
            m = _hello(ws, token)
            time.sleep(0.05)
            _answer(ws, m)
            _play(ws, _next_view(ws))
    table = open_dataset(cfg.dataset_id, tmp_path).steps()
    first = table.slice(0, 1).to_pylist()[0]
    assert first["response_s"] >= 0.05 and first["t_action"] > first["t_shown"] > 1.7e9
    assert np.all(np.asarray(table.column("response_s")) >= 0)


def test_a_person_leads_against_a_registered_robot_never_the_reference():
    """serve --physical takes the physical registry's robots that feel the human only: the
    upper reference reads the simulated human's route, which a person does not have."""
    pytest.importorskip("mujoco")
    from hri_bench.core.physical_robots import check_robot, default_robot, robot_names

    assert default_robot() in robot_names() and "upper" not in robot_names()
    with pytest.raises(ConfigError, match="cannot face a person") as err:
        ServeConfig("hanger", agent="upper", physical=True)
    assert err.value.field == "agent"
    with pytest.raises(ConfigError, match="is not a physical robot; allowed: .*admittance"):
        check_robot("admitance")


def test_a_physical_sessions_answer_counts_as_played_on_the_sessions_clock(monkeypatch):
    """A page that answered a lead view has played (a played session is never abandoned as
    unclaimed when its page drops, nor its folder removed), and its activity is read on the
    sessions' clock (which the tests hold): LeadSession.handle shares Session's bookkeeping.
    A message that answers another view changes nothing."""
    import queue
    import threading

    from hri_bench.people.serve import session as session_module
    from hri_bench.people.serve.lead_session import LeadSession
    from hri_bench.people.serve.session import MessageError

    monkeypatch.setattr(session_module, "_clock", lambda: 1234.0)
    lead = LeadSession.__new__(LeadSession)  # the handling alone, without its worker process
    lead._lock, lead._actions, lead._hand = threading.Lock(), queue.Queue(), None
    lead._expect, lead._view = ("hand", 3, frozenset()), {"type": "lead"}
    lead.played, lead.last_activity = False, 0.0
    with pytest.raises(MessageError, match="seq 2 does not answer"):
        lead.handle({"type": "hand", "seq": 2, "target": [0.0] * 7})
    assert not lead.played and lead.last_activity == 0.0 and lead._actions.empty()
    lead.handle({"type": "hand", "seq": 3, "target": [0.0] * 7})
    assert lead.played and lead.last_activity == 1234.0 and lead._actions.get() == ("hand", 0)
