"""Which robot agents the benchmark can run, by name.

The registry (:class:`~agents.registry.AgentSpec`, :data:`~agents.registry.AGENTS`,
:func:`~agents.registry.register_agent`) is :mod:`agents.registry`'s, re-exported here; this
module registers the built-in agents (importing :mod:`hri_bench.run.builtin_agents`, their
specs) and resolves the names that are not registered.

Built in: ``learner``, ``imitator``, ``maxent``, ``passive``, ``oracle``, ``goalfilter`` (a
Bayesian goal filter that learns no preference, :mod:`baselines.goalfilter`), ``countqmdp``
(counts of the human's actions per context, a Bayes filter over ι and QMDP planning,
:mod:`baselines.countqmdp`), and the
references ``informed`` (the information bound: sees ι; exact for every scripted or
finite-state human, shared or drawn per run), ``blind`` (the ceiling for any robot that must
infer ι, exact for one shared deterministic scripted human), see :mod:`baselines.bounds`,
and ``qmdp`` (a feasible intention-blind policy that knows the human's model: the lower
end of the bracket on ``blind`` where the exact plan does not fit), see
:mod:`baselines.product`.

``sb3:PATH`` plays a trained stable-baselines3 / sb3-contrib model saved at ``PATH`` (a
``.zip``; MaskablePPO, PPO, A2C, DQN or :class:`agents.rl.MaskedDQN`) through
:class:`agents.sb3.SB3BatchAgent`: deterministic, invalid actions masked, frozen (it does
not learn between episodes). The file is read without unpickling: its JSON metadata and its
weights (see :func:`agents.sb3.load_model`).

``jaxppo:PATH`` plays a recurrent PPO policy trained in JAX (:mod:`agents.jax_ppo`, the
``jax`` extra) through :class:`agents.jax_ppo.agent.JaxPPOAgent`: greedy, invalid actions
masked, its GRU memory kept across a run's episodes. ``PATH`` is its ``.npz`` checkpoint
(arrays and a JSON config, no pickle) or a folder with one ``<scenario>.npz`` per scenario.
``jaxppo`` alone plays the checkpoints shipped with the package (:data:`JAXPPO_CHECKPOINTS`,
trained by ``benchmarks/train_jax_ppo.py`` on the ``train`` split).

Any other entry of the form ``module:Class`` is an agent of your own, and it runs in a
process of its own (:mod:`hri_bench.run.isolation`): that process imports ``Class`` from
``module`` (this one never does), instantiates an :class:`~agents.protocol.Agent` subclass
once per run, a :class:`~agents.protocol.BatchAgent` subclass once per batch as
``Class(graph, n_runs)``, and gives it, by keyword, each of :data:`CONTRACT` its
constructor names (or all of them if it takes ``**kwargs``): never the study's seed, the run
indices or the human. A constructor that names none of them is called as before
(``Class()``, or ``Class(graph=...)`` for an ``Agent``; docs/agents.md, "Your own agent").
``sb3:PATH`` and ``jaxppo:PATH`` run in the benchmark's process: their code is shipped, and
the user's file is read as data (weights and JSON, never unpickled).

:func:`resolve_agent` turns any of these names into one :class:`AgentSpec` (the registered
one, or an :class:`AgentForm` for the forms above); making, privilege, settings and identity
all ask that spec, so a name's form is read in one place.

:func:`agent_privilege` says what an agent sees besides the robot's view (the intention, the
human's model), from what it declares: that decides whether a suite shows it as a reference.

:func:`agent_identity` names an agent's code for a results file: a built-in agent by the
installed ``hri-envs`` version; ``sb3:PATH`` by the model file's sha256, ``jaxppo[:PATH]``
by its checkpoint files'; ``module:Class`` by the sha256 of its module's source file (every
``.py`` file of its top-level package when it is in one), the files' combined hash
``code_sha256``, and the constructor keywords the benchmark passes it
(:func:`contract_keywords`; docs/results.md, "What is recorded").
"""

from __future__ import annotations

import functools
import hashlib
import importlib
import importlib.metadata
import json
import os
import sys
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import agents as agents_package
from agents.protocol import METHODS, Agent, BatchAgent, missing_methods
from agents.registry import (
    AGENTS,
    JAXPPO,
    ROLES,
    AgentContext,
    AgentSpec,
    agent_spec,
    register_agent,
)
from hri_bench.core.imports import import_class
from hri_bench.run import builtin_agents
from hri_bench.run.agent_host import ISOLATED_CONTRACT, isolated_keywords
from hri_bench.run.isolation import describe, make_isolated
from hri_envs.errors import ConfigError
from hri_envs.humans.protocol import BatchHuman
from hri_envs.humans.scripted import ScriptedHuman
from hri_envs.task.graph import TaskGraph
from hri_envs.task.scenarios import ScenarioSpec, as_graph, spec_of

