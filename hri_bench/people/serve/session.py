"""A participant's session: a person in the human's seat of the benchmark's own loop.

Each session runs :func:`hri_bench.run.runner.run_episodes` in a thread of its own, with its
own robot agent (made by :func:`hri_bench.run.agents.make_agent`, as in a study) and, in the
human's seat, :class:`PersonHuman` inside :class:`~hri_bench.people.recording.RecordingHumans`:
when the loop asks the human to act, the person's page is sent a picture of the step (a
*view*), and the thread waits until the page sends a valid action. The episode rules, rewards
and the robot's learning between episodes are the benchmark's; nothing is simulated here.

The page and the thread meet in :class:`Session`: the thread publishes views (``frame``,
``outcome``, ``done``, ``ended``), each with a sequence number ``seq``; the page answers a
``frame`` with ``{"type": "action", "seq", "action", "rt_ms"}`` and an ``outcome`` with
``{"type": "continue", "seq"}``. :meth:`Session.handle` checks every message against the view
it answers (its ``seq``, an action among the offered ones) and changes nothing otherwise.
"""

from __future__ import annotations

import functools
import json
import logging
import queue
import secrets
import shutil
import threading
import time
from collections.abc import Callable, Mapping
from concurrent.futures import Future, ThreadPoolExecutor
from typing import Any

import numpy as np

from agents.learning import algorithm1
from agents.protocol import BatchAgent, read_belief
from hri_bench.data.datasets import Dataset, SessionWriter, create_dataset, new_participant_id
from hri_bench.people.recording import RecordingHumans, agent_identity
from hri_bench.people.serve.design import Assignment, ServeConfig, assignment, describe_preference
from hri_bench.people.serve.hand import FIELDS as HAND_FIELDS
from hri_bench.people.serve.hand import check_hand
from hri_bench.people.serve.robot import AgentFailed, AgentWorker, GuardedAgent, Stopped
from hri_bench.people.serve.scenes import graph_view, warm
from hri_bench.people.serve.store import DatasetLock, make_private, mark_interrupted
from hri_bench.run.agents import make_agent
from hri_bench.run.runner import Schedule, run_episodes
from hri_envs.envs.backends import GraphBatch
from hri_envs.errors import ConfigError
from hri_envs.humans.protocol import BatchHuman
from hri_envs.task.graph import TaskGraph
from hri_envs.task.scenarios import Layout

__all__ = ["EndedSession", "MessageError", "PersonHuman", "Session", "SessionManager",
           "load_json", "parse_message"]

log = logging.getLogger("hri_bench.serve")

#: The largest message a page may send, in characters.
MAX_MESSAGE = 1024
#: Client response times above this are not believed (recorded as unknown).
MAX_RT_MS = 24 * 3600 * 1000.0
#: Seconds a session nobody has played yet stays without a connected page before it is
#: abandoned (and its folder removed): the page connects as soon as it has joined, and
#: reconnects within seconds; a client that joins and leaves holds a place no longer.
CLAIM_TIMEOUT_S = 30.0
#: The clock of the sessions' timeouts (a test may put a fake clock in its place).
_clock = time.monotonic


@functools.cache
def writer_pool() -> ThreadPoolExecutor:
    """The thread that writes finished episodes, one at a time, in the order handed in."""
    return ThreadPoolExecutor(1, thread_name_prefix="hri-bench-writer")


class MessageError(ConfigError):
    """A message from the page that is refused; ``field`` names the offending part."""


def _whole(value: Any, field: str, low: int, high: int) -> int:
    if type(value) is not int or not low <= value <= high:
        raise MessageError(f"{field} must be a whole number in [{low}, {high}], got "
                           f"{json.dumps(value)[:40]}", field=field)
    return value


#: Message type -> its fields (besides "type"): the schema of what a page may send.
MESSAGES: dict[str, tuple[str, ...]] = {
    "hello": ("session",),
    "action": ("seq", "action", "rt_ms"),
    "continue": ("seq",),
    "hand": HAND_FIELDS,  # a physical task's input (hand.py)
}


def _once(pairs: list[tuple[str, Any]]) -> dict[str, Any]:
    """A JSON object's members, each key once (``object_pairs_hook``)."""
    doc: dict[str, Any] = {}
    for key, value in pairs:
        if key in doc:
            raise MessageError(f"the key {json.dumps(key)[:40]} is given twice; give each "
                               "once", field=str(key)[:40])
        doc[key] = value
    return doc


