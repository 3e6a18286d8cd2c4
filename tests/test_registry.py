"""One registry pattern for every kind (hri_envs/registry.py, docs/extending.md): register
returns the spec and runs the kind's check, a name is refused twice unless replaced, and an
unknown name raises a ConfigError naming the registered ones."""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import pytest

from agents.registry import AGENTS, AgentSpec, register_agent
from hri_envs.envs.backends import BACKENDS, BackendSpec, register_backend
from hri_envs.errors import ConfigError
from hri_envs.humans.families import FAMILIES, Family, register_family
from hri_envs.humans.spec import POPULATION_KINDS, PopulationKind, register_population_kind
from hri_envs.registry import Registry
from hri_envs.task.episode import REWARD_RULES, RewardRule, register_reward_rule
from hri_envs.task.scenarios import SCENARIOS, register_scenario


@dataclass(frozen=True)
class _Thing:
    name: str
    size: int = 1


def _positive(thing: _Thing) -> None:
    if thing.size <= 0:
        raise ConfigError(f"thing {thing.name!r}: size must be > 0", field="thing")


def test_register_checks_returns_and_refuses_a_name_twice_unless_replaced():
    things: Registry[_Thing] = Registry("thing", _Thing, field="thing", check=_positive)
    a = _Thing("a")
    assert things.register(a) is a and things.get("a") is a and things["a"] is a
    assert things.register(_Thing("a")) == a  # an equal spec again: nothing changes
    with pytest.raises(ConfigError, match="'a' is registered already.*replace=True") as err:
        things.register(_Thing("a", 2))
    assert err.value.field == "thing" and things.get("a") == a
    b = things.register(_Thing("a", 2), replace=True)
    assert things.get("a") is b
    with pytest.raises(ConfigError, match="size must be > 0"):
        things.register(_Thing("c", 0))
    with pytest.raises(ConfigError, match="size must be > 0"):  # replace checks too
        things.register(_Thing("a", 0), replace=True)
    assert "c" not in things and things.get("a") is b
    with pytest.raises(ConfigError, match="registered as a _Thing with a name"):
        things.register("a")
    with pytest.raises(ConfigError, match="with a name"):
        things.register(_Thing(""))
    things.register(_Thing("z"))
    assert things.names() == ("a", "z") == tuple(things) and len(things) == 2
    assert things.items() == [("a", b), ("z", _Thing("z"))]
    with pytest.raises(ConfigError, match="unknown thing 'q'; allowed: a, z") as err:
        things.get("q")
    assert err.value.field == "thing"
    assert things.find("q") is None and things.find(3) is None and 3 not in things
    assert things.unregister("z") == _Thing("z") and things.names() == ("a",)


# Every kind, its registry and a spec of it: register_X(spec) is the registry's register.
def _kinds():
    from tests import scenario_box

    return [
        ("scenario", SCENARIOS, register_scenario, scenario_box.SPEC, "gamma", 0.5),
        ("backend", BACKENDS, register_backend,
         BackendSpec("test-kind", "hri_envs.envs.episode:Episode",
                     "hri_envs.envs.backends:GraphBatch"), "extra", "x"),
        ("human family", FAMILIES, register_family,
         Family("test-kind", "scripted", lambda graph, *, k=1: None, "a test family"),
         "description", "another"),
        ("reward", REWARD_RULES, register_reward_rule,
         RewardRule("test-kind", "a test rule"), "description", "another"),
        ("agent", AGENTS, register_agent,
         AgentSpec("test-kind", lambda context: None), "description", "another"),
        ("population kind", POPULATION_KINDS, register_population_kind,
         PopulationKind("test-kind:", "a test kind", lambda name, graph: None),
         "description", "another"),
    ]


@pytest.mark.parametrize("index", range(6), ids=["scenario", "backend", "family", "reward",
                                                 "agent", "population-kind"])