__all__ = ["AGENTS", "CONTRACT", "DEFAULT_STUDY_AGENTS", "JAXPPO", "JAXPPO_CHECKPOINTS",
           "JAXPPO_PREFIX", "NAME_FORBIDDEN", "ROLES", "SB3_PREFIX", "AgentContext", "AgentForm",
           "AgentSpec", "Privilege", "agent_identity", "agent_name_problem", "agent_privilege",
           "agent_settings", "agent_spec", "contract_keywords", "import_agent", "jaxppo_path",
           "make_agent", "package_version", "register_agent", "resolve_agent", "source_identity",
           "validate_agent_name"]


#: The study's default agents (``hri-bench study --agents``): the paper's five, by value.
DEFAULT_STUDY_AGENTS: tuple[str, ...] = ("learner", "imitator", "maxent", "passive", "oracle")


def __getattr__(name: str) -> Any:
    """Views of the registry under the names they had before it (read when asked, so that
    agents registered since are in them): ``KNOWN_AGENTS`` (every name),
    ``REFERENCE_AGENTS`` (references planning for one shared human), ``BRACKET_AGENTS``
    (other references), ``PLANNING_REFERENCES`` (all references), ``BUILTIN_AGENTS`` (the
    study's default agents).
    """
    if name == "KNOWN_AGENTS":
        return tuple(AGENTS)
    if name == "PLANNING_REFERENCES":
        return tuple(a for a, s in AGENTS.items() if s.plans)
    if name == "REFERENCE_AGENTS":
        return tuple(a for a, s in AGENTS.items() if s.plans and s.shared_human)
    if name == "BRACKET_AGENTS":
        return tuple(a for a, s in AGENTS.items() if s.plans and not s.shared_human)
    if name == "BUILTIN_AGENTS":
        return DEFAULT_STUDY_AGENTS
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


#: Agent names ``sb3:PATH`` load a saved SB3 model.
SB3_PREFIX = "sb3:"
#: Agent names ``jaxppo:PATH`` load a recurrent PPO policy trained in JAX.
JAXPPO_PREFIX = "jaxppo:"
#: The shipped checkpoints, one ``<scenario>.npz`` per scenario (package data).
JAXPPO_CHECKPOINTS = Path(agents_package.__file__).parent / "jax_ppo" / "checkpoints"


def jaxppo_path(name: str) -> Path | None:
    """The checkpoint (file or folder) a ``jaxppo`` or ``jaxppo:PATH`` name plays; None for
    other names.
    """
    if name == JAXPPO:
        return JAXPPO_CHECKPOINTS
    if name.startswith(JAXPPO_PREFIX):
        return Path(name[len(JAXPPO_PREFIX):])
    return None


#: Characters an agent's name never holds: they break the leaderboard's Markdown tables
#: and HTML (besides ``,``, which separates ``--agents``).
NAME_FORBIDDEN = "|<>`"


def agent_name_problem(name: Any) -> str | None:
    """What is wrong with ``name`` as an agent's name in a results file or leaderboard
    (None: nothing): it is printable text of at most 300 characters, without
    :data:`NAME_FORBIDDEN` or surrounding spaces.
    """
    if not isinstance(name, str) or not name:
        return "an agent's name is a non-empty string"
    bad = sorted({c for c in name if c in NAME_FORBIDDEN or not c.isprintable()})
    if bad:
        return (f"agent name {name[:60]!r} holds {', '.join(map(repr, bad))}; a name is "
                f"printable text without {', '.join(NAME_FORBIDDEN)} (they break the "
                "leaderboard's tables) or line breaks")
    if name != name.strip() or len(name) > 300:
        return f"agent name {name[:60]!r} has surrounding spaces or over 300 characters"
    return None


@dataclass(frozen=True)
class AgentForm(AgentSpec):
    """An agent named by a form instead of registered (``sb3:PATH``, ``jaxppo[:PATH]``,
    ``module:Class``), made into an :class:`AgentSpec` by :func:`resolve_agent`.

    Attributes:
        kind: ``"sb3"``, ``"jaxppo"`` or ``"custom"``.
        identity: ``identity() -> dict``: how a results file names its code
            (:func:`agent_identity`).
    """

    kind: str = "custom"
    identity: Callable[[], dict[str, Any]] | None = None