def load_json(text: str | bytes, what: str = "a message") -> Any:
    """``text`` parsed as JSON whose objects give each key once.

    Raises:
        MessageError: Not JSON (``field="message"``), or a key given twice (the field is
            the key).
    """
    try:
        return json.loads(text, object_pairs_hook=_once)
    except MessageError:
        raise
    except (ValueError, RecursionError):
        raise MessageError(f"{what} is a JSON object; this is not JSON", field="message"
                           ) from None


def parse_message(text: Any) -> dict[str, Any]:
    """A page's message, validated: a JSON object of a known ``type`` with exactly its
    fields (each once, none missing; ``rt_ms`` may be null), of their types
    (:data:`MESSAGES`); :class:`MessageError` naming the field otherwise.
    """
    if not isinstance(text, str) or len(text) > MAX_MESSAGE:
        raise MessageError(f"a message is a JSON text of at most {MAX_MESSAGE} characters",
                           field="message")
    msg = load_json(text)
    if not isinstance(msg, dict):
        raise MessageError("a message is a JSON object with a 'type'", field="message")
    kind = msg.get("type")
    if not isinstance(kind, str) or kind not in MESSAGES:
        raise MessageError(f"type must be one of {', '.join(MESSAGES)}, got "
                           f"{json.dumps(kind)[:40]}", field="type")
    fields = MESSAGES[kind]
    unknown = sorted(set(msg) - {"type", *fields})
    if unknown:
        raise MessageError(f"a {kind!r} message has the fields {', '.join(fields)}; unknown: "
                           f"{', '.join(map(str, unknown))[:80]}", field=str(unknown[0])[:40])
    missing = [f for f in fields if f not in msg]
    if missing:
        raise MessageError(f"a {kind!r} message has the fields {', '.join(fields)}; missing: "
                           f"{', '.join(missing)}" + (" (null when not measured)"
                                                      if missing[0] == "rt_ms" else ""),
                           field=missing[0])
    if kind == "hello":
        token = msg.get("session")
        if not isinstance(token, str) or not 16 <= len(token) <= 128:
            raise MessageError("session must be the session's token", field="session")
    else:
        _whole(msg.get("seq"), "seq", 0, 2**31)
    if kind == "hand":
        check_hand(msg, MessageError)
    if kind == "action":
        _whole(msg.get("action"), "action", 0, 1000)
        rt = msg.get("rt_ms")
        if rt is not None and (type(rt) not in (int, float) or not 0 <= rt <= MAX_RT_MS):
            raise MessageError(f"rt_ms must be null or a number of milliseconds in [0, "
                               f"{MAX_RT_MS:.0f}]", field="rt_ms")
    return msg


class PersonHuman(BatchHuman):
    """A person at a web page in the human's seat (one row): each ``act`` shows the page
    the step and waits for the person's action (:meth:`Session.ask`).

    Attributes:
        client_response_ms: (1,) the response time the page measured, NaN when unknown.
    """

    name = "person"

    def __init__(self, graph: TaskGraph, ask: Callable[[Mapping[str, np.ndarray]], int]) -> None:
        super().__init__(graph, 1)
        self.ask = ask
        self.client_response_ms = np.full(1, np.nan)

    def act(self, observations: Mapping[str, np.ndarray], active: np.ndarray) -> np.ndarray:
        """The person's action (blocks until the page sends a valid one)."""
        return np.array([self.ask(observations)], dtype=np.int64)