def test_every_kind_registers_by_the_one_pattern(index):
    kind, registry, register, spec, field, other = _kinds()[index]
    assert isinstance(registry, Registry) and registry.kind == kind
    name = getattr(spec, registry.key)
    assert name not in registry
    try:
        assert register(spec) is spec and registry.get(name) is spec
        assert register(spec) is spec  # again, equal: accepted
        changed = dataclasses.replace(spec, **{field: other})
        with pytest.raises(ConfigError, match="registered already") as err:
            register(changed)
        assert err.value.field == registry.field and registry.get(name) is spec
        assert register(changed, replace=True) is changed and registry.get(name) is changed
        with pytest.raises(ConfigError, match=f"unknown {kind} 'no-such'; allowed: .*{name}"):
            registry.get("no-such")
        with pytest.raises(ConfigError):
            register(object())
    finally:
        if name in registry:
            registry.unregister(name)


def test_each_kind_runs_its_own_check_on_register():
    with pytest.raises(ConfigError, match="group 'odd' is not one of"):
        register_family(Family("odd-one", "odd", lambda graph: None, "?"))
    with pytest.raises(ConfigError, match="role 'star' is not one of"):
        register_agent(AgentSpec("odd-one", lambda context: None, role="star"))
    with pytest.raises(ConfigError, match="taken by a form of its own"):
        register_agent(AgentSpec("my:agent", lambda context: None))
    with pytest.raises(ConfigError, match="batch must be a 'module:name' entry point"):
        register_backend(BackendSpec("odd-one", "hri_envs.envs.episode:Episode", "GraphBatch"))
    with pytest.raises(ConfigError, match="presets but no options checker"):
        register_backend(BackendSpec("odd-one", "hri_envs.envs.episode:Episode",
                                     "hri_envs.envs.backends:GraphBatch", presets=("p",)))
    with pytest.raises(ConfigError, match="prefix ends with ':'"):
        register_population_kind(PopulationKind("odd", "?", lambda name, graph: None))
    from tests import scenario_box

    with pytest.raises(ConfigError, match="n_actions"):
        register_scenario(dataclasses.replace(scenario_box.SPEC, name="odd-one", n_actions=3))
    for registry in (FAMILIES, AGENTS, BACKENDS, POPULATION_KINDS, SCENARIOS):
        assert "odd-one" not in registry and "my:agent" not in registry and "odd" not in registry


def test_an_unknown_agent_name_raises_as_every_kind_does():
    from hri_bench.run.agents import agent_spec  # the built-ins registered

    with pytest.raises(ConfigError, match="unknown agent 'nobody'; allowed: .*learner") as err:
        agent_spec("nobody")
    assert err.value.field == "agents"


def test_the_benchmark_re_exports_the_agents_registry():
    import agents.registry
    from hri_bench.run import agents as bench_agents

    for name in ("AGENTS", "AgentSpec", "AgentContext", "register_agent", "agent_spec",
                 "JAXPPO", "ROLES"):
        assert getattr(bench_agents, name) is getattr(agents.registry, name)


def test_a_public_function_resolves_a_users_scenario_name_once_and_passes_objects_through():
    """Issue 42: as_graph / as_spec are the one resolution at a public function's top: a
    graph or spec passes through as it is (an unregistered spec too), a name is looked up."""
    from hri_envs.task.scenarios import as_graph, as_spec, scenario_graph

    graph = scenario_graph("wheel")
    spec = SCENARIOS["wheel"]
    assert as_graph(graph) is graph and as_graph(spec) is graph and as_graph("wheel") is graph
    assert as_spec(spec) is spec and as_spec(graph) is spec and as_spec("wheel") is spec
    odd = dataclasses.replace(spec, name="unregistered-wheel")
    assert as_spec(odd) is odd and as_graph(odd).spec is odd and as_graph(odd) is not graph
    for resolve in (as_graph, as_spec):
        with pytest.raises(ConfigError, match="hanger, wheel") as err:
            resolve("kitchen")
        assert err.value.field == "scenario"