def resolve_agent(name: str) -> AgentSpec:
    """The agent ``name`` stands for, as an :class:`AgentSpec`: the registered one, or an
    :class:`AgentForm` for ``sb3:PATH``, ``jaxppo[:PATH]`` and ``module:Class`` (module
    docstring). Every question about an agent (:func:`make_agent`, :func:`agent_privilege`,
    :func:`agent_settings`, :func:`agent_identity`) asks the spec this returns.

    For ``sb3:PATH`` the file must exist (its contents are checked when it is loaded); for
    ``module:Class`` its process imports the class (:func:`hri_bench.run.isolation.describe`),
    which must subclass :class:`~agents.protocol.Agent` or :class:`~agents.protocol.BatchAgent`
    and implement every method of the protocol (:data:`agents.protocol.METHODS`), so a study
    refuses it before simulating.

    Raises:
        ConfigError: ``name`` is no agent, or not a name a leaderboard can show
            (:func:`agent_name_problem`); the message names the allowed agents
            (``field="agents"``).
    """
    spec = AGENTS.find(name)
    if spec is not None:
        return spec
    problem = agent_name_problem(name)
    if problem is not None:
        raise ConfigError(problem, field="agents")
    if name.startswith(SB3_PREFIX):
        model = Path(name[len(SB3_PREFIX):])
        if not model.is_file():
            raise ConfigError(f"agent {name!r}: no SB3 model file at {str(model)!r}; give "
                              "'sb3:PATH' with the .zip written by model.save()", field="agents")
        return AgentForm(name, functools.partial(_make_sb3, str(model)),
                         settings=functools.partial(_file_settings, model), kind="sb3",
                         identity=functools.partial(_sb3_identity, model))
    path = jaxppo_path(name)
    if path is not None:
        if not (path.is_file() or path.is_dir()):  # the folder's file: when it is loaded
            raise ConfigError(f"agent {name!r}: no JAX PPO checkpoint at {str(path)!r}; give "
                              "'jaxppo:FILE.npz' or 'jaxppo:FOLDER' holding <scenario>.npz",
                              field="agents")
        return AgentForm(name, functools.partial(_make_jaxppo, path),
                         settings=functools.partial(_file_settings, path), kind="jaxppo",
                         identity=functools.partial(_jaxppo_identity, path))
    if ":" in name and all(name.split(":", 1)):
        info = describe(name)  # in its own process: nothing of it runs in this one
        identity = functools.partial(_isolated_identity, name)
        return AgentForm(name, functools.partial(_make_isolated, name),
                         intention_blind=not info["privileged"],
                         settings=lambda *_: identity(), kind="custom", identity=identity)
    raise ConfigError(
        f"unknown agent {name!r}; allowed: {', '.join(AGENTS)}, "
        "'sb3:PATH' for a saved stable-baselines3 model, 'jaxppo' or 'jaxppo:PATH' for a "
        "JAX PPO policy, "
        "or 'module:Class' for your own agent",
        field="agents",
    )


def validate_agent_name(name: str) -> None:
    """Raise a :class:`~hri_envs.errors.ConfigError` naming the allowed agents unless
    ``name`` is one (:func:`resolve_agent`).
    """
    resolve_agent(name)


def _make_sb3(path: str, ctx: AgentContext) -> BatchAgent:
    from agents.sb3 import SB3BatchAgent  # the rl extra (stable-baselines3, torch)

    return SB3BatchAgent(path, len(ctx.runs), graph=ctx.graph, seed=ctx.seed, runs=ctx.runs)


def _make_jaxppo(path: Path, ctx: AgentContext) -> BatchAgent:
    from agents.jax_ppo.agent import JaxPPOAgent  # the jax extra

    return JaxPPOAgent(path, ctx.graph, len(ctx.runs))


def _make_isolated(name: str, ctx: AgentContext) -> BatchAgent:
    settings = {"r0": ctx.r0, "reward": ctx.reward, "max_steps": ctx.max_steps,
                "episodes": ctx.episodes}
    return make_isolated(name, ctx.graph, ctx.seed, ctx.runs, settings)


def _file_settings(path: Path, *_: Any) -> dict[str, Any]:
    """A model's settings in ``summary.json``: its path and size."""
    return {"path": str(path), "bytes": path.stat().st_size if path.is_file() else None}