class Session:
    """One participant: a robot, a recorder and the thread that runs the episodes.

    Args:
        config: The server's settings.
        design: The participant's counterbalanced design.
        writer: Where the session is recorded.
        on_view: Called (from the session's thread) whenever a new view is published.
    """

    def __init__(self, config: ServeConfig, design: Assignment, writer: SessionWriter,
                 on_end: Callable[[Session], None] | None = None) -> None:
        self.config, self.design, self.writer = config, design, writer
        self.on_end = on_end
        self.token = secrets.token_urlsafe(32)
        self.participant = writer.participant
        self.graph = config.graph
        self._lock = threading.Lock()
        self._actions: queue.Queue[tuple[str, int]] = queue.Queue()
        self._listeners: list[Callable[[], None]] = []
        self._owner: Callable[[], None] | None = None
        self._view: dict[str, Any] = {"type": "wait", "seq": 0}
        self._text = json.dumps(self._view)
        self._expect: tuple[str, int, frozenset[int]] | None = None  # (type, seq, actions)
        self._stop: str | None = None
        self.final_seq: int | None = None  # the seq of the last view (done, ended)
        self.last_activity = _clock()
        self._unwatched = self.last_activity  # since when no page is connected
        self.outcomes: list[dict[str, Any]] = []
        self.finished = threading.Event()
        self.error: str | None = None  # why it failed, for the page
        n_e = config.episodes
        self.person = PersonHuman(self.graph, self._ask)
        # the robot is made, and called, in a worker thread of its own (robot.py), by the
        # session's thread: an agent that fails or hangs ends this session only
        # a call may take --agent-timeout, and no longer than --idle-timeout: a hung robot
        # idles the session too; the page is told when the robot is slow
        timeout, limit = min((config.agent_timeout_s, "--agent-timeout"),
                             (config.idle_timeout_s, "--idle-timeout"))
        self.worker = AgentWorker(f"robot-{self.participant}", timeout, limit, self._slow)
        self.played = False  # the page has answered a view
        self.discarded = False  # ended unplayed: its folder was removed
        self.agent: GuardedAgent | None = None
        self.recorder: RecordingHumans | None = None
        starts = np.array([[p[0] for p in design.pairs]], dtype=np.int64)
        goals = np.array([[p[1] for p in design.pairs]], dtype=np.int64)
        self.schedule = Schedule(starts, goals, np.zeros((1, n_e), dtype=bool))
        sample = config.spec.layout
        rng = np.random.default_rng([config.seed, design.index, 3])
        self.layouts: list[Layout | None] = [None if sample is None else sample(rng)
                                             for _ in range(n_e)]
        self._episode = 0
        self._step = 0
        self._last: tuple[int, int, int] | None = None
        self._written: Future[None] | None = None
        self.thread = threading.Thread(target=self._run, name=f"session-{self.participant}",
                                       daemon=True)

    # ----------------------------------------------------------------- the page's side
    def subscribe(self, listener: Callable[[], None]) -> Callable[[], None]:
        """Call ``listener`` on every new view (from the session's thread); returns the
        function that unsubscribes it.
        """
        with self._lock:
            self._listeners.append(listener)

        def unsubscribe() -> None:
            with self._lock:
                if listener in self._listeners:
                    self._listeners.remove(listener)

        return unsubscribe

    def connect(self, on_replaced: Callable[[], None]) -> object:
        """Make a new connection the session's page; the previous one, if any, is told by its
        ``on_replaced`` (a reload, or a second tab, takes the session over). Returns the
        connection's handle for :meth:`disconnect`.
        """
        with self._lock:
            old, self._owner = self._owner, on_replaced
        if old is not None:
            old()
        return on_replaced

    def disconnect(self, handle: object) -> None:
        """The connection ``handle`` closed."""
        with self._lock:
            if self._owner is handle:
                self._owner = None
                self._unwatched = _clock()

    def view(self) -> tuple[int, str]:
        """The current view: its ``seq`` and its JSON text."""
        with self._lock:
            return int(self._view["seq"]), self._text

    def handle(self, msg: Mapping[str, Any]) -> None:
        """Apply a validated ``action`` or ``continue`` message (:func:`parse_message`).

        Raises:
            MessageError: The message does not answer the current view (another ``seq``, a
                ``continue`` during a step, an action the step does not offer); nothing
                changes.
        """
        with self._lock:
            kind, seq, actions = self._expected(msg)
            if kind == "action" and msg["action"] not in actions:
                raise MessageError(f"action {msg['action']} is not offered in this step; "
                                   f"offered: {', '.join(map(str, sorted(actions)))}",
                                   field="action")
            self._answered()
            if kind == "action":
                rt = msg.get("rt_ms")
                self.person.client_response_ms[0] = np.nan if rt is None else float(rt)
            self._actions.put((kind, int(msg.get("action", 0))))

    #: What the page waits for in a step, as the participant is told.
    _STEP_ANSWER = "an action"

    def _expected(self, msg: Mapping[str, Any]) -> tuple[str, int, frozenset[int]]:
        """The answer the page's view waits for, (type, seq, actions), if ``msg`` gives it
        (called holding the lock).

        Raises:
            MessageError: No view waits, or ``msg`` is of another type or answers another
                view (``seq``).
        """
        expect = self._expect
        if expect is None:
            raise MessageError("the session is not waiting for you now", field="type")
        kind, seq, _ = expect
        if msg["type"] != kind:
            want = "'continue'" if kind == "continue" else self._STEP_ANSWER
            raise MessageError(f"the page shows a {self._view['type']}; it waits for "
                               f"{want}", field="type")
        if msg["seq"] != seq:
            raise MessageError(f"seq {msg['seq']} does not answer the view on the page "
                               f"(seq {seq}); reload the page", field="seq")
        return expect

    def _answered(self) -> None:
        """The page answered the view (lock held): nothing awaited, the session active and
        played (a session once played is never abandoned as unclaimed nor its folder
        removed).
        """
        self._expect = None
        self.last_activity = _clock()
        self.played = True

    def stop(self, status: str = "stopped") -> None:
        """End the session (the thread records ``status`` and exits, without waiting for a
        call of the robot under way).
        """
        with self._lock:
            if self._stop is None:
                self._stop = status
        self.worker.stop(status)
        self._actions.put(("stop", 0))

    # ----------------------------------------------------------------- the thread's side
    def _publish(self, view: dict[str, Any], expect: tuple[str, frozenset[int]] | None
                 ) -> None:
        with self._lock:
            view["seq"] = int(self._view["seq"]) + 1
            self._view, self._text = view, json.dumps(view)
            if view["type"] in ("done", "ended"):
                self.final_seq = view["seq"]
            self._expect = None if expect is None else (expect[0], view["seq"], expect[1])
            listeners = list(self._listeners)
        for listener in listeners:
            listener()

    def _slow(self, what: str) -> None:
        """The robot is slow to answer: the page says so (a view to wait on)."""
        self._publish({"type": "wait", "message": "The robot is thinking "
                       f"({what.removesuffix('()')})..."}, None)

    def _wait(self) -> int:
        """Block until the page answers the current view; the action (0 for continue). The
        session is abandoned after ``idle_timeout_s`` without an answer, and, before its
        first answer, after :data:`CLAIM_TIMEOUT_S` without a connected page.
        """
        while True:
            try:
                kind, action = self._actions.get(timeout=0.5)
            except queue.Empty:
                kind, action = "", 0
            with self._lock:
                stop = self._stop
            if stop is not None:
                raise Stopped(stop)
            if kind in ("action", "continue", "hand"):
                return action
            now = _clock()
            with self._lock:
                unclaimed = (not self.played and self._owner is None
                             and now - self._unwatched > CLAIM_TIMEOUT_S)
            if unclaimed or now - self.last_activity > self.config.idle_timeout_s:
                raise Stopped("abandoned")

    def _header(self) -> dict[str, Any]:
        names = self.graph.support_names
        start, goal = self.design.pairs[self._episode]
        pref = self.design.preference
        return {"episode": self._episode + 1, "episodes": self.config.episodes,
                "start": int(start), "start_name": names[start], "goal": int(goal),
                "goal_name": names[goal],
                "preference": None if pref is None else describe_preference(
                    self.config.spec, pref)}

    def _ask(self, observations: Mapping[str, np.ndarray]) -> int:
        """The loop asks the person to act: publish the frame, wait for a valid action."""
        g = self.graph
        s, a_r = int(observations["state"][0]), int(observations["robot_action"][0])
        options = [int(a) for a in np.flatnonzero(g.valid[s])]
        note = None
        if self._last is not None and g.aborted[self._last]:
            note = "Nothing moved: your action and the robot's did not fit together."
        view = {"type": "frame", **self._header(), "step": self._step + 1,
                "max_steps": self.config.max_steps, "state": s, "state_name": g.state_names[s],
                "robot": g.agent_action_label(s, a_r, robot=True), "note": note,
                "options": [{"action": a, "label": g.agent_action_label(s, a, robot=False),
                             "key": str(i + 1) if i < 9 else ""}
                            for i, a in enumerate(options)],
                **self._scene(s)}
        if self.config.show_belief and self.agent is not None:
            belief = read_belief(self.agent)
            if belief is not None:
                view["belief"] = {n: round(float(b), 3) for n, b in
                                  zip(g.support_names, np.asarray(belief)[0], strict=True)}
        self.person.client_response_ms[0] = np.nan
        self._publish(view, ("action", frozenset(options)))
        a_h = self._wait()
        self._last = (s, a_r, a_h)
        self._step += 1
        return a_h

    def _scene(self, state: int) -> dict[str, Any]:
        """The 3D view of ``state`` in this episode (:func:`~hri_bench.people.serve.scenes.
        graph_view`).
        """
        return graph_view(self.graph, self.layouts[self._episode], state,
                          self.design.pairs[self._episode][0])

    def _prerender(self, episode: int) -> None:
        """Compute an episode's first view ahead, while the page shows the last outcome
        (the wheel's layout is new each episode; later states are placed when first
        needed, about 10 ms each on the wheel, and kept).
        """
        if 0 <= episode < self.config.episodes:
            warm(self.graph, self.layouts[episode], self.design.pairs[episode][0])

    def _make_robot(self) -> tuple[GuardedAgent, RecordingHumans]:
        """The robot agent, made in its worker as in a study, and the recorder around the
        person.
        """
        cfg, design = self.config, self.design
        inner = self.worker.call("making the agent", lambda: make_agent(
            cfg.agent, self.graph, self.person, [design.index], seed=cfg.seed,
            r0=cfg.waiting_reward, learner=dict(cfg.learner), max_steps=cfg.max_steps,
            reward=cfg.reward))
        if not isinstance(inner, BatchAgent):
            raise AgentFailed("the robot could not be made",
                              f"the agent is a {type(inner).__name__}, not a BatchAgent")
        agent = GuardedAgent(inner, self.worker)
        recorder = RecordingHumans(self.person, [self.writer], agent=agent,
                                   r0=cfg.waiting_reward, reward=cfg.reward,
                                   session_index=[design.index], layouts=[self.layouts],
                                   defer_writes=True)
        return agent, recorder

    def _play(self) -> None:
        """The session's episodes, each outcome shown; returns when all are played."""
        cfg = self.config
        names = self.graph.support_names
        self._prerender(0)
        self.agent, self.recorder = self._make_robot()
        loop = run_episodes(self.graph, self.agent, self.recorder, self.schedule,
                            GraphBatch(self.graph, [self.design.index], cfg.seed),
                            r0=cfg.waiting_reward, max_steps=cfg.max_steps, reward=cfg.reward)
        for result in loop:
            end = int(result.traces[0].states[-1])
            reached = int(result.intentions[0])
            goal = self.design.pairs[self._episode][1]
            outcome = {"episode": self._episode + 1,
                       "reached_name": None if reached < 0 else names[reached],
                       "goal_name": names[goal], "success": reached == goal,
                       "truncated": bool(result.metrics.truncated[0]),
                       "steps": int(result.metrics.steps[0]),
                       "reward": round(float(result.metrics.reward[0]), 4)}
            self.outcomes.append(outcome)
            last = self._episode + 1 == cfg.episodes
            self._publish({"type": "outcome", **self._header(), **outcome, "last": last,
                           **self._scene(end)},
                          None if last else ("continue", frozenset()))
            # written by the server's writer thread while the page shows the outcome
            self._written = writer_pool().submit(self.recorder.flush)
            if last:
                return
            self._prerender(self._episode + 1)
            self._wait()
            self._episode += 1
            self._step = 0
            self._last = None

    def _run(self) -> None:
        """The session's thread: play, then record how it ended and tell the page. Whatever
        happens (the robot raising, exiting or hanging included) the session ends, is
        recorded and the page is told.
        """
        status, detail = "complete", None
        try:
            self._play()
        except Stopped as stop:
            status = stop.status
        except AgentFailed as exc:  # the robot's fault: this session ends, the others go on
            log.error("session %s failed: %s", self.participant, exc.detail)
            status, self.error, detail = "failed", exc.public, exc.detail
        except BaseException as exc:  # noqa: BLE001 (a session never stays running)
            log.exception("session %s failed", self.participant)
            status = "failed"
            self.error = f"the session failed ({type(exc).__name__})"
            detail = f"{type(exc).__name__}: {str(exc)[:300]}"
        self.worker.close()
        self._end(status, detail)

    def _end(self, status: str, detail: str | None) -> None:
        """Wait for the episodes' writes, record the status, publish the last view."""
        try:
            if self._written is not None:
                self._written.result()
        except OSError:
            log.exception("session %s: cannot write an episode", self.participant)
            status = "failed"
            self.error = self.error or "the session could not be recorded"
        if detail is not None:
            self.writer.meta["error"] = detail
        try:
            if not self.played and status in ("abandoned", "stopped") and not self.writer.episodes:
                shutil.rmtree(self.writer.path)  # a join never played: nothing to keep
                self.discarded = True
            else:
                self.writer.finish(status)
                make_private(self.writer.path)
        except OSError:
            log.exception("session %s: cannot write its metadata", self.participant)
        if status == "complete":
            self._publish({"type": "done", "participant": self.participant,
                           "outcomes": self.outcomes}, None)
        else:
            self._publish({"type": "ended", "reason": status, "error": self.error,
                           "participant": self.participant}, None)
        if self.on_end is not None:
            self.on_end(self)  # the server keeps its last view only
        self.finished.set()


