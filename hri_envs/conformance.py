"""Conformance checks anyone can run on what they add, as PettingZoo ships ``api_test``.

Each check raises a :class:`~hri_envs.errors.ConfigError` naming the first thing that does
not hold (``field`` says what), and returns a short report on success. The test suite runs
them over every registered entry (``tests/test_conformance.py``); docs/extending.md ends
each guide with the one that fits. The robot's side has its own:
:func:`agents.conformance.check_agent`.

* :func:`check_scenario`: a :class:`~hri_envs.task.scenarios.ScenarioSpec` builds a graph
  of its ``n_actions``, every preference's scripted human leads every start to every goal,
  and its robot env passes Gymnasium's ``check_env``.
* :func:`check_human`: a human (a :class:`~hri_envs.humans.spec.HumanSpec` or a ready-made
  one) plays episodes in a robot env without failing, the same ones for the same seed, and
  can be seated in several rows.
* :func:`check_reward_rule`: a :class:`~hri_envs.task.episode.RewardRule` gives rewards in
  [-1, 0] of the steps' shape, the same on the env's fused table as step by step.
* :func:`check_backend`: a registered :class:`~hri_envs.envs.backends.BackendSpec` loads,
  its robot env passes Gymnasium's ``check_env`` and plays the same episodes for the same
  seed, and its :class:`~hri_envs.envs.backends.BatchBackend` moves runs as the benchmark's
  loop expects, the same runs alike whatever batch they are in.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from hri_envs.envs.backends import (
    BACKENDS,
    BackendSpec,
    BatchBackend,
    BatchStep,
    backend_spec,
    batch_backend,
)
from hri_envs.envs.episode import Episode
from hri_envs.errors import ConfigError
from hri_envs.humans.scripted import preference_human
from hri_envs.humans.seat import HumanLike, seat_human
from hri_envs.humans.spec import HumanBody
from hri_envs.imports import import_class, import_object
from hri_envs.task import episode as rules
from hri_envs.task.actions import WAIT
from hri_envs.task.episode import RewardRule
from hri_envs.task.graph import TaskGraph
from hri_envs.task.scenarios import SCENARIOS, ScenarioSpec, as_spec, graph_of

__all__ = ["check_backend", "check_human", "check_reward_rule", "check_scenario"]


def _fail(what: str, field: str) -> ConfigError:
    return ConfigError(what, field=field)


def _named(exc: BaseException) -> str:
    """An exception as its class and message (a ConfigError's message alone)."""
    return str(exc) if isinstance(exc, ConfigError) else f"{type(exc).__name__}: {exc}"


def check_scenario(spec: ScenarioSpec | str, *, env: bool = True) -> str:
    """Check a scenario (registered or not).

    Args:
        spec: The spec, or a registered scenario's name.
        env: Also build its robot env (it must be registered) and run Gymnasium's
            ``check_env`` on it.

    Raises:
        ConfigError: The graph does not build or has another number of actions than the
            spec says; a preference's scripted human cannot lead from a start to a goal with
            the robot following (``field="route"``); the env fails ``check_env``
            (``field="env"``).
    """
    spec = as_spec(spec)
    graph = graph_of(spec)
    if graph.n_actions != spec.n_actions:
        raise _fail(f"scenario {spec.name!r}: its graph has {graph.n_actions} actions, the "
                    f"spec says n_actions={spec.n_actions}", "n_actions")
    for preference in spec.preferences:
        try:
            human = preference_human(graph, preference)
        except Exception as exc:  # ConfigError, or what the scenario's route raised
            raise _fail(f"scenario {spec.name!r}: preference {preference!r} does not lead the "
                        f"object anywhere a scripted human can follow ({_named(exc)})",
                        "route") from exc
        for start in range(graph.n_intentions):
            for goal in range(graph.n_intentions):
                if goal != start and not _leads(graph, human, start, goal):
                    raise _fail(f"scenario {spec.name!r}: preference {preference!r} does not "
                                f"lead the object from {graph.support_names[start]} to "
                                f"{graph.support_names[goal]} with the robot following",
                                "route")
    if env and SCENARIOS.find(spec.name) is spec:
        _check_env(spec.name)
    return (f"scenario {spec.name!r}: {graph.n_states} states, {graph.n_actions} actions, "
            f"{len(spec.preferences)} preference(s) lead every start to every goal"
            + (", its env passes check_env" if env else ""))


def _leads(graph: TaskGraph, human: Any, start: int, goal: int, limit: int = 200) -> bool:
    """Whether the deterministic human brings the object from ``start`` to ``goal`` while a
    robot that mirrors it (holds when it holds, follows its motions) never blocks it.
    """
    s = int(rules.start_state(graph, start))
    lifted = False
    for _ in range(limit):
        a_h = int(human.preferred_action(s, start, goal)) if hasattr(
            human, "preferred_action") else WAIT
        a_r = a_h if graph.valid[s, a_h] else WAIT
        s = int(graph.next_state[s, a_r, a_h])
        lifted = lifted or bool(rules.left_start(graph, s, start))
        if rules.episode_over(graph, s, start, lifted):
            return int(graph.support[s]) == goal
    return False


def _check_env(name: str) -> None:
    from gymnasium.utils.env_checker import check_env

    from hri_envs.envs.robot import RobotEnv

    try:
        check_env(RobotEnv(name), skip_render_check=True)
    except Exception as exc:  # gymnasium raises AssertionError and others
        raise _fail(f"scenario {name!r}: its robot env fails gymnasium's check_env: "
                    f"{type(exc).__name__}: {exc}", "env") from exc


def check_human(human: HumanLike, scenario: str, *, episodes: int = 4, seed: int = 0) -> str:
    """Check a human in a scenario's robot env (the seat every env, study and ``serve``
    uses).

    Args:
        human: A :class:`~hri_envs.humans.spec.HumanSpec` or a ready-made human (as an env's
            ``human=``). A ready-made human with state of its own is played as given, so
            pass a fresh one.
        scenario: A registered scenario.
        episodes: Episodes played, with a robot that waits and one that acts at random.
        seed: The first seed.

    Raises:
        ConfigError: It cannot be seated, fails while playing (an action outside the action
            set included), is not the same for the same seed, or cannot be seated in several
            rows (``field="human"``).
    """
    from hri_envs.envs.robot import RobotEnv

    env = _seated(lambda: RobotEnv(scenario, human=human), human)
    first = _play(env, episodes, seed)
    from hri_envs.humans.spec import HumanSpec

    if isinstance(human, HumanSpec):  # a spec can be seated afresh: the same seed, the same
        again = _play(_seated(lambda: RobotEnv(scenario, human=human), human), episodes, seed)
        if again != first:
            raise _fail(f"human {human!r}: two envs with seed {seed} saw different actions",
                        "human")
        seat = _seated(lambda: seat_human(env.graph, human=human, n_runs=3), human)
        if seat.n_runs != 3:
            raise _fail(f"human {human!r}: a seat of 3 rows has {seat.n_runs}", "human")
    return (f"human {human!r} on the {scenario}: {episodes} episodes with valid actions"
            + (", reproducible by seed" if isinstance(human, HumanSpec) else ""))


def _seated(make: Any, human: Any) -> Any:
    """``make()``: an env or seat of ``human``; what its family or model raises is a
    ConfigError naming the human.
    """
    try:
        return make()
    except ConfigError:
        raise
    except Exception as exc:  # the family's builder or the human's own code
        raise _fail(f"human {human!r} cannot be seated: {_named(exc)}", "human") from exc


def _play(env: Any, episodes: int, seed: int) -> list[int]:
    """The human's actions over ``episodes`` episodes (a waiting robot, then a random one);
    the seat refuses an action outside the action set (``checked_actions``), and an action
    not valid in the state aborts the step, which the env counts.
    """
    rng = np.random.default_rng(seed)
    seen: list[int] = []
    for e in range(episodes):
        try:
            obs, _ = env.reset(seed=seed + e)
        except Exception as exc:
            raise _fail(f"the human failed at the reset of episode {e + 1}: {_named(exc)}",
                        "human") from exc
        done = False
        while not done:
            mask = obs["action_mask"].astype(bool)
            a = WAIT if e % 2 == 0 else int(rng.choice(np.flatnonzero(mask)))
            try:
                obs, _, terminated, truncated, _ = env.step(a)
            except Exception as exc:
                raise _fail(f"the human failed in episode {e + 1}: {type(exc).__name__}: "
                            f"{exc}", "human") from exc
            seen.append(int(obs["last_human_action"]))
            done = terminated or truncated
    return seen


def check_reward_rule(rule: RewardRule | str, scenarios: tuple[str, ...] | None = None
                      ) -> str:
    """Check a reward rule on every (state, robot action, human action, start, lifted) of
    the scenarios' graphs.

    Raises:
        ConfigError: Its rewards are not of the steps' shape, not finite or outside
            [-1, 0], or differ between the env's fused table (:class:`StepTable`) and
            :func:`~hri_envs.task.episode.step_reward` (``field="reward"``).
    """
    rule = rules.reward_rule(rule) if isinstance(rule, str) else rule
    if not isinstance(rule, RewardRule):
        raise _fail(f"check_reward_rule takes a RewardRule or a registered rule's name, got "
                    f"{rule!r}", "reward")
    specs = [as_spec(name) for name in scenarios] if scenarios else SCENARIOS.values()
    for spec in specs:
        rules.verify_reward_rule(rule, graph_of(spec))
    return f"reward rule {rule.name!r}: rewards in [-1, 0], the same on every path"


# --------------------------------------------------------------------------- a backend
def check_backend(spec: BackendSpec | str, scenario: str = "hanger", *, episodes: int = 2,
                  runs: int = 2, max_steps: int = 40, seed: int = 0) -> str:
    """Check a registered backend (docs/extending.md, "A backend").

    Its entry points load (an :class:`~hri_envs.envs.episode.Episode` subclass, a
    :class:`~hri_envs.envs.backends.BatchBackend` subclass, the options checker, which
    accepts no options and every preset, and the vector and continuous entries it names);
    its robot env passes Gymnasium's ``check_env`` and plays the same episodes for the same
    seed; its batch moves ``runs`` runs, a robot mirroring the scripted human, as the
    benchmark's loop (:func:`hri_bench.run.runner.simulate`) expects: its groups hold every
    row once, every step reports states of the graph, the human's actions, faults and
    penalties as flags and the figures :attr:`BatchBackend.extras` names, one per row; the
    same runs move alike again, and a run alone moves as it did in the batch (its random
    streams derive from ``(seed, run)``).

    Args:
        spec: A registered backend, or its name (the envs look backends up by name).
        scenario: A registered scenario with a Gymnasium robot env.
        episodes: Episodes of the robot env per play.
        runs: Runs of the batch.
        max_steps: Steps per episode at most.
        seed: The first seed.

    Raises:
        ConfigError: ``spec`` is not registered (``field="backend"``), or the first of the
            above that does not hold (``field="backend"``; ``"env"`` for the robot env).
        BackendUnavailableError: Its extra is not installed.
    """
    name = spec if isinstance(spec, str) else getattr(spec, "name", None)
    if not isinstance(spec, str) and (not isinstance(name, str)
                                      or BACKENDS.find(name) is not spec):
        raise _fail(f"check_backend checks a registered backend (the envs look it up by "
                    f"name): register_backend({spec!r}) first", "backend")
    assert isinstance(name, str)
    found = backend_spec(name)  # registered, and its extra installed
    _check_entries(found)
    steps, graph = _check_backend_env(name, scenario, episodes, max_steps, seed)
    first = _play_batch(name, graph, tuple(range(runs)), max_steps, seed)
    if _play_batch(name, graph, tuple(range(runs)), max_steps, seed) != first:
        raise _fail(f"backend {name!r}: the same runs moved differently the second time: "
                    "draw randomness only from generators seeded by (seed, run)", "backend")
    alone = _play_batch(name, graph, (runs - 1,), max_steps, seed)
    if alone[0] != first[runs - 1]:
        raise _fail(f"backend {name!r}: run {runs - 1} moved differently alone than in a "
                    f"batch of {runs}: a run's random streams must derive from (seed, run) "
                    "only, not from the batch", "backend")
    moves = sum(len(row) for row in first)
    return (f"backend {name!r} on the {scenario}: its env passes check_env and replays "
            f"{steps} steps alike; its batch moved {runs} runs {moves} steps, alike again "
            "and alone")


def _check_entries(spec: BackendSpec) -> None:
    """Its entry points load as what they must be; its options checker takes its presets
    and the options of a default body (its ``body`` converter's, if it has one).
    """
    what = f"backend {spec.name!r}'s"
    import_class(spec.episode, f"{what} episode", "backend", (Episode,))
    batch: type[BatchBackend] = import_class(spec.batch, f"{what} batch", "backend",
                                             (BatchBackend,))
    if not set(batch.step_means) <= set(batch.extras):
        raise _fail(f"backend {spec.name!r}: step_means {batch.step_means} are not all among "
                    f"its extras {batch.extras}", "backend")
    for field in ("options", "body", "vector_entry", "carry", "carry_vector"):
        entry = getattr(spec, field)
        if entry is not None and not callable(import_object(entry, f"{what} {field}",
                                                            "backend")):
            raise _fail(f"backend {spec.name!r}: {field}={entry!r} is not callable", "backend")
    if spec.options is not None:
        checker = import_object(spec.options, f"{what} options", "backend")
        bodies = [] if spec.body is None else [
            import_object(spec.body, f"{what} body", "backend")(HumanBody())]
        for options in ({}, *({"preset": p} for p in spec.presets), *bodies):
            try:
                checked = checker(options)
            except Exception as exc:
                raise _fail(f"backend {spec.name!r}: its options checker refuses {options} "
                            f"({type(exc).__name__}: {exc})", "backend") from exc
            if not isinstance(checked, dict):
                raise _fail(f"backend {spec.name!r}: its options checker returns "
                            f"{type(checked).__name__}, not the checked options' dict",
                            "backend")


def _check_backend_env(name: str, scenario: str, episodes: int, max_steps: int,
                       seed: int) -> tuple[int, TaskGraph]:
    """Gymnasium's ``check_env`` on its robot env, and the same episodes twice: the steps
    of one play, and the env's task graph.
    """
    from gymnasium.utils.env_checker import check_env

    from hri_envs.envs.robot import RobotEnv

    def make() -> RobotEnv:
        return RobotEnv(scenario, backend=name, max_cycles=max_steps)

    try:
        checked = make()
        check_env(checked, skip_render_check=True)
    except Exception as exc:  # gymnasium raises AssertionError and others
        raise _fail(f"backend {name!r}: its robot env fails gymnasium's check_env: "
                    f"{type(exc).__name__}: {exc}", "env") from exc

    def play() -> list[Any]:
        env, out = make(), []
        rng = np.random.default_rng(seed)
        for e in range(episodes):
            obs, _ = env.reset(seed=seed + e)
            done = False
            while not done:
                action = int(rng.choice(np.flatnonzero(obs["action_mask"])))
                obs, reward, terminated, truncated, _ = env.step(action)
                if not -1.0 <= reward <= 0.0:
                    raise _fail(f"backend {name!r}: a step of its robot env earned {reward}, "
                                "outside [-1, 0]", "env")
                out.append((action, int(obs["state"]), float(reward)))
                done = terminated or truncated
        env.close()
        return out

    first = play()
    if play() != first:
        raise _fail(f"backend {name!r}: its robot env played the same seeds differently: draw "
                    "randomness only from the generators reset(seed=...) gives", "env")
    return len(first), checked.graph


def _play_batch(name: str, graph: TaskGraph, runs: tuple[int, ...], max_steps: int,
                seed: int) -> list[list[tuple[Any, ...]]]:
    """Each run's steps (next state, human seen, fault, penalty, figures), the batch driven
    as the benchmark's loop drives it, a robot mirroring the scripted human.
    """
    cls = batch_backend(name)
    backend = cls(graph, list(runs), seed, {})
    n_b = len(runs)
    human = preference_human(graph)
    starts = np.array([r % graph.n_intentions for r in runs])
    goals = (starts + 1) % graph.n_intentions
    rows = np.concatenate([np.asarray(g, dtype=np.int64).ravel() for g in backend.groups()]
                          or [np.zeros(0, dtype=np.int64)])
    if sorted(rows.tolist()) != list(range(n_b)):
        raise _fail(f"backend {name!r}: its groups {backend.groups()} do not hold every row "
                    f"of {n_b} once", "backend")
    state = np.asarray(rules.start_state(graph, starts), dtype=np.int64)
    lifted = np.zeros(n_b, dtype=bool)
    out: list[list[tuple[Any, ...]]] = [[] for _ in range(n_b)]
    for group in backend.groups():
        group = np.asarray(group, dtype=np.int64)
        cannot = np.asarray(backend.begin(group, starts[group]))
        if cannot.shape != group.shape or cannot.dtype != bool:
            raise _fail(f"backend {name!r}: begin returned {cannot!r}, not one flag per row "
                        "of the group", "backend")
        active = np.zeros(n_b, dtype=bool)
        active[group] = ~cannot
        for _ in range(max_steps):
            if not active.any():
                break
            a_h = np.where(active, human.preferred_action(state, starts, goals), WAIT)
            a_r = np.where(graph.valid[state, a_h], a_h, WAIT)
            step = backend.transition(state.copy(), a_r, a_h, active.copy())
            _check_step(name, graph, cls, step, n_b)
            fault = np.zeros(n_b, bool) if step.fault is None else np.asarray(step.fault)
            penalty = np.zeros(n_b, bool) if step.penalty is None else np.asarray(step.penalty)
            for i in np.flatnonzero(active):
                out[i].append((int(step.next_state[i]), int(step.human_seen[i]),
                               bool(fault[i]), bool(penalty[i]),
                               tuple(float(step.extras[k][i]) for k in cls.extras)))
            state = np.where(active, step.next_state, state)
            lifted |= rules.left_start(graph, state, starts)
            active &= ~(fault | penalty | rules.episode_over(graph, state, starts, lifted))
    return out


def _check_step(name: str, graph: TaskGraph, cls: type[BatchBackend], step: Any,
                n_b: int) -> None:
    """One :class:`BatchStep` as the loop reads it."""
    if not isinstance(step, BatchStep):
        raise _fail(f"backend {name!r}: transition returned {type(step).__name__}, not a "
                    "BatchStep", "backend")
    for field, top in (("next_state", graph.n_states), ("human_seen", graph.n_actions)):
        value = np.asarray(getattr(step, field))
        if (value.shape != (n_b,) or not np.issubdtype(value.dtype, np.integer)
                or value.min(initial=0) < 0 or value.max(initial=0) >= top):
            raise _fail(f"backend {name!r}: a step's {field} is {value!r}; it must be {n_b} "
                        f"integers in [0, {top})", "backend")
    for field in ("fault", "penalty"):
        value = getattr(step, field)
        if value is not None and (np.shape(value) != (n_b,)
                                  or np.asarray(value).dtype != bool):
            raise _fail(f"backend {name!r}: a step's {field} is {value!r}; it must be None or "
                        f"{n_b} booleans", "backend")
    if set(step.extras) != set(cls.extras) or any(
            np.shape(v) != (n_b,) or not np.isfinite(v).all() for v in step.extras.values()):
        raise _fail(f"backend {name!r}: a step's figures are {sorted(step.extras)}; it must "
                    f"report {n_b} finite values of each of its extras {cls.extras}", "backend")