def import_agent(spec: str) -> type[Agent] | type[BatchAgent]:
    """The agent class ``module:Class`` names.

    Raises:
        ConfigError: The module does not import, the class is not an agent, or it leaves a
            method of the protocol unimplemented (``field="agents"``).
    """
    cls: type[Agent] | type[BatchAgent] = import_class(spec, "agent", "agents",
                                                       (Agent, BatchAgent))
    missing = missing_methods(cls)
    if missing:  # refused now, not when the first run makes it (mid-study, in a worker)
        raise ConfigError(f"agent {spec!r} does not implement {', '.join(missing)} of the agent "
                          f"protocol ({', '.join(METHODS)}; docs/agents.md, \"Your own "
                          "agent\")", field="agents")
    return cls



#: What a custom agent's constructor may ask for, by keyword (docs/agents.md, "Your own
#: agent"): :data:`hri_bench.run.agent_host.ISOLATED_CONTRACT`. It is never told the study's
#: seed, its runs or their humans (:data:`~hri_bench.run.agent_host.WITHHELD`).
CONTRACT: dict[str, str] = ISOLATED_CONTRACT
#: The :data:`CONTRACT` keywords a class's constructor is given
#: (:func:`hri_bench.run.agent_host.isolated_keywords`).
contract_keywords = isolated_keywords


@dataclass(frozen=True)
class Privilege:
    """What an agent sees besides the robot's view, from what it declares.

    Attributes:
        sees_intention: It is handed ι (a registered agent whose ``intention_blind`` is
            False; a ``module:Class`` whose class sets ``privileged = True``).
        knows_human: It is handed the human's model (a registered agent that ``plans``).
    """

    sees_intention: bool
    knows_human: bool

    @property
    def reference(self) -> bool:
        """Whether a suite shows it as a reference, never ranked among learners."""
        return self.sees_intention or self.knows_human


def agent_privilege(name: str) -> Privilege:
    """What agent ``name`` sees (:class:`Privilege`): a registered agent's
    :class:`AgentSpec` fields, a ``module:Class``'s ``privileged`` attribute as its process
    reads it (:func:`hri_bench.run.isolation.describe`); ``sb3:PATH`` and ``jaxppo[:PATH]``
    see the robot's view only.

    Raises:
        ConfigError: ``name`` is not an agent (:func:`resolve_agent`).
    """
    spec = resolve_agent(name)
    return Privilege(not spec.intention_blind, spec.plans)


def agent_settings(name: str, scenario: ScenarioSpec | TaskGraph | str, r0: float,
                   learner: dict[str, Any] | None = None) -> dict[str, Any] | None:
    """The settings :func:`make_agent` gives agent ``name`` on ``scenario`` (its spec or task
    graph, or a registered scenario's name, resolved here) (for ``summary.json``).

    The Learner and plain ME-IRL: their :class:`~agents.config.LearnerConfig` as a dict;
    ``countqmdp``: its parameters (:meth:`~baselines.countqmdp.CountQMDP.defaults`, but
    the reward rule, which is the study's);
    ``sb3:PATH``, ``jaxppo[:PATH]``: the model's path and size; ``module:Class``: its code identity
    (:func:`agent_identity`: its source files' sha256 and the
    constructor keywords it is given); the other agents: None (they have none).
    """
    spec = resolve_agent(name)
    if spec.settings is None:
        return None
    return spec.settings(spec_of(as_graph(scenario)), r0, learner or {})


def make_agent(
    name: str,
    graph: TaskGraph,
    human: ScriptedHuman | BatchHuman,
    runs: Sequence[int],
    *,
    seed: int,
    r0: float,
    learner: dict[str, Any] | None = None,
    max_steps: int = 100,
    reward: str = "paper",
    episodes: int = 1,
) -> BatchAgent:
    """A batched agent for the given runs.

    Args:
        name: See the module docstring.
        graph: The task graph.
        human: The scripted human, or the benchmark's humans per run (the Oracle copies
            their preferred actions).
        runs: Run indices of the batch (randomness derives from ``(seed, run)``).
        seed: Base seed.
        r0: The study's waiting reward, used by the Learner's robot reward (and the goal
            filter's and ``countqmdp``'s).
        learner: Changes to the Learner's :class:`~agents.config.LearnerConfig` (after the
            scenario's defaults and ``r0``); other agents ignore them.
        max_steps: The step limit (the horizon of ``informed`` and ``blind``).
        reward: The reward variant ``informed``, ``blind`` and ``countqmdp`` optimise.
        episodes: Episodes per run (the horizon of ``informed`` and ``qmdp`` for humans
            who remember across episodes).
    """
    return resolve_agent(name).make(AgentContext(
        graph, human, tuple(int(r) for r in runs), seed, r0, dict(learner or {}), max_steps,
        reward, episodes))