class EndedSession:
    """What the server keeps of a session that has ended and is recorded: its last view
    (``done`` or ``ended``), so that a reload still shows it, and nothing else (the robot,
    the recorder and the thread are freed).
    """

    def __init__(self, session: Session) -> None:
        self.participant = session.participant
        self.seq, self.text = session.view()
        self.final_seq: int | None = self.seq
        self.ended_at = time.monotonic()
        self.finished = threading.Event()
        self.finished.set()

    def subscribe(self, listener: Callable[[], None]) -> Callable[[], None]:
        """No view will follow."""
        return lambda: None

    def connect(self, on_replaced: Callable[[], None]) -> object:
        """Any number of pages may show the last view."""
        return on_replaced

    def disconnect(self, handle: object) -> None:
        """Nothing to do."""

    def view(self) -> tuple[int, str]:
        """The last view."""
        return self.seq, self.text

    def handle(self, msg: Mapping[str, Any]) -> None:
        """Nothing is accepted any more.

        Raises:
            MessageError: Always.
        """
        raise MessageError("the session is over", field="type")


def _rows(dataset: Any) -> tuple[int, list[int]]:
    """A :class:`~hri_bench.data.datasets.Dataset`'s next new row of the design, and the
    rows below it no session holds (a join never played leaves no folder: its row is given
    to the next participant), from the sessions' ``session_index``; with a session whose
    file cannot be read, no row is reused.
    """
    taken: set[int] = set()
    unread = 0
    for folder in dataset.session_dirs():
        try:
            index = json.loads((folder / "session.json").read_text(encoding="utf-8")).get(
                "session_index")
        except (OSError, ValueError, AttributeError):
            index = None
        if isinstance(index, int) and not isinstance(index, bool) and index >= 0:
            taken.add(index)
        else:
            unread += 1
    joined = max(max(taken, default=-1) + 1, len(taken) + unread)
    return joined, ([] if unread else sorted(set(range(joined)) - taken))


