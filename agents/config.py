"""Validated parameters of the Learner and the plain ME-IRL baseline."""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from typing import Any

from hri_envs.errors import ConfigError
from hri_envs.task.scenarios import SCENARIOS, scenario_spec

__all__ = ["LearnerConfig", "default_config"]


@dataclass(frozen=True)
class LearnerConfig:
    """Parameters of Algorithm 1 (paper Sect. 5 values as defaults, see :func:`default_config`).

    Attributes:
        learning_rate: λ, the ME-IRL step size.
        robot_temperature: τ_R of the robot's soft-max.
        eta: η, the robot's relative probability bound.
        human_temperature: τ_H of the human policy estimate.
        beta: Intention bias β of the Bayes filter, in [1/n, 1].
        gamma: Discount of every Q-iteration (0.9 hanger, 0.6 wheel).
        r0: Robot reward for waiting while the human acts, in (-1, 0).
        irl_temperature: Demonstrator temperature inside the ME-IRL expectation. The paper
            is silent; its published code uses 1 (a near-uniform demonstrator given
            |θ| ≤ 1), which we keep as the default.
        robot_model_temperature: Temperature of the robot policy the human model assumes
            (T_H); the paper's code uses the robot's own τ_R.
        passive_prior: Keep the passive baseline's action in the bounded soft-max (the
            paper's only prior, Sect. 7); False: the bound is ``η · max_a p(a)`` alone (the
            paper's "without it" variant).
        initial_preference: Start from another preference (paper Sect. 7): before the first
            episode the human model makes :attr:`pretrain_passes` ME-IRL passes over the
            named preference's demonstrated routes, one per (start, goal) pair; None: θ⁰.
        pretrain_passes: Passes over those demonstrations, >= 1.
    """

    learning_rate: float = 0.1
    robot_temperature: float = 5.0
    eta: float = 0.9
    human_temperature: float = 25.0
    beta: float = 0.95
    gamma: float = SCENARIOS["hanger"].gamma  # the class defaults are the hanger's
    r0: float = SCENARIOS["hanger"].r0
    irl_temperature: float = 1.0
    robot_model_temperature: float = 5.0
    passive_prior: bool = True
    initial_preference: str | None = None
    pretrain_passes: int = 3

    def __post_init__(self) -> None:
        checks = [
            ("learning_rate", self.learning_rate > 0, "> 0"),
            ("robot_temperature", self.robot_temperature > 0, "> 0"),
            ("eta", 0.0 <= self.eta <= 1.0, "in [0, 1]"),
            ("human_temperature", self.human_temperature > 0, "> 0"),
            ("beta", 0.0 < self.beta <= 1.0, "in (0, 1] (the paper uses 0.95)"),
            ("gamma", 0.0 <= self.gamma < 1.0, "in [0, 1)"),
            ("r0", -1.0 < self.r0 < 0.0, "in (-1, 0)"),
            ("irl_temperature", self.irl_temperature > 0, "> 0"),
            ("robot_model_temperature", self.robot_model_temperature > 0, "> 0"),
            ("passive_prior", isinstance(self.passive_prior, bool), "True or False"),
            ("pretrain_passes", isinstance(self.pretrain_passes, int)
             and self.pretrain_passes >= 1, "a whole number >= 1"),
        ]
        for name, ok, allowed in checks:
            if not ok:
                raise ConfigError(f"{name} must be {allowed}, got {getattr(self, name)!r}",
                                  field=name)

    def replace(self, **changes: Any) -> LearnerConfig:
        """A copy with some fields changed (validated)."""
        names = {f.name for f in dataclasses.fields(self)}
        unknown = set(changes) - names
        if unknown:
            raise ConfigError(f"unknown parameter(s) {sorted(unknown)}; allowed: {sorted(names)}",
                              field=sorted(unknown)[0])
        return dataclasses.replace(self, **changes)

    def to_dict(self) -> dict[str, float | bool | str | None]:
        """Plain dict, for JSON."""
        return dataclasses.asdict(self)


def default_config(scenario: str, **changes: Any) -> LearnerConfig:
    """The paper's parameters for a scenario (γ and r0 from its
    :class:`~hri_envs.task.scenarios.ScenarioSpec`: hanger γ = 0.9, r0 = -0.33; wheel
    γ = 0.6, r0 = -0.25), with optional changes.
    """
    spec = scenario_spec(scenario)
    pref = changes.get("initial_preference")
    if pref is not None and pref not in spec.preferences:
        raise ConfigError(f"initial_preference must be None or one of the {scenario} "
                          f"preferences ({', '.join(spec.preferences[:3])}, ...), got {pref!r}",
                          field="initial_preference")
    return LearnerConfig(gamma=spec.gamma, r0=spec.r0).replace(**changes)