def _sha256(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


def _combined(hashes: dict[str, str]) -> str:
    """One sha256 for several files, from their names and hashes."""
    return hashlib.sha256(json.dumps(hashes, sort_keys=True).encode()).hexdigest()


def package_version(package: str) -> str | None:
    """The installed version of distribution ``package`` (None: not installed)."""
    try:
        return importlib.metadata.version(package)
    except importlib.metadata.PackageNotFoundError:
        return None


def _source_files(module_name: str) -> tuple[Path, list[Path]]:
    """(root, files): every ``.py`` file of the module's top-level package (or the module's
    own file when it is in none), with the folder their names are given relative to.
    """
    module = sys.modules.get(module_name) or importlib.import_module(module_name)
    top = module_name.split(".")[0]
    top_file = getattr(sys.modules.get(top) or importlib.import_module(top), "__file__", None)
    if top_file is not None and Path(top_file).name == "__init__.py":
        package = Path(top_file).parent
        return package.parent, sorted(p for p in package.rglob("*.py") if p.is_file())
    path = getattr(module, "__file__", None)
    return (Path("."), []) if path is None else (Path(path).parent, [Path(path)])


def _unimported_files(module_name: str) -> tuple[Path, list[Path]]:
    """:func:`_source_files` found on ``sys.path`` without importing (running) anything."""
    import importlib.machinery

    parts = module_name.split(".")
    # where the agent's own process finds it: the environment, then the current folder
    # (hri_envs.imports), which this process has not put on its path
    here = os.getcwd()
    path: list[str] | None = [*sys.path, *([] if here in sys.path or "" in sys.path else [here])]
    found = []
    for i in range(len(parts)):
        spec = importlib.machinery.PathFinder.find_spec(".".join(parts[:i + 1]), path)
        if spec is None:
            raise ConfigError(f"cannot find module {module_name!r} on the path", field="agents")
        found.append(spec)
        path = list(spec.submodule_search_locations or [])
    top = found[0]
    if top.origin and Path(top.origin).name == "__init__.py":
        package = Path(top.origin).parent
        return package.parent, sorted(p for p in package.rglob("*.py") if p.is_file())
    origin = found[-1].origin
    return (Path("."), []) if not origin else (Path(origin).parent, [Path(origin)])


def agent_identity(name: str) -> dict[str, Any]:
    """How agent ``name`` of a study is identified (module docstring)."""
    spec = resolve_agent(name)
    if isinstance(spec, AgentForm) and spec.identity is not None:
        return spec.identity()
    if spec.make.__module__ == builtin_agents.__name__:  # shipped
        return {"kind": "builtin", "package": "hri-envs", "version": package_version("hri-envs")}
    # registered by a package of the user's: its maker's source
    root, files = _source_files(spec.make.__module__)
    hashes = {p.relative_to(root).as_posix(): _sha256(p) for p in files}
    return {"kind": "custom", "module": spec.make.__module__, "class": f"registered:{name}",
            "files": hashes, "code_sha256": _combined(hashes), "constructor": []}


def _sb3_identity(path: Path) -> dict[str, Any]:
    return {"kind": "sb3", "path": str(path), "sha256": _sha256(path) if path.is_file() else None}


def _jaxppo_identity(model: Path) -> dict[str, Any]:
    """A checkpoint file, or a folder of ``<scenario>.npz``: their combined hash."""
    files = sorted(p for p in model.rglob("*") if p.is_file()) if model.is_dir() else (
        [model] if model.is_file() else [])
    hashes = {p.relative_to(model).as_posix() if model.is_dir() else p.name: _sha256(p)
              for p in files}
    return {"kind": "jaxppo", "path": str(model), "sha256": _combined(hashes) if hashes else None}


def _isolated_identity(name: str) -> dict[str, Any]:
    info = describe(name)  # its process imports it; this one only reads its files
    root, files = _unimported_files(info["module"])
    hashes = {p.relative_to(root).as_posix(): _sha256(p) for p in files}
    return {"kind": "custom", "module": info["module"], "class": info["class"],
            "files": hashes, "code_sha256": _combined(hashes),
            "constructor": list(info["keywords"])}


def source_identity(module_name: str) -> dict[str, Any]:
    """``files`` (each ``.py`` file of the module's package and its sha256, found on the path
    without importing anything) and ``code_sha256`` (one hash of them all): how a results
    file names the code of an agent of your own.
    """
    root, files = _unimported_files(module_name)
    hashes = {p.relative_to(root).as_posix(): _sha256(p) for p in files}
    return {"files": hashes, "code_sha256": _combined(hashes)}