#: How long, and up to how many bytes in all, the last views of ended sessions are kept.
ENDED_KEEP_S = 3600.0
ENDED_KEEP_BYTES = 8 << 20


class SessionManager:
    """The server's sessions, by token; creates them in join order (the design's rows).

    Args:
        config: The server's settings.
    """

    def __init__(self, config: ServeConfig) -> None:
        import pyarrow.parquet  # noqa: F401  (the web extra; loaded once, before a session writes)

        if config.agent in ("learner", "maxent") and not config.physical:
            # compiled (the first time after installing) or loaded now, so that no robot's
            # first call waits for them (and none runs into --agent-timeout)
            algorithm1.preload()
        self.config = config
        self.dataset = self._open_dataset()
        self._dataset_lock = DatasetLock(self.dataset)  # one server per dataset (store.py)
        try:
            #: Sessions a server that was killed left running, now marked interrupted.
            self.interrupted = mark_interrupted(self.dataset)
            make_private(self.dataset.path)
        except OSError as exc:
            self._dataset_lock.release()
            raise ConfigError(f"cannot use the dataset folder {self.dataset.path} "
                              f"({exc.strerror or exc}): {exc.filename}", field="data") from None
        self._lock = threading.Lock()
        self._sessions: dict[str, Session] = {}  # running
        self._ended: dict[str, EndedSession] = {}  # in the order they ended
        self._ended_bytes = 0
        self._joined, self._free = _rows(self.dataset)

    def _open_dataset(self) -> Dataset:
        """The dataset the sessions are recorded in (made if new)."""
        config = self.config
        return create_dataset(config.dataset_id, config.graph, synthetic=False,
                              root=config.data,
                              description="people in the human's seat (hri-bench serve)")

    def create(self) -> Session:
        """A new participant's session, started.

        Raises:
            ConfigError: As many sessions run as ``max_sessions`` allows (``field="sessions"``).
        """
        cfg = self.config
        with self._lock:
            if len(self._sessions) >= cfg.max_sessions:
                raise ConfigError(f"the study is full ({cfg.max_sessions} sessions at once); "
                                  "try again later", field="sessions")
            index = self._free[0] if self._free else self._joined
            session = self._new_session(index, assignment(cfg, index))
            self._take(index)  # the design's row is taken once the session is on disk
            self._sessions[session.token] = session
        session.thread.start()
        return session

    def _new_session(self, index: int, design: Assignment) -> Session:
        """Participant ``index``'s session, recorded from now (not started)."""
        cfg = self.config
        writer = SessionWriter(self.dataset, new_participant_id(), {
            "source": "web", "human": "person", "session_index": index,
            "scenario": cfg.scenario, "r0": cfg.waiting_reward, "reward_rule": cfg.reward,
            "max_steps": cfg.max_steps, "seed": cfg.seed, "run": index,
            "episodes_planned": cfg.episodes,
            "schedule": [[int(a), int(b), False] for a, b in design.pairs],
            "preference": design.preference, "serve_settings": cfg.settings(),
            **agent_identity(cfg.agent, cfg.spec, cfg.waiting_reward, dict(cfg.learner))})
        return Session(cfg, design, writer, on_end=self._retire)

    def _retire(self, session: Session) -> None:
        """A session has ended and is recorded: keep its last view only (an
        :class:`EndedSession`, for :data:`ENDED_KEEP_S` and within
        :data:`ENDED_KEEP_BYTES` in all, the oldest dropped first).
        """
        ended = EndedSession(session)
        with self._lock:
            if session.discarded:  # never played: its row of the design goes to the next
                self._free = sorted({*self._free, session.design.index})
            self._sessions.pop(session.token, None)
            self._ended[session.token] = ended
            self._ended_bytes += len(ended.text)
            self._prune()

    def _take(self, index: int) -> None:
        """Row ``index`` of the design is a session's (lock held)."""
        if index in self._free:
            self._free.remove(index)
        else:
            self._joined = index + 1

    def _prune(self) -> None:
        """Drop the last views kept too long or beyond the byte budget (lock held)."""
        now = time.monotonic()
        while self._ended:
            token, oldest = next(iter(self._ended.items()))
            if (now - oldest.ended_at <= ENDED_KEEP_S
                    and self._ended_bytes <= ENDED_KEEP_BYTES):
                break
            del self._ended[token]
            self._ended_bytes -= len(oldest.text)

    def running(self) -> int:
        """How many sessions run."""
        with self._lock:
            return len(self._sessions)

    def get(self, token: Any) -> Session | EndedSession | None:
        """The session whose token this is (or the last view of one that ended), or None
        (compared in constant time).
        """
        if not isinstance(token, str):
            return None
        found: Session | EndedSession | None = None
        with self._lock:
            self._prune()
            for table in (self._sessions, self._ended):
                for known, session in table.items():
                    if secrets.compare_digest(known.encode(), token.encode()):
                        found = session
        return found

    def close(self, timeout: float = 5.0) -> None:
        """Stop every session (:meth:`stop_all`), then let another server use the dataset
        (a session that did not end in time stays ``running`` on disk: the next server
        marks it ``interrupted``).
        """
        self.stop_all(timeout)
        self._dataset_lock.release()

    def stop_all(self, timeout: float = 5.0) -> None:
        """Stop every session (status ``stopped``) and wait for their threads."""
        with self._lock:
            sessions = list(self._sessions.values())
        for s in sessions:
            s.stop("stopped")
        deadline = time.monotonic() + timeout
        for s in sessions:
            s.thread.join(max(0.0, deadline - time.monotonic()))
